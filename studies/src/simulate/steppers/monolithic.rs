//! The monolithic model (eq. 7), with a fixed or the adaptive step.

use cosim::error_estimate::ErrorEstimate;
use cosim::step_control::{Controller, Tolerances};
use feedcore::genalpha::StepError as IntegratorError;
use feedcore::scene::ValidScene;
use stewart::Compensation;

use super::{Stepper, fixed, stopped, vec6};
use crate::feed::FeedSample;
use crate::monolithic::{Monolithic, MonolithicError, Sample};
use crate::net::Frame;
use crate::simulate::RunError;
use crate::simulate::record::{Observed, Probe, stepped};
use crate::stepping::{Request, Step};
use crate::system::Adaptive;

/// Quantities the monolithic model's adaptive step watches: the cabin's position and
/// orientation (quaternion), the displacement the results are judged by. Not its velocities,
/// accelerations or the platform's wrench, as the co-simulation's interface does: in the index-3
/// model they carry a step-to-step oscillation of the multipliers that decays only by ρ∞ per
/// step, whose third differences the estimate reads as error (measured at C: with them the
/// steps stay at 1e-5…1e-4 s and the run reached the step cap at 10 s).
const WATCHED: usize = 7;

pub(in crate::simulate) struct MonolithicStepper {
    model: AdaptiveMonolithic,
    /// The adaptive step's controller, tolerances and error estimate (a fixed step: none).
    adaptive: Option<(Controller, Tolerances, ErrorEstimate)>,
    /// The feed (scenes with `[control]`).
    compensation: Option<Compensation>,
    method: &'static str,
}

impl MonolithicStepper {
    pub(in crate::simulate) fn new(
        scene: &ValidScene,
        adaptive: Option<&Adaptive>,
        method: &'static str,
    ) -> Result<MonolithicStepper, RunError> {
        let model = Monolithic::new(scene).map_err(|e| RunError::setup(method, &e))?;
        let compensation = scene.control.as_ref().and(model.compensation().cloned());
        let adaptive = match adaptive {
            Some(a) => {
                let ctl = a.controller().map_err(|reason| RunError::Refused { method, reason })?;
                Some((ctl, a.tolerances, ErrorEstimate::of_kind(a.estimate, WATCHED)))
            }
            None => None,
        };
        Ok(MonolithicStepper { model: AdaptiveMonolithic::new(model), adaptive, compensation, method })
    }

    fn probe_of(&self, s: &Sample) -> Probe {
        Probe {
            position: s.cabin.position,
            orientation: s.cabin.orientation,
            wrench: vec6(&s.wrench),
            feed: self.compensation.as_ref().map(|c| {
                let cabin = (&s.cabin.position, &s.cabin.orientation);
                FeedSample::place(
                    c,
                    s.time,
                    cabin,
                    (&s.platform, &s.platform_rotation),
                    s.leg_lengths,
                    s.actuator_forces,
                    s.estimate,
                )
            }),
        }
    }
}

impl Stepper for MonolithicStepper {
    fn compensation(&self) -> Option<&Compensation> {
        self.compensation.as_ref()
    }

    fn probe(&mut self) -> Result<Probe, RunError> {
        let s = self.model.model.sample();
        Ok(self.probe_of(&s))
    }

    fn step(&mut self, request: Request) -> Result<Step<Observed>, RunError> {
        let method = self.method;
        let failed = |e: MonolithicError, t: f64| match e {
            MonolithicError::Stopped { time, reason } => stopped(method, time, reason.to_string()),
            e => stopped(method, e.time().unwrap_or(t), e.to_string()),
        };
        let m = &mut self.model;
        let (h, iterations, rejected) = match (request, self.adaptive.as_mut()) {
            (Request::Adaptive { t_stop }, Some((ctl, tol, estimate))) => {
                let t = m.model.time();
                let a = cosim::adaptive::step(m, estimate, ctl, *tol, t, t_stop).map_err(|e| failed(e, t))?;
                (a.h, a.report.iterations, a.rejected)
            }
            _ => {
                let (h, t) = fixed(method, request)?;
                (h, m.model.step(h).map_err(|e| failed(e, t - h))?.iterations, 0)
            }
        };
        let s = self.model.model.sample();
        let mut step = stepped(h, iterations, 0.0, self.probe_of(&s));
        step.payload.constraint_residual = s.constraint_residual;
        step.rejected = rejected;
        Ok(step)
    }

