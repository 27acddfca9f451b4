//! The linear algebra of a Newton iteration of the monolithic model.
//!
//! ```text
//!  ┌ K_chains  P                         ┐ ┌ nodes  ┐
//!  │ Q         A_cabin            G_cᵀ   │ │ cabin  │
//!  │                     A_bodies G_bᵀ   │ │ bodies │
//!  └           s·G_c·T   s·G_b·T  0      ┘ └ λ      ┘
//! ```
//!
//! 1. Every cable chain is eliminated onto the cabin (the cable crate's block-tridiagonal
//!    elimination, linear in the nodes): the cabin keeps a 6×6 Schur complement.
//! 2. The 14 rigid bodies (the cabin with its condensed block, the 13 Stewart bodies) have
//!    6×6 blocks of their own, mass-dominated and invertible: they are eliminated too, which
//!    leaves the constraints' Schur complement `W = s·G·T·A⁻¹·Gᵀ` (78×78; two rows couple only
//!    when they share a body).
//! 3. W is assembled densely and factorized in the platform's structure ([`crate::schur`]).
//!
//! Vectors are laid out as the model's unknowns: the cable–cabin model's (nodes, cabin), the
//! Stewart bodies' 6 each (platform, upper parts, lower parts), then the multipliers.

use cable::chain_matrix::{ChainElimination, ChainMatrix, FactorError};
use faer::Mat;
use feedcore::Mat3;
use feedcore::stewart_geometry::BODIES;
use nalgebra::{Matrix6, Vector6};
use stewart::constraints::{CABIN, CONSTRAINTS, ConstraintRow, SYSTEM_BODIES};

use crate::schur::Schur;

