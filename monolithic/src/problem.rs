//! Residual and iteration matrix of the monolithic model, as the integrator asks for them
//! ([`feedcore::genalpha::Problem`]).
//!
//! Residual rows: the cable–cabin model's (its own assembly: cables, cabin, damping), with the
//! Stewart joints' reactions on the cabin as its external wrench; the Stewart bodies' Newton–Euler
//! equations with their joint reactions `Φ_qᵀ λ`; the joint constraints `s·Φ(q, t)`.

use cable::chain_matrix::ChainMatrix;
use cable::system::Coefficients as CableCoefficients;
use feedcore::genalpha::{Iterate, IterationMatrix, Problem};
use feedcore::rigid::{BodyTerms, RigidMotion};
use feedcore::scene::LEGS;
use feedcore::stewart_geometry::BODIES;
use feedcore::{Mat3, Vec3};
use nalgebra::{Matrix6, Vector6};
use stewart::constraints::{CABIN, CONSTRAINTS, ConstraintRow, SYSTEM_BODIES};
use stewart::{CommandState, PathPoint, StewartError, Stroke};

use crate::config::Config;
use crate::kkt::{Kkt, KktError};
use crate::model::Model;

/// What the monolithic model itself objects to during a step.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum Fault {
    #[error(transparent)]
    Stewart(#[from] StewartError),
    #[error("iteration matrix: {0}")]
    Matrix(#[from] KktError),
    #[error("the {0} are not finite")]
    NotFinite(&'static str),
}

/// The matrix to assemble: `mass·M + damping·C + stiffness·K·T`, constraint rows `scale·Φ_q·T`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Coefficients {
    pub mass: f64,
    pub damping: f64,
    pub stiffness: f64,
    pub constraint_scale: f64,
    pub slack_as_taut: bool,
}

/// Linear algebra and scratch of the model's steps (allocated once).
pub struct Scratch {
    chain: ChainMatrix,
    blocks: [Matrix6<f64>; BODIES],
    pub(crate) kkt: Kkt,
    /// Step size of the kept factorization (`None`: none, or not an iteration matrix).
    pub(crate) factor_step: Option<f64>,
    strokes: [Stroke; LEGS],
    /// The time `strokes` are for.
    strokes_time: f64,
    /// Change of the platform's first moment since the start, cabin frame (zero unless the
    /// weight shift is left out).
    weight_shift: Vec3,
    /// The scene's own load on the cabin (wind) at the step's end.
    load: Vector6<f64>,
    pub(crate) rows: Box<[ConstraintRow; CONSTRAINTS]>,
    /// The rows at the last configuration checked for acceptance, and its time.
    pub(crate) accepted: Box<[ConstraintRow; CONSTRAINTS]>,
    pub(crate) accepted_time: f64,
}

impl Scratch {
    pub fn new(model: &Model, config: &Config, point: &PathPoint, time: f64) -> Result<Scratch, StewartError> {
        let strokes = model.stewart.strokes_at(point, time)?;
        let weight_shift = weight_shift(model, point, time)?;
        let mut rows = Box::new([ConstraintRow::EMPTY; CONSTRAINTS]);
        model.stewart.joints().evaluate_positions(&system_motion(model, config, None), &strokes, &mut rows);
        Ok(Scratch {
            chain: model.system.new_matrix(),
            blocks: [Matrix6::zeros(); BODIES],
            kkt: Kkt::new(model.system.cables(), model.system.free_nodes(), &rows),
            factor_step: None,
            strokes,
            strokes_time: time,
            weight_shift,
            load: model.system.scene_load(time),
            accepted: rows.clone(),
            rows,
            accepted_time: f64::NAN,
        })
    }

    /// The strokes last set, if they are for time `t` (a step computed them at its end).
    pub(crate) fn strokes_at_time(&self, t: f64) -> Option<[Stroke; LEGS]> {
        (self.strokes_time == t).then_some(self.strokes)
    }

    /// The joints at an accepted configuration at time `t` with these strokes (for samples).
    pub(crate) fn evaluate_accepted(&mut self, model: &Model, config: &Config, strokes: &[Stroke; LEGS], t: f64) {
        model.stewart.joints().evaluate_positions(&system_motion(model, config, None), strokes, &mut self.accepted);
        self.accepted_time = t;
    }

    /// Sets the prescribed strokes for time `t`, the platform centre commanded to `point`.
    pub(crate) fn set_time(&mut self, model: &Model, point: &PathPoint, t: f64) -> Result<(), StewartError> {
        self.strokes = model.stewart.strokes_at(point, t)?;
        self.strokes_time = t;
        self.weight_shift = weight_shift(model, point, t)?;
        self.load = model.system.scene_load(t);
        Ok(())
    }

    /// Writes the residual at `at` (constraint rows times `scale`) and with `coef` assembles and
    /// factorizes the matrix.
    pub(crate) fn assemble(
        &mut self,
        model: &Model,
        at: &Iterate<'_, Config>,
        scale: f64,
        residual: &mut [f64],
        coef: Option<&Coefficients>,
    ) -> Result<(), KktError> {
        let (nc, n) = (model.cable_dim(), model.motion_dim());
        let joints = model.stewart.joints();
        match coef {
            // the start, whose γ the consistent accelerations need
            Some(c) if c.stiffness == 0.0 => {
                joints.evaluate(&system_motion(model, at.config, Some(at.velocity)), &self.strokes, &mut self.rows)
            }
            _ => joints.evaluate_positions(&system_motion(model, at.config, None), &self.strokes, &mut self.rows),
        }
        // the joints' reactions on the cabin and the scene's load, as the cable–cabin system's
        // external wrench
        let mut wrench = self.load;
        for (row, lambda) in self.rows.iter().zip(at.multipliers) {
            for s in 0..2 {
                if row.bodies[s] == CABIN {
                    wrench -= row.jacobian[s] * *lambda;
                }
            }
        }
        if model.weight_shift_from.is_some() {
            // `inertial_only`: the moment of the weight shift taken out (residual only: its
            // dependence on the cabin's rotation, ~1 % of the rotational stiffness, is left to
            // the Newton iteration)
            let moment = (at.config.cable.orientation * self.weight_shift).cross(&model.system.net.spec.gravity);
            for k in 0..3 {
                wrench[3 + k] -= moment[k];
            }
        }
        let tangents: [Mat3; SYSTEM_BODIES] = match coef {
            Some(_) => std::array::from_fn(|b| Model::tangent(at.increment, model.body_offset(b))),
            None => [Mat3::identity(); SYSTEM_BODIES],
        };
        let (q, v, a) = (&at.config.cable, &at.velocity[..nc], &at.acceleration[..nc]);
        match coef {
            Some(c) => {
                let cable = CableCoefficients {
                    mass: c.mass,
                    damping: c.damping,
                    stiffness: c.stiffness,
                    rotation_tangent: tangents[CABIN],
                    slack_as_taut: c.slack_as_taut,
                };
                model.system.assemble(q, v, a, &wrench, &mut residual[..nc], Some((&mut self.chain, cable)));
            }
            None => model.system.residual(q, v, a, &wrench, &mut residual[..nc]),
        }
        // the Stewart bodies about their centres of mass
        let g = model.stewart.gravity();
        for b in 0..BODIES {
            let pose = &at.config.bodies[b];
            let o = model.body_offset(b);
            let world =
                model.bodies[b].transformed(&pose.orientation.to_rotation_matrix().into_inner(), &pose.position);
            let v3 = |x: &[f64], k: usize| Vec3::new(x[o + k], x[o + k + 1], x[o + k + 2]);
            let (omega, acc, alpha) = (v3(at.velocity, 3), v3(at.acceleration, 0), v3(at.acceleration, 3));
            let r = match coef {
                Some(c) => {
                    let terms = BodyTerms::new(&world, &pose.position, &omega, &acc, &alpha, &g);
                    let mut kt = terms.stiffness * c.stiffness;
                    for row in 0..6 {
                        let turned = kt.fixed_view::<1, 3>(row, 3) * tangents[b];
                        kt.fixed_view_mut::<1, 3>(row, 3).copy_from(&turned);
                    }
                    self.blocks[b] = terms.mass * c.mass + terms.gyroscopic * c.damping + kt;
                    terms.residual
                }
                None => BodyTerms::residual(&world, &pose.position, &omega, &acc, &alpha, &g),
            };
            residual[o..o + 6].copy_from_slice(r.as_slice());
        }
        for (k, row) in self.rows.iter().enumerate() {
            let lambda = at.multipliers[k];
            for s in 0..2 {
                if row.bodies[s] != CABIN {
                    let o = model.body_offset(row.bodies[s]);
                    for (x, j) in residual[o..o + 6].iter_mut().zip(row.jacobian[s].iter()) {
                        *x += j * lambda;
                    }
                }
            }
            residual[n + k] = scale * row.value;
        }
        if let Some(c) = coef {
            self.kkt.factorize(&self.chain, &self.blocks, &self.rows, &tangents, c.constraint_scale)?;
        }
        Ok(())
    }
}

/// The cabin and the Stewart bodies as the joints see them: poses, and velocities if given
/// (the joint equations and their Jacobians need only the poses; γ needs the velocities).
pub(crate) fn system_motion(model: &Model, config: &Config, velocity: Option<&[f64]>) -> [RigidMotion; SYSTEM_BODIES] {
    std::array::from_fn(|b| {
        let mut m = if b == CABIN {
            RigidMotion::at_rest(config.cable.position, config.cable.orientation)
        } else {
            RigidMotion::at_rest(config.bodies[b].position, config.bodies[b].orientation)
        };
        if let Some(v) = velocity {
            let o = model.body_offset(b);
            m.velocity = Vec3::from_column_slice(&v[o..o + 3]);
            m.angular_velocity = Vec3::from_column_slice(&v[o + 3..o + 6]);
        }
        m
    })
}

/// Where the platform centre is commanded (cabin frame) at time `t`: by a sampled sensor's
/// `command` (scene `[control]`; `t` after its last sample), else along the path (with
/// `[control]` and no sensor: held at rest).
pub(crate) fn command_point(model: &Model, command: Option<&CommandState>, t: f64) -> PathPoint {
    match (command, model.stewart.compensation()) {
        (Some(state), Some(c)) => state.at(c, t),
        _ => model.stewart.path().at(t),
    }
}

/// The model side of one generalized-α step.
pub(crate) struct Step<'a> {
    pub model: &'a Model,
    pub scratch: &'a mut Scratch,
    /// A sampled sensor's commands, sampled at the step's start.
    pub command: Option<&'a CommandState>,
}

