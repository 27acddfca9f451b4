//! Form-finding statics (the paper's "cable-length solution"): the unstretched lengths that make
//! a prescribed cabin pose a static equilibrium of the sagging finite-element cables.
//!
//! For trial lengths every cable is solved between its anchor and its attachment point at the
//! target pose ([`crate::shooting`]); the six cabin equations (force and moment about the cabin
//! centre point) are then driven to zero by Newton on the lengths, with exact derivatives.
//! The end node of each cable sits on the cabin: its lumped mass (half an element) is carried by
//! the cabin in the statics as in the dynamics.
//!
//! Cables are numbered from 0, as in lt50m.md: cable i runs from anchor i to attachment i.

use feedcore::{Quat, Vec3};
use nalgebra::{Matrix6, Vector6};

use crate::net::CableNet;
use crate::shooting::{ChainStatics, ShootingError, backtrack, solve_chain};

/// How a cable hangs at the equilibrium.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CableState {
    Taut,
    /// The cable's lowest point lies inside the span, below its cabin end: most of its
    /// weight hangs on the towers and its pull on the cabin is small and soft.
    NearlySlack,
    /// At least one element is shorter than its unstretched length.
    Slack,
}

/// One cable at the equilibrium.
#[derive(Clone, Debug)]
pub struct CableReport {
    pub unstretched_length: f64,
    /// Axial force of the element next to the tower.
    pub tension_anchor: f64,
    /// Axial force of the element next to the cabin.
    pub tension_cabin: f64,
    pub state: CableState,
    /// Height of the cable's lowest node.
    pub lowest_point_z: f64,
    pub shape: ChainStatics,
}

impl CableReport {
    /// The larger of the two end tensions: what the rope must hold.
    pub fn largest_tension(&self) -> f64 {
        self.tension_anchor.max(self.tension_cabin)
    }
}

/// A static equilibrium of the net at a prescribed cabin pose.
#[derive(Clone, Debug)]
pub struct Equilibrium {
    pub position: Vec3,
    pub orientation: Quat,
    pub cables: Vec<CableReport>,
    /// Largest residual of the six cabin equations (N and N·m) at the solution.
    pub residual: f64,
    pub newton_iterations: usize,
}

impl Equilibrium {
    pub fn lengths(&self) -> Vec<f64> {
        self.cables.iter().map(|c| c.unstretched_length).collect()
    }
}

#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum StaticsError {
    /// Holding the pose needs a cable to push.
    #[error(
        "the pose is infeasible: cable {cable} would have to push ({tension:.1} N in a straight-cable estimate); move the target pose towards the middle of the workspace or change the anchors"
    )]
    Infeasible { cable: usize, tension: f64 },
    /// The form finding balances the cabin's six equations with six unstretched lengths.
    #[error("form finding needs exactly six cables (six lengths for the cabin's six equations); the scene has {count}")]
    CableCount { count: usize },
    #[error("form finding did not converge after {iterations} Newton iterations (residual {residual:.3e}): {detail}")]
    NoConvergence { residual: f64, iterations: usize, detail: Detail },
}

/// What stopped the form finding.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum Detail {
    #[error("straight-cable statics failed: {0}")]
    StraightCable(&'static str),
    #[error("cable {cable}: {source}")]
    Cable { cable: usize, source: ShootingError },
    #[error("singular length Jacobian")]
    SingularJacobian,
    #[error("the line search stalled")]
    Stalled,
}

/// Finds the unstretched lengths that hold the cabin at `position`, `orientation`.
pub fn form_find(net: &CableNet, position: Vec3, orientation: Quat) -> Result<Equilibrium, StaticsError> {
    let load = net.suspended().weight_wrench(&orientation, &net.spec.gravity);
    form_find_loaded(net, position, orientation, load)
}

/// As [`form_find`], with the cabin carrying the `external` wrench (force; moment about the cabin
/// centre point; world frame) in place of the payload's weight: what an external platform
/// exerts on it (co-simulation).
pub(crate) fn form_find_under(
    net: &CableNet,
    position: Vec3,
    orientation: Quat,
    external: &Vector6<f64>,
) -> Result<Equilibrium, StaticsError> {
    let load = net.cabin.weight_wrench(&orientation, &net.spec.gravity) + external;
    form_find_loaded(net, position, orientation, load)
}