    fn net(&mut self, frame: &mut Frame) -> bool {
        let m = &mut self.model.model;
        frame.fill_cables(m.cable_system(), m.cable_config());
        let s = m.sample();
        frame.time = s.time;
        frame.platform = (s.platform, s.platform_rotation);
        frame.leg_forces = Some(s.actuator_forces);
        true
    }
}

/// The monolithic model as a stepper that can undo a step (for the adaptive step): a snapshot
/// before every step. The state is restored exactly; the kept factorization only steers Newton,
/// so a retaken step agrees with a first take to the Newton tolerance.
struct AdaptiveMonolithic {
    model: Monolithic,
    before: crate::monolithic::Snapshot,
    /// The state at the last checkpoint (step doubling goes back over two steps).
    checkpoint: crate::monolithic::Snapshot,
    group: Vec<usize>,
    scale: Vec<f64>,
}

impl AdaptiveMonolithic {
    fn new(mut model: Monolithic) -> AdaptiveMonolithic {
        let before = model.snapshot();
        let group: Vec<usize> = [3, 4].iter().enumerate().flat_map(|(g, &n)| [g].repeat(n)).collect();
        let mut start = [0.0; WATCHED];
        watched_of(&model.sample(), &mut start);
        let scale = cosim::Layout::group_scales(&start, &group);
        let checkpoint = model.snapshot();
        AdaptiveMonolithic { model, before, checkpoint, group, scale }
    }
}

fn watched_of(s: &Sample, out: &mut [f64]) {
    let c = &s.cabin;
    let q = c.orientation.quaternion();
    let parts: [&[f64]; 2] = [c.position.as_slice(), &[q.w, q.i, q.j, q.k]];
    for (o, v) in out.iter_mut().zip(parts.into_iter().flatten()) {
        *o = *v;
    }
}

impl cosim::adaptive::Retake for AdaptiveMonolithic {
    type Report = feedcore::genalpha::StepReport;
    type Error = MonolithicError;

    fn try_step(&mut self, h: f64) -> Result<Option<Self::Report>, MonolithicError> {
        self.model.save(&mut self.before);
        match self.model.step(h) {
            Ok(r) => Ok(Some(r)),
            // Newton failed even after halving, or settled on a wrong solution: retry smaller
            Err(MonolithicError::Stopped {
                reason: IntegratorError::NotConverged { .. } | IntegratorError::ConstraintResidual { .. },
                ..
            }) => Ok(None),
            Err(e) => Err(e),
        }
    }

    fn undo(&mut self, _t: f64) -> Result<(), MonolithicError> {
        self.model.restore(&self.before);
        Ok(())
    }

    fn checkpoint(&mut self) -> Result<(), MonolithicError> {
        self.model.save(&mut self.checkpoint);
        Ok(())
    }

    fn back_to_checkpoint(&mut self) -> Result<(), MonolithicError> {
        self.model.restore(&self.checkpoint);
        Ok(())
    }

    fn then(first: Self::Report, next: Self::Report) -> Self::Report {
        first.then(next)
    }

    fn watched(&mut self, out: &mut [f64]) -> Result<(), MonolithicError> {
        watched_of(&self.model.sample(), out);
        Ok(())
    }

    fn groups(&self) -> (&[usize], &[f64]) {
        (&self.group, &self.scale)
    }

    /// Newton converges the configuration far below what the estimate can see.
    fn noise(&self, out: &mut [f64]) {
        out.fill(0.0);
    }

    fn too_small(&self, t: f64, error: f64, h_min: f64) -> MonolithicError {
        MonolithicError::StepTooSmall { time: t, error, h_min }
    }
}
