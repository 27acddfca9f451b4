//! A run checked whole before its first step, then driven through the step loop by the
//! method's stepper.

use std::cell::RefCell;
use std::path::Path;
use std::time::Instant;

use feedcore::scene::{Control, SensorKind, StewartMode, ValidScene};
use stewart::Stewart;

use super::Method;
use super::error::RunError;
use super::record::{Observed, Probe, Recorder};
use super::steppers::{CableStepper, CosimStepper, Coupling, MonolithicStepper, Stepper};
use super::trace::Trace;
use crate::feed::FeedTrace;
use crate::limits::{Footprint, Limits, Plan, PlanError, Schedule, check_memory};
use crate::net::{Frame, Layout, NetSink};
use crate::stepping::{Flow, Request, Unwatched, Watch, drive};

/// A run checked whole, ready to start.
#[derive(Clone, Debug)]
pub struct Run<'a> {
    scene: &'a ValidScene,
    scene_file: &'a Path,
    method: Method,
    schedule: Schedule,
    every: u64,
}

impl<'a> Run<'a> {
    /// Checks everything the run needs before anything is built: the steps against the end time
    /// and the step cap, the memory the models need, and what the method needs from the scene.
    /// `dt` is the fixed step; an adaptive run ([`Method::CosimAdaptive`]) chooses its own.
    pub fn prepare(
        scene: &'a ValidScene,
        scene_file: &'a Path,
        method: Method,
        dt: f64,
        t_end: f64,
        limits: &Limits,
    ) -> Result<Run<'a>, RunError> {
        let name = method.name();
        let refused = |reason: String| RunError::Refused { method: name, reason };
        let schedule = match &method {
            Method::CosimAdaptive(o, a) => {
                if !o.scheme.is_implicit() {
                    return Err(refused(format!(
                        "the adaptive step needs a scheme that iterates (iterative, ijcsa, iqn-ils), not {}",
                        o.scheme.name()
                    )));
                }
                a.controller().map_err(refused)?;
                Schedule::adaptive(t_end, a.h_min, a.h_max, limits).map_err(|e| refused(e.to_string()))?
            }
            Method::MonolithicAdaptive(a) => {
                a.controller().map_err(refused)?;
                Schedule::adaptive(t_end, a.h_min, a.h_max, limits).map_err(|e| refused(e.to_string()))?
            }
            _ => Schedule::Fixed(Plan::new(dt, t_end, limits).map_err(|e| refused(e.to_string()))?),
        };
        let footprint = if matches!(method, Method::CableOnly) { Footprint::CableModel } else { Footprint::Coupled };
        check_memory(scene, footprint, cable::model::CableCabin::modes_built(scene, 0), limits)
            .map_err(|e: PlanError| refused(format!("{}: {e}", scene_file.display())))?;
        let coupled = scene.analyses.stewart == StewartMode::Coupled;
        match method {
            Method::CableOnly => {
                if scene.disturbance.is_none() && coupled {
                    return Err(refused(format!(
                        "{}: `--scheme cable` runs the cable–cabin model under the scene's [disturbance], and this \
                         scene has none (its platform is coupled: run it with a coupling scheme or monolithic)",
                        scene_file.display()
                    )));
                }
            }
            _ if !coupled => {
                return Err(refused(format!(
                    "{}: the scene has no moving platform (analyses.stewart = {:?}); only `--scheme cable` runs it",
                    scene_file.display(),
                    scene.analyses.stewart
                )));
            }
            Method::Decoupled(_) if scene.control.as_ref().is_some_and(|c| c.sensor != SensorKind::Off) => {
                return Err(refused(format!(
                    "{}: the scene's [control] compensates the cabin (sensor = {:?}), which the decoupled model \
                     does not have: run it with a coupling scheme (ijcsa, iqn-ils, ...) or monolithic, or set \
                     control.sensor = \"off\" for the uncompensated feed",
                    scene_file.display(),
                    scene.control.as_ref().map(|c| c.sensor).expect("matched"),
                )));
            }
            Method::Monolithic | Method::MonolithicAdaptive(_)
                if scene.control.as_ref().is_some_and(|c| c.sensor == SensorKind::Ideal) =>
            {
                return Err(refused(format!(
                    "{}: [control] sensor = \"ideal\" makes the legs' strokes follow the cabin's velocity and \
                     acceleration at the step's end, which the monolithic model's position-level driving \
                     constraints cannot express (it would need another formulation): use sensor = \"sampled\", \
                     or a coupling scheme (ijcsa, iqn-ils, ...) for the ideal sensor",
                    scene_file.display(),
                )));
            }
            Method::Monolithic | Method::MonolithicAdaptive(_) => {}
            _ if !scene.analyses.wrench.is_full() => {
                return Err(refused(format!(
                    "{}: `analyses.wrench = \"inertial_only\"` (a hypothesis for the paper's amplitudes) is \
                     implemented in the monolithic model only; run it with `--scheme monolithic`",
                    scene_file.display()
                )));
            }
            Method::Cosim(_) | Method::CosimAdaptive(..) | Method::Decoupled(_) => {
                if scene.system.is_none() {
                    return Err(refused(format!(
                        "{}: the scene has no [system] section (the FMUs and their connections)",
                        scene_file.display()
                    )));
                }
            }
        }
        // a sampled sensor's samples are taken at step starts: no step may skip one
        if let Some(bound) = scene.control.as_ref().and_then(Control::step_bound) {
            let refusal = match schedule {
                Schedule::Fixed(plan) if !bound.admits(plan.dt) => Some(bound.refusal(plan.dt)),
                Schedule::Adaptive { h_max, .. } if !bound.admits(h_max) => {
                    Some(format!("--h-max {h_max} s: {}", bound.refusal(h_max)))
                }
                _ => None,
            };
            if let Some(reason) = refusal {
                return Err(refused(format!("{}: {reason}", scene_file.display())));
            }
        }
        let every = match schedule {
            Schedule::Fixed(plan) => ((scene.outputs.sample_interval_s / plan.dt).round() as u64).clamp(1, plan.steps),
            // every accepted step
            Schedule::Adaptive { .. } => 1,
        };
        Ok(Run { scene, scene_file, method, schedule, every })
    }

    /// The method it runs.
    pub fn method(&self) -> &Method {
        &self.method
    }

    /// Runs it, unwatched.
    pub fn execute(&self) -> Result<Trace, RunError> {
        self.execute_watched(&mut Unwatched)
    }

    /// Runs it, showing every step to `watch` (a progress bar; a caller's callback, which may
    /// stop the run by returning the reason).
    pub fn execute_watched(&self, watch: &mut dyn Watch) -> Result<Trace, RunError> {
        self.execute_with_net(watch, None)
    }

    /// As [`Run::execute_watched`], handing the net to `net` at the start and at every
    /// `every`-th sample after it (methods that have the net: [`Method::net_refusal`]).
    pub fn execute_with_net(
        &self,
        watch: &mut dyn Watch,
        mut net: Option<(&mut dyn NetSink, u64)>,
    ) -> Result<Trace, RunError> {
        let scene = self.scene;
        let name = self.method.name();
        let (dt, sample_interval_s) = match self.schedule {
            Schedule::Fixed(plan) => (plan.dt, self.every as f64 * plan.dt),
            Schedule::Adaptive { .. } => (0.0, 0.0),
        };
        let mut rec = Recorder {
            trace: Trace {
                method: name.into(),
                dt,
                t_end: self.schedule.t_end(),
                sample_interval_s,
                ..Default::default()
            },
            every: self.every,
            origin: None,
            method: name,
        };
        // the feed of a co-simulation (scenes with [control]): placed by the scene's compensation,
        // which the monolithic model carries itself
        let comp = || match &scene.control {
            Some(_) => Ok(Stewart::from_scene(scene).map_err(|e| RunError::setup(name, &e))?.compensation().cloned()),
            None => Ok(None),
        };
        let start = Instant::now();
        let file = self.scene_file;
        let mut stepper: Box<dyn Stepper> = match &self.method {
            Method::CableOnly => Box::new(CableStepper::new(scene, name)?),
            Method::Monolithic => Box::new(MonolithicStepper::new(scene, None, name)?),
            Method::MonolithicAdaptive(a) => Box::new(MonolithicStepper::new(scene, Some(a), name)?),
            Method::Cosim(o) => Box::new(CosimStepper::new(scene, file, Coupling::Fixed(*o), comp()?, name)?),
            Method::CosimAdaptive(o, a) => {
                Box::new(CosimStepper::new(scene, file, Coupling::Adaptive(*o, a), comp()?, name)?)
            }
            Method::Decoupled(o) => Box::new(CosimStepper::new(scene, file, Coupling::Decoupled(*o), comp()?, name)?),
        };
        rec.trace.feed = stepper.compensation().map(FeedTrace::new);
        let first = stepper.probe()?;
        let layout = net.as_ref().map(|_| Layout::of(scene));
        let stepper = RefCell::new(stepper);
        let mut frame = Frame::default();
        let every = self.every;
        // the net at sample k (its time as the trace has it), every `thin`-th sample
        let mut sample_net = |k: u64, t: f64| -> Result<(), RunError> {
            if let (Some((sink, thin)), Some(layout)) = (net.as_mut(), &layout)
                && k.is_multiple_of(every)
                && (k / every).is_multiple_of(*thin)
                && stepper.borrow_mut().net(&mut frame)
            {
                frame.time = t;
                sink.frame(layout, &frame).map_err(|e| RunError::Output { method: name, source: e })?;
            }
            Ok(())
        };
        sample_net(0, 0.0)?;
        self.drive(&mut rec, first, watch, |r| Ok(Flow::Stepped(stepper.borrow_mut().step(r)?)), &mut sample_net)?;
        rec.trace.wall_time_s = start.elapsed().as_secs_f64();
        Ok(rec.trace)
    }
}