/// Change of the end tensions of a form-found equilibrium when the external wrench on the cabin
/// changes and the unstretched lengths follow, so that the pose stays an equilibrium:
/// `[cable][0 anchor end, 1 cabin end][wrench component]`. Exact: the lengths move by
/// `−J⁻¹ δW` (J the length Jacobian of the cabin equations), each cable's end tensions with
/// its length through the shooting sensitivity.
pub fn tension_wrench_sensitivity(net: &CableNet, eq: &Equilibrium) -> Result<Vec<[[f64; 6]; 2]>, StaticsError> {
    let n = net.cable_count();
    let singular = || StaticsError::NoConvergence {
        residual: eq.residual,
        iterations: eq.newton_iterations,
        detail: Detail::SingularJacobian,
    };
    if n != 6 {
        return Err(StaticsError::CableCount { count: n });
    }
    let arms: Vec<Vec3> = net.attachments.iter().map(|a| eq.orientation * a).collect();
    let jac = length_jacobian(net, eq.cables.iter().map(|c| &c.shape), &arms);
    // cabin equations R(L) + δW = 0  ⇒  δL = −J⁻¹ δW
    let dl_dw = jac.try_inverse().ok_or_else(singular)? * -1.0;
    Ok(eq
        .cables
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let t = &c.shape.tension;
            let d_last = c.shape.d_last_tension_d_length;
            // T_first = T_last − (n − 1) m g with node mass m = μ L / n
            let d_first = d_last + net.spec.gravity * net.spec.interior_mass_rate();
            let rate = |tv: &Vec3, dt: &Vec3| if tv.norm() > 0.0 { tv.normalize().dot(dt) } else { 0.0 };
            let (ra, rc) = (rate(&t[0], &d_first), rate(&t[t.len() - 1], &d_last));
            let mut out = [[0.0; 6]; 2];
            for k in 0..6 {
                out[0][k] = ra * dl_dw[(i, k)];
                out[1][k] = rc * dl_dw[(i, k)];
            }
            out
        })
        .collect())
}

/// The cabin equations' Jacobian with respect to the unstretched lengths (six cables, each
/// with its end points held): column i is ∂(force, moment about the cabin centre point)/∂L_i
/// of cable i's pull on the cabin and its lumped end node's weight; `arms` the attachments
/// turned into the world frame.
fn length_jacobian<'a>(net: &CableNet, cables: impl Iterator<Item = &'a ChainStatics>, arms: &[Vec3]) -> Matrix6<f64> {
    let mut jac = Matrix6::zeros();
    for (i, c) in cables.enumerate() {
        let df = -c.d_last_tension_d_length + net.spec.gravity * net.spec.end_node_mass_rate();
        let dm = arms[i].cross(&df);
        for k in 0..3 {
            jac[(k, i)] = df[k];
            jac[(k + 3, i)] = dm[k];
        }
    }
    jac
}

