//! Statics of one finite-element cable between two fixed points, solved by shooting.
//!
//! Walking from the first end, the tension vector of each element follows from the previous
//! one by the equilibrium of the node between them, `T_{j+1} = T_j − m_j g`, and each element's
//! stretched length follows from its tension, `L_j = L0e (1 + |T_j|/EA)`. The only unknown is
//! the first element's tension vector: Newton on it until the walk lands on the second end.
//! This is the exact equilibrium of the discrete (lumped-mass, tension-only) chain, and it is
//! robust for nearly slack cables where a displacement-based Newton struggles.

use feedcore::{Mat3, Vec3};

/// Equilibrium of one cable: node positions and element forces.
#[derive(Clone, Debug)]
pub struct ChainStatics {
    /// All k = n + 1 node positions, from the first end to the second.
    pub nodes: Vec<Vec3>,
    /// Tension vector of every element, pointing from its first node to its second.
    pub tension: Vec<Vec3>,
    /// ∂(last element's tension vector)/∂(unstretched length), at fixed end points.
    pub d_last_tension_d_length: Vec3,
}

impl ChainStatics {
    pub(crate) fn first_tension(&self) -> f64 {
        self.tension[0].norm()
    }
    pub(crate) fn last_tension(&self) -> f64 {
        self.tension[self.tension.len() - 1].norm()
    }
    /// Force the cable exerts on its second end point.
    pub(crate) fn force_on_second_end(&self) -> Vec3 {
        -self.tension[self.tension.len() - 1]
    }
}

/// Material and discretisation of one cable.
#[derive(Clone, Copy, Debug)]
pub struct CableSpec {
    pub elements: usize,
    pub ea: f64,
    pub mass_per_length: f64,
    pub gravity: Vec3,
}

/// The lumped masses of a chain of `elements` bars: every interior node carries one element's
/// mass, each end node half of one.
impl CableSpec {
    /// Mass of an interior node of a chain of unstretched `length`.
    pub fn node_mass(&self, length: f64) -> f64 {
        self.mass_per_length * (length / self.elements as f64)
    }

    /// ∂[`CableSpec::node_mass`]/∂length.
    pub fn node_mass_rate(&self) -> f64 {
        self.mass_per_length / self.elements as f64
    }

    /// Mass of each end node of a chain of unstretched `length`.
    pub fn end_node_mass(&self, length: f64) -> f64 {
        0.5 * self.mass_per_length * length / self.elements as f64
    }

    /// ∂[`CableSpec::end_node_mass`]/∂length.
    pub fn end_node_mass_rate(&self) -> f64 {
        0.5 * self.mass_per_length / self.elements as f64
    }

    /// ∂(mass of all interior nodes)/∂length: (n − 1) of them.
    pub fn interior_mass_rate(&self) -> f64 {
        let n = self.elements as f64;
        self.mass_per_length * (n - 1.0) / n
    }
}

/// Walks the chain for a trial first tension `t1`; returns the end point and its derivatives
/// with respect to `t1` (3×3) and to the unstretched length (3).
fn walk(
    spec: &CableSpec,
    start: &Vec3,
    length: f64,
    t1: &Vec3,
    nodes: Option<&mut Vec<Vec3>>,
    tension: Option<&mut Vec<Vec3>>,
) -> (Vec3, Mat3, Vec3) {
    let n = spec.elements;
    let l0e = length / n as f64;
    let node_weight = -spec.gravity * spec.node_mass(length); // −m g: added to T at each interior node
    let d_weight_d_length = -spec.gravity * spec.node_mass_rate();
    let (mut r, mut dr_dt, mut dr_dl) = (*start, Mat3::zeros(), Vec3::zeros());
    let mut t = *t1;
    let mut nodes = nodes;
    let mut tension = tension;
    if let Some(v) = nodes.as_deref_mut() {
        v.clear();
        v.push(r);
    }
    if let Some(v) = tension.as_deref_mut() {
        v.clear();
    }
    for j in 0..n {
        if j > 0 {
            t += node_weight;
        }
        let tn = t.norm();
        let e = t / tn;
        let stretch = 1.0 + tn / spec.ea;
        // d(stretch · e)/dT = (I − e eᵀ)/|T| + I/EA
        let g = (Mat3::identity() - e * e.transpose()) / tn + Mat3::identity() / spec.ea;
        let dt_dl = d_weight_d_length * j as f64;
        dr_dt += g * l0e;
        dr_dl += e * (stretch / n as f64) + g * dt_dl * l0e;
        r += e * (stretch * l0e);
        if let Some(v) = nodes.as_deref_mut() {
            v.push(r);
        }
        if let Some(v) = tension.as_deref_mut() {
            v.push(t);
        }
    }
    (r, dr_dt, dr_dl)
}