impl Run<'_> {
    /// Observes the start, then takes every step with `step` through the step loop, refusing
    /// non-finite values and keeping the summary.
    fn drive(
        &self,
        rec: &mut Recorder,
        first: Probe,
        watch: &mut dyn Watch,
        step: impl FnMut(Request) -> Result<Flow<Observed>, RunError>,
        net: &mut dyn FnMut(u64, f64) -> Result<(), RunError>,
    ) -> Result<(), RunError> {
        let adaptive = matches!(self.schedule, Schedule::Adaptive { .. });
        rec.observe(0, 0.0, &first)?;
        if adaptive {
            rec.trace.h.push(0.0);
        }
        let method = rec.method;
        let totals = drive(
            &self.schedule,
            watch,
            |time, reason| RunError::Stopped { method, time, reason },
            step,
            |k, t, s| {
                let c = s.payload.constraint_residual;
                if !c.is_finite() {
                    return Err(rec.stopped(t, format!("the constraint residual is {c}")));
                }
                let m = &mut rec.trace.summary.max_constraint_residual_m;
                *m = m.max(c);
                rec.observe(k, t, &s.payload.probe)?;
                net(k, t)?;
                if adaptive {
                    rec.trace.h.push(s.h);
                }
                Ok(())
            },
        )?;
        let summary = &mut rec.trace.summary;
        summary.steps = totals.steps;
        summary.iterations = totals.iterations;
        summary.max_interface_residual = totals.max_residual;
        summary.rejected_steps = totals.rejected;
        summary.h_min_used = totals.h_min;
        summary.h_max_used = totals.h_max;
        rec.trace.steps = totals.steps;
        Ok(())
    }
}

/// Runs `scene` (read from `scene_file`) with `method` at step `dt` to `t_end`, within the
/// default [`Limits`].
pub fn simulate(scene: &ValidScene, scene_file: &Path, method: Method, dt: f64, t_end: f64) -> Result<Trace, RunError> {
    Run::prepare(scene, scene_file, method, dt, t_end, &Limits::default())?.execute()
}
