//! The constraints' Schur complement `W` (78×78), factorized in the Stewart platform's
//! structure.
//!
//! Two rows of W couple only when their joints share a body. Each leg's actuator rows (prismatic
//! and driving: upper part to lower part) share bodies with nothing outside their leg, so they
//! are eliminated leg by leg (6×6 blocks); what is left couples the rows that touch the cabin or
//! the platform (Hooke and spherical joints, 7 per leg) — a dense 42×42 "hub" system, factorized
//! by LU with partial pivoting (faer). A solve then costs about 2,500 multiply-adds instead of
//! the 6,000 of a dense 78×78 LU (measured: see docs/ARCHITECTURE.md).

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::lu::partial_pivoting::factor;
use faer::{Mat, Par};
use feedcore::scene::LEGS;
use nalgebra::{Matrix6, SMatrix, SVector, Vector6};
use stewart::constraints::{CABIN, CONSTRAINTS, ConstraintRow, PLATFORM};

/// Rows of one leg that touch neither the cabin nor the platform, and of those that do.
const INTERNAL: usize = 6;
const HUB_PER_LEG: usize = 7;

/// One leg: its internal rows, the positions of its hub rows in the hub system, and their
/// blocks `W_PP⁻¹`, `C = W_PP⁻¹ W_Ph` and `R = W_hP`.
#[derive(Clone, Debug)]
struct Leg {
    rows: [usize; INTERNAL],
    hub: [usize; HUB_PER_LEG],
    inverse: Matrix6<f64>,
    c: SMatrix<f64, INTERNAL, HUB_PER_LEG>,
    r: SMatrix<f64, HUB_PER_LEG, INTERNAL>,
}

/// The factorized Schur complement and its scratch (allocated once).
pub struct Schur {
    legs: Vec<Leg>,
    /// The constraint row of each hub unknown.
    hub_rows: Vec<usize>,
    hub: Mat<f64>,
    perm: Vec<usize>,
    perm_inv: Vec<usize>,
    stack: MemBuffer,
    /// Column-major copy of the hub's LU factors with the diagonal inverted.
    lu: Vec<f64>,
    rhs: Vec<f64>,
}

impl Schur {
    /// The structure of the joints `rows` (which bodies each row couples). Panics unless every
    /// leg has the Stewart model's 6 internal and 7 hub rows.
    pub fn new(rows: &[ConstraintRow; CONSTRAINTS]) -> Schur {
        let is_hub = |r: &ConstraintRow| r.bodies.iter().any(|b| *b == CABIN || *b == PLATFORM);
        let hub_rows: Vec<usize> = (0..CONSTRAINTS).filter(|k| is_hub(&rows[*k])).collect();
        // a leg: the internal rows sharing a body; its hub rows touch one of those bodies
        let mut legs = Vec::new();
        let mut internal: Vec<usize> = (0..CONSTRAINTS).filter(|k| !is_hub(&rows[*k])).collect();
        while let Some(&first) = internal.first() {
            let bodies = rows[first].bodies;
            let group: Vec<usize> = internal.iter().copied().filter(|k| rows[*k].bodies == bodies).collect();
            internal.retain(|k| rows[*k].bodies != bodies);
            let hub: Vec<usize> = hub_rows
                .iter()
                .enumerate()
                .filter(|(_, k)| rows[**k].bodies.iter().any(|b| bodies.contains(b)))
                .map(|(i, _)| i)
                .collect();
            legs.push(Leg {
                rows: group.try_into().expect("six actuator rows per leg"),
                hub: hub.try_into().expect("seven Hooke and spherical rows per leg"),
                inverse: Matrix6::zeros(),
                c: SMatrix::zeros(),
                r: SMatrix::zeros(),
            });
        }
        let n = hub_rows.len();
        assert!(legs.len() == LEGS && n == LEGS * HUB_PER_LEG, "every hub row belongs to one of the legs");
        let stack = factor::lu_in_place_scratch::<usize, f64>(n, n, Par::Seq, Default::default());
        Schur {
            legs,
            hub: Mat::zeros(n, n),
            perm: vec![0; n],
            perm_inv: vec![0; n],
            stack: MemBuffer::new(stack),
            lu: vec![0.0; n * n],
            rhs: vec![0.0; n],
            hub_rows,
        }
    }

