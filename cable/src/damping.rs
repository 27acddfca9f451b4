//! Rayleigh damping of the cable structure: `C = α M + β K`, the mass and tangent-stiffness
//! matrices of the cable–cabin system (Stewart platform locked) at its static equilibrium,
//! with α and β chosen so that the modal damping ratio `ζ(ω) = α/(2ω) + βω/2` equals the
//! scene's ratio at two frequencies — by default those of the first and the sixth natural mode,
//! the band of the cabin's six rigid-body-like modes that carry the response to the platform.
//!
//! C is frozen at the equilibrium: the damping forces are linear in the velocities, and
//! exactly Rayleigh for the small motions about the equilibrium that the scenes describe.

use crate::chain_matrix::ChainMatrix;
use crate::modes::tangent;
use crate::system::{Config, System};

/// Rayleigh coefficients for damping ratio `zeta` at the angular frequencies `w1 < w2` (rad/s).
pub fn rayleigh_coefficients(zeta: f64, w1: f64, w2: f64) -> (f64, f64) {
    (2.0 * zeta * w1 * w2 / (w1 + w2), 2.0 * zeta / (w1 + w2))
}

/// `α M + β K` of `sys` at `cfg` (at rest), with K symmetrized (see [`crate::modes`]).
pub fn rayleigh_matrix(sys: &System, cfg: &Config, alpha: f64, beta: f64) -> ChainMatrix {
    let t = tangent(sys, cfg);
    let mut out = sys.new_matrix();
    out.add_scaled(alpha, &t.mass);
    out.add_scaled(beta, &t.stiffness);
    out
}