impl Problem for Step<'_> {
    type Config = Config;
    type Input = ();
    type Error = Fault;

    /// The cable–cabin part moves smoothly; the Stewart bodies' accelerations, tied to the
    /// joints at index 3, oscillate from step to step (measured at C: 2.27 Newton iterations per
    /// step with a constant predictor, 2.14 extrapolating the cable–cabin part, 2.47 all).
    fn extrapolated_unknowns(&self) -> usize {
        self.model.cable_dim()
    }

    fn place(&self, base: &Config, increment: &[f64], trial: &mut Config) {
        trial.set_displaced(base, increment);
    }

    fn begin_step(&mut self, time: f64, _: &()) -> Result<(), Fault> {
        if !time.is_finite() {
            return Err(StewartError::Input { what: "time".into(), value: time.to_string() }.into());
        }
        let point = command_point(self.model, self.command, time);
        Ok(self.scratch.set_time(self.model, &point, time)?)
    }

    fn residual(&mut self, at: &Iterate<'_, Config>, constraint_scale: f64, residual: &mut [f64]) {
        self.scratch
            .assemble(self.model, at, constraint_scale, residual, None)
            .expect("a residual alone factorizes nothing");
    }

    fn factorize(&mut self, at: &Iterate<'_, Config>, s: &IterationMatrix, residual: &mut [f64]) -> Result<(), Fault> {
        let coef = Coefficients {
            mass: s.mass,
            damping: s.damping,
            stiffness: 1.0,
            constraint_scale: s.constraint_scale,
            slack_as_taut: s.slack_as_taut,
        };
        self.scratch.factor_step = None;
        self.scratch.assemble(self.model, at, s.constraint_scale, residual, Some(&coef))?;
        self.scratch.factor_step = Some(s.step);
        Ok(())
    }

    fn factorized_step(&self) -> Option<f64> {
        self.scratch.factor_step
    }

    fn solve(&mut self, rhs: &mut [f64]) {
        self.scratch.kkt.solve(rhs);
    }

    fn unknown_name(&self, index: usize) -> String {
        self.model.unknown_name(index)
    }

    fn constraint_violation(&mut self, config: &Config) -> f64 {
        let sc = &mut *self.scratch;
        let motion = system_motion(self.model, config, None);
        self.model.stewart.joints().evaluate_positions(&motion, &sc.strokes, &mut sc.accepted);
        sc.accepted_time = f64::NAN; // the caller confirms the time once the step is accepted
        largest_value(&sc.accepted[..])
    }
}

/// `S(t) − S(0)` of the platform and legs (cabin frame) when the model leaves the weight shift
/// out; zero otherwise.
fn weight_shift(model: &Model, point: &PathPoint, t: f64) -> Result<Vec3, StewartError> {
    match model.weight_shift_from {
        Some(s0) => Ok(model.stewart.relative_at(point, t)?.first_moment[0] - s0),
        None => Ok(Vec3::zeros()),
    }
}

/// Largest |Φ| of the rows; NaN if one is NaN.
pub(crate) fn largest_value(rows: &[ConstraintRow]) -> f64 {
    rows.iter().fold(0.0, |m: f64, r| if m.is_nan() || r.value.is_nan() { f64::NAN } else { m.max(r.value.abs()) })
}