/// Form finding for the cabin load `load` (its weight and what it carries).
fn form_find_loaded(
    net: &CableNet,
    position: Vec3,
    orientation: Quat,
    load: Vector6<f64>,
) -> Result<Equilibrium, StaticsError> {
    let n = net.cable_count();
    if n != 6 {
        return Err(StaticsError::CableCount { count: n });
    }
    let arms: Vec<Vec3> = net.attachments.iter().map(|a| orientation * a).collect();
    let ends: Vec<Vec3> = arms.iter().map(|d| position + d).collect();

    // Straight, massless cables: the linear statics gives tensions, a feasibility check and a
    // first guess. With six cables it is square; otherwise least squares.
    let mut a = nalgebra::DMatrix::zeros(6, n);
    for i in 0..n {
        let u = (net.anchors[i] - ends[i]).normalize();
        let m = arms[i].cross(&u);
        for r in 0..3 {
            a[(r, i)] = u[r];
            a[(r + 3, i)] = m[r];
        }
    }
    // cable weights: roughly half of each cable hangs on the cabin
    let mut rhs = -nalgebra::DVector::from_column_slice(load.as_slice());
    for i in 0..n {
        let w = net.spec.gravity * (0.5 * net.spec.mass_per_length * (net.anchors[i] - ends[i]).norm());
        let m = arms[i].cross(&w);
        for r in 0..3 {
            rhs[r] -= w[r];
            rhs[r + 3] -= m[r];
        }
    }
    let straight = a.clone().svd(true, true).solve(&rhs, 1e-12).map_err(|e| StaticsError::NoConvergence {
        residual: f64::NAN,
        iterations: 0,
        detail: Detail::StraightCable(e),
    })?;
    // A cable pushing in the straight estimate may still be feasible once sag is accounted for
    // (a nearly slack cable); start it at a small tension and let Newton decide.
    let floor = 0.02 * straight.iter().cloned().fold(0.0, f64::max);
    let mut lengths: Vec<f64> = (0..n)
        .map(|i| {
            let chord = (net.anchors[i] - ends[i]).norm();
            chord / (1.0 + straight[i].max(floor) / net.spec.ea)
        })
        .collect();

    let solve_all = |lengths: &[f64], guesses: &[Option<Vec3>]| -> Result<Vec<ChainStatics>, Detail> {
        (0..n)
            .map(|i| {
                solve_chain(&net.spec, &net.anchors[i], &ends[i], lengths[i], guesses[i])
                    .map_err(|source| Detail::Cable { cable: i, source })
            })
            .collect()
    };
    let residual_of = |cables: &[ChainStatics], lengths: &[f64]| -> Vector6<f64> {
        let mut r = load;
        for (i, c) in cables.iter().enumerate() {
            let f = c.force_on_second_end() + net.spec.gravity * net.spec.end_node_mass(lengths[i]);
            let m = arms[i].cross(&f);
            r += Vector6::new(f.x, f.y, f.z, m.x, m.y, m.z);
        }
        r
    };

    let weight = net.suspended().mass * net.spec.gravity.norm();
    // Converged at 1e-11 of the weight; the shooting's own precision (≈1e-13 of the span, times
    // the axial stiffness) limits what can be reached, so a stalled search below 1e-9 is accepted.
    let (tol, acceptable) = (1e-11 * weight, 1e-9 * weight);
    let mut guesses: Vec<Option<Vec3>> = vec![None; n];
    let mut cables = match solve_all(&lengths, &guesses) {
        Ok(c) => c,
        Err(detail) => return Err(StaticsError::NoConvergence { residual: f64::NAN, iterations: 0, detail }),
    };
    let mut r = residual_of(&cables, &lengths);
    let max_iter = 100;
    for iter in 0..max_iter {
        if r.amax() <= tol {
            return Ok(report(net, position, orientation, cables, &lengths, r.amax(), iter));
        }
        let jac = length_jacobian(net, cables.iter(), &arms);
        let dl = jac.lu().solve(&(-r)).ok_or_else(|| StaticsError::NoConvergence {
            residual: r.amax(),
            iterations: iter,
            detail: Detail::SingularJacobian,
        })?;
        // Backtracking on the residual norm; lengths stay positive.
        guesses = cables.iter().map(|c| Some(c.tension[0])).collect();
        let accepted = backtrack(1e-10, |step| {
            let trial: Vec<f64> = (0..n).map(|i| lengths[i] + step * dl[i]).collect();
            if !trial.iter().all(|l| *l > 0.0) {
                return None;
            }
            let tc = solve_all(&trial, &guesses).ok()?;
            let tr = residual_of(&tc, &trial);
            (tr.norm() < r.norm()).then_some((trial, tc, tr))
        });
        let Some(next) = accepted else {
            if r.amax() <= acceptable {
                return Ok(report(net, position, orientation, cables, &lengths, r.amax(), iter));
            }
            return Err(infeasible_or_stalled(&straight, r.amax(), iter));
        };
        (lengths, cables, r) = next;
    }
    Err(infeasible_or_stalled(&straight, r.amax(), max_iter))
}

/// When Newton fails, a cable that pushes in the straight-cable statics is the reason.
fn infeasible_or_stalled(straight: &nalgebra::DVector<f64>, residual: f64, iterations: usize) -> StaticsError {
    match straight.iter().enumerate().min_by(|a, b| a.1.total_cmp(b.1)) {
        Some((cable, &tension)) if tension <= 0.0 => StaticsError::Infeasible { cable, tension },
        _ => StaticsError::NoConvergence { residual, iterations, detail: Detail::Stalled },
    }
}

fn report(
    net: &CableNet,
    position: Vec3,
    orientation: Quat,
    shapes: Vec<ChainStatics>,
    lengths: &[f64],
    residual: f64,
    iterations: usize,
) -> Equilibrium {
    let l0e: Vec<f64> = lengths.iter().map(|l| l / net.spec.elements as f64).collect();
    let cables = shapes
        .into_iter()
        .enumerate()
        .map(|(i, shape)| {
            let lowest = shape.nodes.iter().map(|p| p.z).fold(f64::INFINITY, f64::min);
            let cabin_end = shape.nodes[shape.nodes.len() - 1].z;
            let anchor_end = shape.nodes[0].z;
            let slack = shape.nodes.windows(2).any(|w| (w[1] - w[0]).norm() <= l0e[i]);
            let state = if slack {
                CableState::Slack
            } else if lowest < cabin_end.min(anchor_end) - 1e-9 {
                CableState::NearlySlack
            } else {
                CableState::Taut
            };
            CableReport {
                unstretched_length: lengths[i],
                tension_anchor: shape.first_tension(),
                tension_cabin: shape.last_tension(),
                state,
                lowest_point_z: lowest,
                shape,
            }
        })
        .collect();
    Equilibrium { position, orientation, cables, residual, newton_iterations: iterations }
}