    /// Factorizes `W` (entries `w(j, k)`, constraint row order). Fails with the leg or hub
    /// pivot that is singular.
    pub fn factorize(&mut self, w: impl Fn(usize, usize) -> f64) -> Result<(), usize> {
        let n = self.hub_rows.len();
        for i in 0..n {
            for j in 0..n {
                self.hub[(i, j)] = w(self.hub_rows[i], self.hub_rows[j]);
            }
        }
        for (l, leg) in self.legs.iter_mut().enumerate() {
            let pp = Matrix6::from_fn(|i, j| w(leg.rows[i], leg.rows[j]));
            leg.inverse = pp.try_inverse().ok_or(l)?;
            let ph = SMatrix::<f64, INTERNAL, HUB_PER_LEG>::from_fn(|i, j| w(leg.rows[i], self.hub_rows[leg.hub[j]]));
            leg.c = leg.inverse * ph;
            leg.r = SMatrix::from_fn(|i, j| w(self.hub_rows[leg.hub[i]], leg.rows[j]));
            let update = leg.r * leg.c;
            for i in 0..HUB_PER_LEG {
                for j in 0..HUB_PER_LEG {
                    self.hub[(leg.hub[i], leg.hub[j])] -= update[(i, j)];
                }
            }
        }
        factor::lu_in_place(
            self.hub.as_mut(),
            &mut self.perm,
            &mut self.perm_inv,
            Par::Seq,
            MemStack::new(&mut self.stack),
            Default::default(),
        );
        for j in 0..n {
            for i in 0..n {
                self.lu[n * j + i] = self.hub[(i, j)];
            }
            let pivot = self.hub[(j, j)];
            if !(pivot.abs() > 0.0 && pivot.is_finite()) {
                return Err(self.hub_rows[j]);
            }
            self.lu[n * j + j] = 1.0 / pivot;
        }
        Ok(())
    }

    /// Overwrites `b` (constraint row order) with `W⁻¹ b`.
    pub fn solve(&mut self, b: &mut [f64]) {
        let n = self.hub_rows.len();
        // the legs' actuator rows first; their coupling moves into the hub's right-hand side
        let mut y = [Vector6::zeros(); LEGS];
        let h = &mut self.rhs;
        for (i, p) in self.perm.iter().enumerate() {
            h[i] = b[self.hub_rows[*p]];
        }
        let mut reduced = [0.0; LEGS * HUB_PER_LEG];
        for (leg, y) in self.legs.iter().zip(&mut y) {
            *y = leg.inverse * Vector6::from_fn(|i, _| b[leg.rows[i]]);
            let coupled = leg.r * *y;
            for i in 0..HUB_PER_LEG {
                reduced[leg.hub[i]] += coupled[i];
            }
        }
        for (i, p) in self.perm.iter().enumerate() {
            h[i] -= reduced[*p];
        }
        // the hub: P·Wh = L·U, column by column (each an axpy on a contiguous column)
        let lu = &self.lu;
        for j in 0..n {
            let yj = h[j];
            for (hi, l) in h[j + 1..].iter_mut().zip(&lu[n * j + j + 1..n * (j + 1)]) {
                *hi -= l * yj;
            }
        }
        for j in (0..n).rev() {
            let column = &lu[n * j..n * j + j + 1];
            let xj = h[j] * column[j];
            h[j] = xj;
            for (hi, u) in h[..j].iter_mut().zip(column) {
                *hi -= u * xj;
            }
        }
        for (i, row) in self.hub_rows.iter().enumerate() {
            b[*row] = h[i];
        }
        for (leg, y) in self.legs.iter().zip(&y) {
            let hub = SVector::<f64, HUB_PER_LEG>::from_fn(|i, _| h[leg.hub[i]]);
            let x = y - leg.c * hub;
            for i in 0..INTERNAL {
                b[leg.rows[i]] = x[i];
            }
        }
    }
}