/// A block that cannot be factorized.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum KktError {
    #[error("cable chains: {0}")]
    Chains(#[from] FactorError),
    #[error(
        "block of {0} is singular: its inertia no longer outweighs its gyroscopic and geometric terms (the body turns too fast for the step); reduce the step size or check the motion"
    )]
    SingularBody(&'static str),
    #[error("block of {0} is not finite (the motion diverged)")]
    NotFinite(&'static str),
    #[error("singular constraint matrix (at Stewart constraint row {0}): the joints are in a singular pose")]
    SingularConstraints(usize),
}

/// Names of the bodies in the Stewart crate's order, the cabin last.
pub(crate) const BODY_NAMES: [&str; SYSTEM_BODIES] = [
    "the Stewart platform",
    "the upper part of leg 1",
    "the upper part of leg 2",
    "the upper part of leg 3",
    "the upper part of leg 4",
    "the upper part of leg 5",
    "the upper part of leg 6",
    "the lower part of leg 1",
    "the lower part of leg 2",
    "the lower part of leg 3",
    "the lower part of leg 4",
    "the lower part of leg 5",
    "the lower part of leg 6",
    "the cabin",
];

/// One constraint row's parts: its two bodies, its Jacobian blocks `G` (as columns), the
/// scaled, tangent-mapped row blocks `Ĝ = s·G·T`, and `Y = A⁻¹·Gᵀ`.
#[derive(Clone, Copy, Debug)]
struct Row {
    bodies: [usize; 2],
    g: [Vector6<f64>; 2],
    g_hat: [Vector6<f64>; 2],
    y: [Vector6<f64>; 2],
}

/// The factorized iteration matrix and what its solves need (allocated once).
pub struct Kkt {
    /// Unknowns of the cable–cabin part; the cabin's start among them.
    cable: usize,
    cabin: usize,
    chains: ChainElimination,
    /// Inverse of each rigid body's block, the cabin's condensed one at [`CABIN`].
    inverse: [Matrix6<f64>; SYSTEM_BODIES],
    rows: Vec<Row>,
    /// The rows that act on each body: (row, which of its two bodies).
    touching: Vec<Vec<(usize, usize)>>,
    /// W, and its factorization.
    w: Mat<f64>,
    schur: Schur,
    rhs: Vec<f64>,
    /// Reduced right-hand sides of the bodies.
    z: [Vector6<f64>; SYSTEM_BODIES],
}

impl Kkt {
    /// Storage for `cables` chains of `nodes` free nodes and the joints whose rows act on the
    /// bodies listed in `rows` (structure only: which bodies each row couples).
    pub fn new(cables: usize, nodes: usize, rows: &[ConstraintRow; CONSTRAINTS]) -> Kkt {
        let mut touching = vec![Vec::new(); SYSTEM_BODIES];
        for (k, row) in rows.iter().enumerate() {
            for (slot, b) in row.bodies.iter().enumerate() {
                touching[*b].push((k, slot));
            }
        }
        let cable = 3 * cables * nodes + 6;
        Kkt {
            cable,
            cabin: cable - 6,
            chains: ChainElimination::new(cables, nodes),
            inverse: [Matrix6::zeros(); SYSTEM_BODIES],
            rows: rows
                .iter()
                .map(|r| Row {
                    bodies: r.bodies,
                    g: [Vector6::zeros(); 2],
                    g_hat: [Vector6::zeros(); 2],
                    y: [Vector6::zeros(); 2],
                })
                .collect(),
            touching,
            w: Mat::zeros(CONSTRAINTS, CONSTRAINTS),
            schur: Schur::new(rows),
            rhs: vec![0.0; CONSTRAINTS],
            z: [Vector6::zeros(); SYSTEM_BODIES],
        }
    }

    /// Start of body `b`'s unknowns (Stewart order, the cabin at [`CABIN`]).
    pub fn body_offset(&self, b: usize) -> usize {
        if b == CABIN { self.cabin } else { self.cable + 6 * b }
    }

    /// Factorizes the matrix made of the cable–cabin part `chain` (its cabin block included),
    /// the Stewart bodies' blocks `bodies`, and the constraint rows `rows` (Jacobians) scaled by
    /// `scale`, with the rotation tangents `tangents` of every rigid body on their columns.
    pub fn factorize(
        &mut self,
        chain: &ChainMatrix,
        bodies: &[Matrix6<f64>; BODIES],
        rows: &[ConstraintRow; CONSTRAINTS],
        tangents: &[Mat3; SYSTEM_BODIES],
        scale: f64,
    ) -> Result<(), KktError> {
        let condensed = self.chains.eliminate(chain)?;
        let invert = |block: &Matrix6<f64>, b: usize| {
            if block.iter().any(|x| !x.is_finite()) {
                return Err(KktError::NotFinite(BODY_NAMES[b]));
            }
            block.try_inverse().ok_or(KktError::SingularBody(BODY_NAMES[b]))
        };
        self.inverse[CABIN] = invert(&condensed, CABIN)?;
        for (b, block) in bodies.iter().enumerate() {
            self.inverse[b] = invert(block, b)?;
        }
        for (row, r) in self.rows.iter_mut().zip(rows) {
            debug_assert_eq!(row.bodies, r.bodies, "the joints' structure is fixed");
            for n in 0..2 {
                let (b, g) = (r.bodies[n], r.jacobian[n]);
                let rot = tangents[b].tr_mul(&g.fixed_rows::<3>(3));
                row.g[n] = g;
                row.g_hat[n] = Vector6::new(g[0], g[1], g[2], rot[0], rot[1], rot[2]) * scale;
                row.y[n] = self.inverse[b] * g;
            }
        }
        // W_jk = Σ over the bodies rows j and k share of Ĝ_j · Y_k
        self.w.fill(0.0);
        for touching in &self.touching {
            for &(j, nj) in touching {
                let g_hat = &self.rows[j].g_hat[nj];
                for &(k, nk) in touching {
                    self.w[(j, k)] += g_hat.dot(&self.rows[k].y[nk]);
                }
            }
        }
        let w = &self.w;
        self.schur.factorize(|j, k| w[(j, k)]).map_err(KktError::SingularConstraints)
    }

    /// Overwrites `x` (right-hand side, laid out as the unknowns) with the solution.
    pub fn solve(&mut self, x: &mut [f64]) {
        let (cable, cabin) = (self.cable, self.cabin);
        let motion = cable + 6 * BODIES;
        let bc = self.chains.forward(&mut x[..cable]);
        for b in 0..SYSTEM_BODIES {
            let rb = if b == CABIN { bc } else { Vector6::from_column_slice(&x[cable + 6 * b..cable + 6 * b + 6]) };
            self.z[b] = self.inverse[b] * rb;
        }
        // W λ = Ĝ z − r_λ
        for (k, row) in self.rows.iter().enumerate() {
            let reduced = row.g_hat[0].dot(&self.z[row.bodies[0]]) + row.g_hat[1].dot(&self.z[row.bodies[1]]);
            self.rhs[k] = reduced - x[motion + k];
        }
        self.schur.solve(&mut self.rhs);
        for (k, row) in self.rows.iter().enumerate() {
            let lambda = self.rhs[k];
            x[motion + k] = lambda;
            for n in 0..2 {
                self.z[row.bodies[n]] -= row.y[n] * lambda;
            }
        }
        for b in 0..BODIES {
            x[cable + 6 * b..cable + 6 * b + 6].copy_from_slice(self.z[b].as_slice());
        }
        let xc = self.z[CABIN];
        self.chains.backward(&mut x[..cable], &xc);
        debug_assert_eq!(&x[cabin..cabin + 6], xc.as_slice());
    }
}
