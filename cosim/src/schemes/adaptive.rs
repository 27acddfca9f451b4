//! The adaptive macro step of the implicit schemes ([`crate::adaptive`]): the estimate watches
//! the coupled inputs `U` (the interface's values at the communication points), and a rejected
//! step is rolled back bit for bit — FMU states, coupled values, extrapolation and quasi-Newton
//! history.

use super::{Core, Coupled, StepReport};
use crate::adaptive::{self, Accepted, Retake};
use crate::error::SetupError;
use crate::error::StepError;
use crate::error_estimate::{ErrorEstimate, Kind};
use crate::step_control::{Controller, Tolerances};
use crate::system::spec::prefix_rest;
use crate::system::{Layout, Slot, Units};

/// One accepted adaptive step.
pub type AdaptiveStep = Accepted<StepReport>;

/// A quantity the adaptive step watches: a coupled input (index into `U`) or an output (into `Y`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(super) enum Watched {
    Input(usize),
    Output(usize),
}

/// What a rollback restores besides the units' states and the scheme's own state (IQN-ILS's
/// history, IJCSA's reused Jacobian: [`super::CouplingScheme::keep`]): the time, the coupled
/// values and the extrapolation history.
pub(super) struct Restorable {
    time: f64,
    /// Base steps completed (a multi-rate system's schedule).
    done: u64,
    y: Vec<f64>,
    y_prev: Vec<f64>,
    prev_step: Option<f64>,
}

impl Restorable {
    fn new(ny: usize) -> Restorable {
        Restorable { time: 0.0, done: 0, y: vec![0.0; ny], y_prev: vec![0.0; ny], prev_step: None }
    }
}

/// The adaptive step's estimate, what it watches, and what its rollbacks restore.
pub(super) struct History {
    pub(super) estimate: ErrorEstimate,
    /// What the estimate watches, and their groups (numbered from 0) and scales.
    pub(super) watched: Vec<Watched>,
    pub(super) group: Vec<usize>,
    pub(super) scale: Vec<f64>,
    /// Before the last step (for [`Slot::Step`]) and at the checkpoint ([`Slot::Checkpoint`]).
    before_step: Restorable,
    checkpoint: Restorable,
}

impl History {
    /// Watching every coupled input of `layout`.
    pub(super) fn new(layout: &Layout) -> History {
        let (n, ny) = (layout.inputs(), layout.outputs());
        History {
            estimate: ErrorEstimate::new(n),
            watched: (0..n).map(Watched::Input).collect(),
            group: layout.group.clone(),
            scale: layout.scale.clone(),
            before_step: Restorable::new(ny),
            checkpoint: Restorable::new(ny),
        }
    }
}