/// A first guess of the first element's tension: a parabolic sag estimate for a cable longer
/// than its chord, the elastic stretch otherwise.
fn initial_tension(spec: &CableSpec, start: &Vec3, end: &Vec3, length: f64) -> Vec3 {
    let chord = end - start;
    let l = chord.norm();
    let u = chord / l;
    let w = spec.mass_per_length * spec.gravity.norm();
    let t_mid = if l >= length {
        spec.ea * (l - length) / length + 0.5 * w * l
    } else {
        let sag = (3.0 * l * (length - l) / 8.0).sqrt();
        w * l * l / (8.0 * sag)
    };
    let t_mid = t_mid.max(1e-9 * spec.ea);
    // T grows by −m g per interior node; start half the weight below the middle.
    let n = spec.elements;
    u * t_mid + spec.gravity * (spec.mass_per_length * length * (n - 1) as f64 / (2 * n) as f64)
}

/// Why a cable cannot be solved between its ends.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ShootingError {
    #[error("singular shooting Jacobian{}", if *.at_solution { " at the solution" } else { "" })]
    SingularJacobian { at_solution: bool },
    #[error("shooting stalled {miss:.3e} m from the end point")]
    Stalled { miss: f64 },
    #[error("shooting did not converge: {miss:.3e} m from the end point")]
    NotConverged { miss: f64 },
}

/// Backtracking: the first trial `attempt` accepts at the steps 1, ½, ¼, … down to `min_step`, or
/// `None`.
pub(crate) fn backtrack<T>(min_step: f64, mut attempt: impl FnMut(f64) -> Option<T>) -> Option<T> {
    let mut step = 1.0;
    while step >= min_step {
        if let Some(accepted) = attempt(step) {
            return Some(accepted);
        }
        step *= 0.5;
    }
    None
}

/// Solves the cable from `start` to `end` with unstretched length `length`.
/// `guess` is a first-element tension vector to start Newton from (e.g. the last solution).
pub fn solve_chain(
    spec: &CableSpec,
    start: &Vec3,
    end: &Vec3,
    length: f64,
    guess: Option<Vec3>,
) -> Result<ChainStatics, ShootingError> {
    let scale = (end - start).norm().max(length);
    let mut t1 = guess.unwrap_or_else(|| initial_tension(spec, start, end, length));
    let (r0, mut j, _) = walk(spec, start, length, &t1, None, None);
    let mut res = r0 - end;
    for _ in 0..200 {
        if res.norm() <= 1e-13 * scale {
            let mut nodes = Vec::with_capacity(spec.elements + 1);
            let mut tension = Vec::with_capacity(spec.elements);
            let (_, jac, dl) = walk(spec, start, length, &t1, Some(&mut nodes), Some(&mut tension));
            // dT_last/dL = dT1/dL + (n−1)·dm g;  dT1/dL = −J⁻¹ ∂r/∂L at fixed end
            let jinv = jac.try_inverse().ok_or(ShootingError::SingularJacobian { at_solution: true })?;
            let dt1 = -(jinv * dl);
            let d_last = dt1 - spec.gravity * spec.interior_mass_rate();
            return Ok(ChainStatics { nodes, tension, d_last_tension_d_length: d_last });
        }
        let dt = j.lu().solve(&(-res)).ok_or(ShootingError::SingularJacobian { at_solution: false })?;
        // Accept the first step that reduces the miss distance and keeps |T| > 0.
        let accepted = backtrack(1e-12, |step| {
            let trial = t1 + dt * step;
            if !(trial.norm() > 0.0) {
                return None;
            }
            let (rt, jt, _) = walk(spec, start, length, &trial, None, None);
            let rest = rt - end;
            (rest.norm().is_finite() && rest.norm() < res.norm()).then_some((trial, jt, rest))
        });
        let Some(next) = accepted else {
            return Err(ShootingError::Stalled { miss: res.norm() });
        };
        (t1, j, res) = next;
    }
    Err(ShootingError::NotConverged { miss: res.norm() })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(n: usize) -> CableSpec {
        CableSpec { elements: n, ea: 1.0247e7, mass_per_length: 0.813, gravity: Vec3::new(0.0, 0.0, -9.81) }
    }

    #[test]
    fn the_sensitivity_to_length_matches_finite_differences() {
        let s = spec(20);
        let (a, b) = (Vec3::new(28.2, 10.3, 30.0), Vec3::new(0.9, 0.5, 9.55));
        let l = (b - a).norm() + 0.1;
        let c = solve_chain(&s, &a, &b, l, None).unwrap();
        let eps = 1e-6;
        let p = solve_chain(&s, &a, &b, l + eps, None).unwrap();
        let m = solve_chain(&s, &a, &b, l - eps, None).unwrap();
        let fd = (p.tension[19] - m.tension[19]) / (2.0 * eps);
        assert!((fd - c.d_last_tension_d_length).norm() < 1e-5 * fd.norm(), "{fd} vs {}", c.d_last_tension_d_length);
    }

    #[test]
    fn a_cable_hanging_below_its_lower_end_converges() {
        // Much longer than the chord: the lowest point is inside the span.
        let s = spec(20);
        let (a, b) = (Vec3::new(-15.0, -26.0, 30.0), Vec3::new(-3.0, 8.0, 15.0));
        let l = (b - a).norm() * 1.08;
        let c = solve_chain(&s, &a, &b, l, None).unwrap();
        let lowest = c.nodes.iter().map(|p| p.z).fold(f64::INFINITY, f64::min);
        assert!(lowest < b.z - 0.1, "lowest {lowest}");
        assert!((c.nodes[20] - b).norm() < 1e-9);
    }
}
