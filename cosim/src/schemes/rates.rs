//! Multi-rate systems: each unit steps at its own period, a whole multiple `m` of the base
//! macro step h (libcosim's decimation factor).
//!
//! A unit of period `m·h` steps from `t₀` to `t₀ + m·h` in the base step that ends at
//! `t₀ + m·h`, together with the units whose steps end there too; between its steps its outputs
//! hold. What one base step couples:
//! * an input whose source is slower than its unit holds the source's outputs from its last
//!   communication point at or before the step's start — a zero-order hold, in every scheme, so
//!   that a slower unit's new outputs reach the others from its communication point on;
//! * an input whose unit and source step in this base step, the source no slower, is coupled as
//!   in a single-rate system: the outputs at the base step's start (Jacobi), the newest
//!   (Gauss–Seidel), or iterated to the end of the step (the iterating schemes' unknowns);
//! * an input whose source does not step holds its outputs; a unit that does not step takes no
//!   inputs.
//!
//! With every multiple 1 every unit steps and every input is an unknown: the single-rate system.

use crate::system::Layout;

pub(super) struct Rates {
    /// Per unit, its period in base steps.
    multiple: Vec<u32>,
    /// Per input, the unit that takes it and the unit whose output feeds it.
    taker: Vec<usize>,
    giver: Vec<usize>,
    /// Base steps completed.
    pub(super) done: u64,
    /// Per unit: it steps in the base step being taken.
    pub(super) stepping: Vec<bool>,
    /// Per input: an unknown of the base step being taken.
    pub(super) iterated: Vec<bool>,
    /// Per input: its source is slower than its unit (held, never the newest).
    pub(super) from_slower: Vec<bool>,
    /// Per unit: some input this step iterates takes its outputs (else IJCSA's block of it is
    /// never read: a sink, or a slower unit whose outputs hold).
    pub(super) feeds_iterated: Vec<bool>,
}

impl Rates {
    /// Every unit at the base step.
    pub(super) fn single(layout: &Layout) -> Rates {
        let (n, nu) = (layout.units.len(), layout.inputs());
        let taker = (0..nu).map(|i| layout.units.iter().position(|u| u.inputs.contains(&i)).unwrap_or(0)).collect();
        let giver: Vec<usize> = (0..nu).map(|i| layout.owner_of_output(layout.source[i]).unwrap_or(0)).collect();
        let feeds_iterated = (0..n).map(|k| giver.contains(&k)).collect();
        Rates {
            multiple: vec![1; n],
            taker,
            giver,
            done: 0,
            stepping: vec![true; n],
            iterated: vec![true; nu],
            from_slower: vec![false; nu],
            feeds_iterated,
        }
    }

    /// Sets each unit's period in base steps (each at least 1, one per unit).
    pub(super) fn set(&mut self, multiple: &[u32]) -> Result<(), String> {
        if multiple.len() != self.multiple.len() {
            return Err(format!("{} periods for {} units", multiple.len(), self.multiple.len()));
        }
        if let Some(k) = multiple.iter().position(|&m| m == 0) {
            return Err(format!("unit {k}: a period of 0 base steps"));
        }
        self.multiple.copy_from_slice(multiple);
        for i in 0..self.taker.len() {
            self.from_slower[i] = self.multiple[self.giver[i]] > self.multiple[self.taker[i]];
        }
        Ok(())
    }

    /// Whether some unit steps at a longer period than the base step.
    pub(super) fn is_multi(&self) -> bool {
        self.multiple.iter().any(|&m| m > 1)
    }

    /// Whether input `i` holds a slower unit's outputs (its source steps at a multiple above 1):
    /// piecewise constant, never extrapolated.
    pub(super) fn held(&self, i: usize) -> bool {
        self.multiple[self.giver[i]] > 1
    }

    /// The units that step in the next base step, and the inputs it iterates.
    pub(super) fn begin(&mut self) {
        if !self.is_multi() {
            return;
        }
        let end = self.done + 1;
        for (s, &m) in self.stepping.iter_mut().zip(&self.multiple) {
            *s = end.is_multiple_of(u64::from(m));
        }
        self.feeds_iterated.fill(false);
        for i in 0..self.taker.len() {
            self.iterated[i] = self.stepping[self.taker[i]] && self.stepping[self.giver[i]] && !self.from_slower[i];
            if self.iterated[i] {
                self.feeds_iterated[self.giver[i]] = true;
            }
        }
    }

    /// Unit `k`'s step in the base step from `t` of size `h`: its start and size.
    pub(super) fn window(&self, k: usize, t: f64, h: f64) -> (f64, f64) {
        match self.multiple[k] {
            1 => (t, h),
            m => {
                let size = f64::from(m) * h;
                (t + h - size, size)
            }
        }
    }
}