impl<S: Units> Coupled<S> {
    /// The adaptive step judges its error by the quantities named in `names` only (each a
    /// `unit.variable`, or a prefix of such names ending before a `.` or `[`, as
    /// `stewart.cabin.v` for `stewart.cabin.v[1]` … `[3]`): the coupled inputs it names, or if it
    /// names none, the outputs in `Y` (those connections carry, and those the system reads
    /// besides, e.g. [`crate::SystemSpec::observed`]); every coupled input if `names` is empty.
    /// Call before the first step.
    pub fn watch(&mut self, names: &[String]) -> Result<(), SetupError> {
        let l = self.core.units.layout();
        let named = |candidate: &str, name: &str| prefix_rest(candidate, name).is_some();
        let mut watched = Vec::new();
        for name in names {
            let inputs = (0..l.inputs()).filter(|&i| named(&l.input_names[i], name)).map(Watched::Input);
            let mut found: Vec<Watched> = inputs.collect();
            if found.is_empty() {
                found = (0..l.outputs()).filter(|&j| named(&l.output_names[j], name)).map(Watched::Output).collect();
            }
            if found.is_empty() {
                let list = |names: &[String]| names.iter().map(|n| format!("`{n}`")).collect::<Vec<_>>().join(", ");
                return Err(SetupError::Invalid(format!(
                    "watched quantity `{name}` is neither a coupled input or output nor a prefix of one ending \
                     before a `.` or `[`; the coupled inputs are {}; the outputs read are {}",
                    list(&l.input_names),
                    list(&l.output_names)
                )));
            }
            for w in found {
                if !watched.contains(&w) {
                    watched.push(w);
                }
            }
        }
        if names.is_empty() {
            watched = (0..l.inputs()).map(Watched::Input).collect();
        }
        watched.sort_unstable();
        // inputs in their unit groups; an output's components (`x[1]`, `x[2]`, …) form a group
        #[derive(PartialEq)]
        enum Key<'a> {
            Input(usize),
            Output(&'a str),
        }
        let key = |w: &Watched| match *w {
            Watched::Input(i) => Key::Input(l.group[i]),
            Watched::Output(j) => Key::Output(l.output_names[j].split('[').next().unwrap_or_default()),
        };
        let keys: Vec<Key> = watched.iter().map(key).collect();
        let values: Vec<f64> = watched
            .iter()
            .map(|w| match *w {
                Watched::Input(i) => l.scale[i],
                Watched::Output(j) => self.core.y[j],
            })
            .collect();
        let output_scales = Layout::group_scales(&values, &keys);
        let a = &mut self.adaptive;
        a.group = Layout::groups(&keys);
        a.scale = watched
            .iter()
            .zip(output_scales)
            .map(|(w, s)| match *w {
                Watched::Input(i) => l.scale[i],
                Watched::Output(_) => s,
            })
            .collect();
        a.estimate = ErrorEstimate::of_kind(a.estimate.kind(), watched.len());
        a.watched = watched;
        Ok(())
    }

    /// How the adaptive step estimates its error (the predictor by default). Call before the
    /// first step.
    pub fn estimate_by(&mut self, kind: Kind) {
        let a = &mut self.adaptive;
        a.estimate = ErrorEstimate::of_kind(kind, a.watched.len());
    }

    /// One accepted step of the adaptive macro step, ending at most at `t_stop`: tries the
    /// controller's step, estimates its error, and rolls every unit back bit for bit to retry a
    /// smaller step until one is accepted.
    pub fn step_adaptive(
        &mut self,
        ctl: &mut Controller,
        tol: Tolerances,
        t_stop: f64,
    ) -> Result<AdaptiveStep, StepError> {
        if !self.core.options.scheme.is_implicit() {
            return Err(self.core.failed(
                self.core.time,
                format!(
                    "the adaptive step needs an implicit scheme (iterative, ijcsa, iqn-ils), not {}",
                    self.core.options.scheme.name()
                ),
            ));
        }
        if self.core.rates.is_multi() {
            return Err(self.core.failed(
                self.core.time,
                "the adaptive step does not take a multi-rate system (a unit stepping at a multiple of the macro step \
                 above 1): its units' periods are whole multiples of one fixed step; run it at a fixed step",
            ));
        }
        // the estimate lives beside the units it judges; lent to the step for its duration
        let mut estimate = std::mem::replace(&mut self.adaptive.estimate, ErrorEstimate::new(0));
        let t = self.core.time;
        let result = adaptive::step(self, &mut estimate, ctl, tol, t, t_stop);
        self.adaptive.estimate = estimate;
        result
    }

    /// Keeps what a rollback to `slot` restores besides the units' states (the schemes save
    /// those for [`Slot::Step`] at the start of every step; [`Coupled::checkpoint`] for
    /// [`Slot::Checkpoint`]): the coupled values and the scheme's own state.
    pub(super) fn keep(&mut self, slot: Slot) {
        let Coupled { adaptive, core, scheme } = self;
        let r = match slot {
            Slot::Step => &mut adaptive.before_step,
            Slot::Checkpoint => &mut adaptive.checkpoint,
        };
        r.time = core.time;
        r.done = core.rates.done;
        r.y.copy_from_slice(&core.y);
        r.y_prev.copy_from_slice(&core.y_prev);
        r.prev_step = core.prev_step;
        scheme.keep(slot);
    }

    /// Goes back to `slot`: every unit to the state saved there, bit for bit, and what
    /// [`Coupled::keep`] kept.
    pub(super) fn roll_back(&mut self, slot: Slot) -> Result<(), StepError> {
        let Coupled { adaptive, core, scheme } = self;
        let r = match slot {
            Slot::Step => &adaptive.before_step,
            Slot::Checkpoint => &adaptive.checkpoint,
        };
        core.restore_states(r.time, slot)?;
        let Core { time, y, y_prev, prev_step, rates, .. } = core;
        *time = r.time;
        rates.done = r.done;
        y.copy_from_slice(&r.y);
        y_prev.copy_from_slice(&r.y_prev);
        *prev_step = r.prev_step;
        scheme.roll_back(slot);
        Ok(())
    }

    /// Saves every unit's state and the coupled values into the checkpoint slot: the adaptive
    /// step's step doubling comes back there over more than one step.
    pub(super) fn checkpoint(&mut self) -> Result<(), StepError> {
        let core = &mut self.core;
        for k in 0..core.units.layout().units.len() {
            if let Err(e) = core.units.save_state(k, Slot::Checkpoint) {
                return Err(core.unit_err(core.time, k, e));
            }
        }
        self.keep(Slot::Checkpoint);
        Ok(())
    }
}

/// The coupled inputs `U` (all, or those named to [`Coupled::watch`]) are what the adaptive step
/// watches, grouped and scaled as the convergence test groups and scales them; they are converged
/// to the interface tolerance.
impl<S: Units> Retake for Coupled<S> {
    type Report = StepReport;
    type Error = StepError;

    fn try_step(&mut self, h: f64) -> Result<Option<StepReport>, StepError> {
        match self.step(h) {
            Ok(r) => Ok(Some(r)),
            Err(StepError::NotConverged { .. }) => Ok(None),
            Err(e) => Err(e),
        }
    }

    fn undo(&mut self, _t: f64) -> Result<(), StepError> {
        self.roll_back(Slot::Step)
    }

    fn checkpoint(&mut self) -> Result<(), StepError> {
        Coupled::checkpoint(self)
    }

    fn back_to_checkpoint(&mut self) -> Result<(), StepError> {
        self.roll_back(Slot::Checkpoint)
    }

    fn then(first: StepReport, next: StepReport) -> StepReport {
        first.then(next)
    }

    fn watched(&mut self, out: &mut [f64]) -> Result<(), StepError> {
        let (l, y) = (self.core.units.layout(), &self.core.y);
        for (u, w) in out.iter_mut().zip(&self.adaptive.watched) {
            *u = match *w {
                Watched::Input(i) => l.coupled(i, y),
                Watched::Output(j) => y[j],
            };
        }
        Ok(())
    }

    fn groups(&self) -> (&[usize], &[f64]) {
        (&self.adaptive.group, &self.adaptive.scale)
    }

    /// Each watched value's own interface residual `|C·Y_i − U_i|` at the end of the step: how
    /// much the last iteration still moved it (mostly far below the tolerance: IJCSA's Newton
    /// ends at 1e-12 … 1e-9 of the scales on LT50m, with a tolerance of 1e-8). An output's: that
    /// of the inputs it feeds (over the connection's gain); none for an output no connection
    /// carries (it is read after the converged step, and known only as well as the inputs).
    fn noise(&self, out: &mut [f64]) {
        let c = &self.core;
        let l = c.units.layout();
        let residual = |i: usize| (l.coupled(i, &c.y) - c.work.guess[i]).abs();
        for (n, w) in out.iter_mut().zip(&self.adaptive.watched) {
            *n = match *w {
                Watched::Input(i) => residual(i),
                Watched::Output(j) => (0..l.inputs())
                    .filter(|&i| l.source[i] == j && l.gain[i] != 0.0)
                    .map(|i| residual(i) / l.gain[i].abs())
                    .fold(0.0, f64::max),
            };
        }
    }

    fn too_small(&self, t: f64, error: f64, h_min: f64) -> StepError {
        StepError::StepTooSmall { time: t, error, h_min }
    }
}
