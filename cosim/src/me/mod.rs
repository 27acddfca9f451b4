//! A Model Exchange FMU as a unit the schemes step like any other: over each macro step the
//! master integrates it ([`solver`]), with its inputs held (or moving along the slope a scheme
//! gives), state events located on the event indicators, time events hit exactly, step events
//! (`completedIntegratorStep`) honoured, and the event iteration run at each event. Its state
//! for a rollback is the FMU's (saved by the system) and the integrator's ([`MeUnit::save`]).

pub mod solver;

use fmi::import::Instance;
use fmi::{VarType, Variability};
use solver::{Integrator, Rhs};
pub use solver::{Method, Tolerances};

use crate::system::UnitError;

/// How the Model Exchange units of a system are integrated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeOptions {
    pub method: Method,
    pub tol: Tolerances,
}

impl Default for MeOptions {
    fn default() -> MeOptions {
        MeOptions { method: Method::Dopri5, tol: Tolerances { rtol: 1e-6, atol: 1e-8 } }
    }
}

/// What a unit's integration did so far. The work — steps, rejected steps, evaluations — counts
/// every try, rolled back or not; the events are those of the run as it went on (a rollback
/// takes back the events of the steps it undoes, so that an iterating scheme reports the
/// system's events once).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MeStats {
    pub steps: u64,
    pub rejected: u64,
    pub state_events: u64,
    pub time_events: u64,
    pub step_events: u64,
    /// Evaluations of the derivatives.
    pub evaluations: u64,
}

/// Event updates at one instant before the event iteration counts as endless.
const MAX_EVENT_UPDATES: usize = 1000;
/// Events in one macro step before an event indicator counts as not settling.
const MAX_EVENTS_PER_STEP: u64 = 10_000;
/// Integrator steps in one macro step before the unit gives up.
const MAX_STEPS_PER_STEP: u64 = 1_000_000;

/// What a rollback slot keeps of the integrator.
#[derive(Clone, Default)]
struct Saved {
    x: Vec<f64>,
    z: Vec<f64>,
    t: f64,
    h: f64,
    next_time_event: Option<f64>,
    /// The event counts (state, time, step).
    events: [u64; 3],
}

/// One Model Exchange unit's integration.
pub(crate) struct MeUnit {
    nx: usize,
    nz: usize,
    needs_completed: bool,
    integrator: Integrator,
    /// The state, its derivative and the event indicators at the unit's time.
    x: Vec<f64>,
    f: Vec<f64>,
    z: Vec<f64>,
    z_new: Vec<f64>,
    z_mid: Vec<f64>,
    x_mid: Vec<f64>,
    next_time_event: Option<f64>,
    /// The connected inputs: value references, values at the step's start, slopes over it.
    inputs: Vec<u32>,
    u0: Vec<f64>,
    slope: Vec<f64>,
    sloped: bool,
    /// Those of them of discrete variability: set in event mode only (an input event), and
    /// never moved along a slope; their positions, value references, values to set, values set.
    discrete: Vec<usize>,
    discrete_vrs: Vec<u32>,
    discrete_new: Vec<f64>,
    discrete_now: Vec<f64>,
    /// The continuous ones likewise.
    continuous: Vec<usize>,
    continuous_vrs: Vec<u32>,
    continuous_new: Vec<f64>,
    /// Out of initialization mode (inputs set from then on obey the modes).
    started: bool,
    /// The unit's time (where the FMU is), and whether it is in event mode for an input event.
    t: f64,
    input_event: bool,
    state_names: Vec<String>,
    saved: [Saved; 2],
    pub(crate) stats: MeStats,
}

/// The FMU as the right-hand side: time, states and (moving) inputs set, derivatives read and
/// checked.
struct FmuRhs<'a> {
    inst: &'a mut Instance,
    inputs: MovingInputs<'a>,
    names: &'a [String],
    evaluations: &'a mut u64,
}

/// The continuous inputs along their slopes from `t0`, if the step has slopes.
struct MovingInputs<'a> {
    slope: Option<(&'a [f64], f64)>,
    u0: &'a [f64],
    positions: &'a [usize],
    vrs: &'a [u32],
    values: &'a mut [f64],
}

impl MovingInputs<'_> {
    fn set(&mut self, inst: &mut Instance, t: f64) -> Result<(), UnitError> {
        if let Some((slope, t0)) = self.slope {
            for (v, &i) in self.values.iter_mut().zip(self.positions) {
                *v = self.u0[i] + slope[i] * (t - t0);
            }
            inst.set_real(self.vrs, self.values)?;
        }
        Ok(())
    }
}

impl Rhs for FmuRhs<'_> {
    fn eval(&mut self, t: f64, x: &[f64], dx: &mut [f64]) -> Result<(), UnitError> {
        *self.evaluations += 1;
        self.inst.set_time(t)?;
        if !x.is_empty() {
            self.inst.set_continuous_states(x)?;
        }
        self.inputs.set(self.inst, t)?;
        self.inst.get_derivatives(dx)?;
        if let Some(i) = dx.iter().position(|d| !d.is_finite()) {
            return Err(UnitError::Other(format!(
                "the derivative of state `{}` is {} at t = {t} (state {:?})",
                self.names[i], dx[i], x
            )));
        }
        Ok(())
    }
}

/// What the last attempted step said, for the message when the step size collapses.
#[derive(Clone, Copy)]
enum Trouble {
    /// Its scaled error norm.
    Error(f64),
    /// Newton's iteration on an implicit stage did not converge.
    Newton,
}

impl Trouble {
    fn describe(self, names: &[String], x: &[f64]) -> String {
        let largest = (0..x.len()).max_by(|&a, &b| x[a].abs().total_cmp(&x[b].abs()));
        let state = largest.map_or(String::new(), |i| format!("; largest state `{}` = {:e}", names[i], x[i]));
        match self {
            Trouble::Error(e) => format!("last error norm {e:.3e}{state}"),
            Trouble::Newton => format!("the implicit stages did not converge{state}"),
        }
    }
}

/// `a` → `b` crosses zero (from a nonzero side).
fn crossed(a: f64, b: f64) -> bool {
    (a > 0.0 && b <= 0.0) || (a < 0.0 && b >= 0.0)
}

impl MeUnit {
    pub(crate) fn new(inst: &Instance, inputs: &[u32], options: MeOptions) -> MeUnit {
        let fmu = inst.fmu();
        let me = fmu.description().model_exchange.clone().unwrap_or_default();
        let (nx, nz) = (me.states.len(), me.event_indicators);
        let state_names = me
            .states
            .iter()
            .map(|s| {
                let v = fmu.description().variables.iter().find(|v| v.value_reference == s.state);
                v.map_or_else(|| format!("#{}", s.state), |v| v.name.clone())
            })
            .collect();
        let saved = || Saved { x: vec![0.0; nx], z: vec![0.0; nz], ..Saved::default() };
        let is_discrete = |vr: u32| {
            let real =
                fmu.description().variables.iter().find(|v| v.value_reference == vr && v.var_type == VarType::Real);
            real.is_some_and(|v| v.variability == Variability::Discrete)
        };
        let (discrete, continuous): (Vec<usize>, Vec<usize>) = (0..inputs.len()).partition(|&i| is_discrete(inputs[i]));
        MeUnit {
            nx,
            nz,
            needs_completed: me.needs_completed_integrator_step,
            integrator: Integrator::new(options.method, options.tol, nx),
            x: vec![0.0; nx],
            f: vec![0.0; nx],
            z: vec![0.0; nz],
            z_new: vec![0.0; nz],
            z_mid: vec![0.0; nz],
            x_mid: vec![0.0; nx],
            next_time_event: None,
            inputs: inputs.to_vec(),
            u0: vec![0.0; inputs.len()],
            slope: vec![0.0; inputs.len()],
            sloped: false,
            discrete_vrs: discrete.iter().map(|&i| inputs[i]).collect(),
            discrete_new: vec![0.0; discrete.len()],
            discrete_now: vec![0.0; discrete.len()],
            discrete,
            continuous_vrs: continuous.iter().map(|&i| inputs[i]).collect(),
            continuous_new: vec![0.0; continuous.len()],
            continuous,
            started: false,
            t: 0.0,
            input_event: false,
            state_names,
            saved: [saved(), saved()],
            stats: MeStats::default(),
        }
    }

    fn other(&self, message: String) -> UnitError {
        UnitError::Other(format!("integrated as Model Exchange: {message}"))
    }

    /// After `exitInitializationMode` at `t0`: the event iteration, then continuous-time mode.
    pub(crate) fn start(&mut self, inst: &mut Instance, t0: f64) -> Result<(), UnitError> {
        (self.started, self.t) = (true, t0);
        self.event(inst, t0)?;
        self.evaluate(inst, t0)?;
        Ok(())
    }

    /// Sets the connected inputs for the next step (their values at its start). In
    /// continuous-time mode only continuous inputs may be set (FMI 2.0 and 3.0): a discrete one
    /// that changes is an input event — event mode, the value, the event iteration.
    pub(crate) fn set_inputs(&mut self, inst: &mut Instance, u: &[f64]) -> Result<(), UnitError> {
        self.u0.copy_from_slice(u);
        self.sloped = false;
        if !self.started || self.discrete.is_empty() {
            return Ok(inst.set_real(&self.inputs, u)?);
        }
        if !self.continuous.is_empty() {
            for (v, &i) in self.continuous_new.iter_mut().zip(&self.continuous) {
                *v = u[i];
            }
            inst.set_real(&self.continuous_vrs, &self.continuous_new)?;
        }
        for (v, &i) in self.discrete_new.iter_mut().zip(&self.discrete) {
            *v = u[i];
        }
        inst.get_real(&self.discrete_vrs, &mut self.discrete_now)?;
        if self.discrete_new.iter().zip(&self.discrete_now).any(|(a, b)| a.to_bits() != b.to_bits()) {
            self.begin_input_event(inst)?;
            inst.set_real(&self.discrete_vrs, &self.discrete_new)?;
            self.end_input_event(inst)?;
        }
        Ok(())
    }

    /// Before a discrete input (any Integer, Boolean or String) that changes is set: event mode
    /// at the unit's time (once for several). Before the start, nothing: initialization mode
    /// takes any input.
    pub(crate) fn begin_input_event(&mut self, inst: &mut Instance) -> Result<(), UnitError> {
        if self.started && !self.input_event {
            inst.set_time(self.t)?;
            inst.enter_event_mode()?;
            self.input_event = true;
        }
        Ok(())
    }

    /// After the discrete inputs of an input event are set: the event iteration, back to
    /// continuous-time mode with the values after it (its events are not the unit's own:
    /// not counted).
    pub(crate) fn end_input_event(&mut self, inst: &mut Instance) -> Result<(), UnitError> {
        if !self.input_event {
            return Ok(());
        }
        self.input_event = false;
        let t = self.t;
        self.event(inst, t)?;
        self.evaluate(inst, t)
    }

    /// Slopes of the inputs over the next step only (of the continuous ones: a discrete input
    /// holds).
    pub(crate) fn slopes_set(&mut self, slopes: &[f64]) {
        self.slope.copy_from_slice(slopes);
        self.sloped = true;
    }

    fn rhs<'a>(&'a mut self, inst: &'a mut Instance, t0: f64) -> (FmuRhs<'a>, &'a mut Integrator) {
        let inputs = MovingInputs {
            slope: self.sloped.then_some((&self.slope[..], t0)),
            u0: &self.u0,
            positions: &self.continuous,
            vrs: &self.continuous_vrs,
            values: &mut self.continuous_new,
        };
        let rhs = FmuRhs { inst, inputs, names: &self.state_names, evaluations: &mut self.stats.evaluations };
        (rhs, &mut self.integrator)
    }

    /// `f` and `z` at `(t, x)` (the FMU left there).
    fn evaluate(&mut self, inst: &mut Instance, t: f64) -> Result<(), UnitError> {
        let (mut f, mut x) = (std::mem::take(&mut self.f), std::mem::take(&mut self.x));
        let result = self.rhs(inst, t).0.eval(t, &x, &mut f);
        (self.f, self.x) = (f, std::mem::take(&mut x));
        result?;
        if self.nz > 0 {
            inst.get_event_indicators(&mut self.z)?;
            self.check_indicators(t, &self.z)?;
        }
        Ok(())
    }

    fn check_indicators(&self, t: f64, z: &[f64]) -> Result<(), UnitError> {
        match z.iter().position(|v| !v.is_finite()) {
            Some(i) => Err(self.other(format!("event indicator {i} is {} at t = {t}", z[i]))),
            None => Ok(()),
        }
    }

    /// The event iteration at `t` (the FMU in event mode from continuous-time mode or from
    /// initialization), back to continuous-time mode with the states it leaves.
    fn event(&mut self, inst: &mut Instance, t: f64) -> Result<(), UnitError> {
        let mut update = None;
        for _ in 0..MAX_EVENT_UPDATES {
            let u = inst.update_discrete_states()?;
            if u.terminate_simulation {
                let signal = if inst.fmu().fmi_major_version() == 3 {
                    "fmi3UpdateDiscreteStates: terminateSimulation"
                } else {
                    "fmi2NewDiscreteStates: terminateSimulation"
                };
                return Err(UnitError::Ended { last_successful_time: Some(t), terminated: true, signal });
            }
            if !u.discrete_states_need_update {
                update = Some(u);
                break;
            }
        }
        let Some(update) = update else {
            return Err(self.other(format!(
                "the event iteration at t = {t} did not end: the FMU asked for another update of its discrete \
                 states {MAX_EVENT_UPDATES} times"
            )));
        };
        inst.enter_continuous_time_mode()?;
        if let Some((nx, nz)) = inst.reported_sizes()?
            && (nx, nz) != (self.nx, self.nz)
        {
            return Err(self.other(format!(
                "at t = {t} the FMU reports {nx} continuous states and {nz} event indicators; its description \
                 declares {} and {} (they may not change)",
                self.nx, self.nz
            )));
        }
        if self.nx > 0 {
            inst.get_continuous_states(&mut self.x)?;
            if let Some(i) = self.x.iter().position(|v| !v.is_finite()) {
                return Err(
                    self.other(format!("state `{}` is {} after the event at t = {t}", self.state_names[i], self.x[i]))
                );
            }
        }
        self.next_time_event = match update.next_event_time {
            Some(te) if !(te > t) => {
                return Err(self.other(format!("the next time event {te} is not after the event at t = {t}")));
            }
            other => other,
        };
        // the derivatives jump at an event: the step size starts anew
        self.integrator.h = 0.0;
        Ok(())
    }

    /// Integrates from `t` to `t + h` with the inputs set (and slopes, if given), handling every
    /// event on the way; the FMU is left at `t + h`.
    pub(crate) fn advance(&mut self, inst: &mut Instance, t: f64, h: f64) -> Result<(), UnitError> {
        let result = self.integrate(inst, t, t + h);
        self.sloped = false;
        self.t = t + h;
        result
    }

    fn integrate(&mut self, inst: &mut Instance, t_start: f64, t_end: f64) -> Result<(), UnitError> {
        let mut t = t_start;
        // the inputs may have changed since the last step: derivatives and indicators anew, and
        // an indicator that changed sign with them is an event now
        self.z_new.copy_from_slice(&self.z);
        self.evaluate(inst, t)?;
        if (0..self.nz).any(|i| crossed(self.z_new[i], self.z[i])) {
            self.handle(inst, t, false, 1)?;
        }
        let (mut steps, mut events) = (0u64, 0u64);
        let mut last_trouble = Trouble::Error(0.0);
        let tiny = |t: f64| 4.0 * f64::EPSILON * t.abs().max(1.0);
        while t_end - t > tiny(t_end) {
            let target = self.next_time_event.map_or(t_end, |te| te.min(t_end));
            if target - t <= tiny(target) {
                // a time event now
                t = target;
                events += 1;
                self.time_event(inst, t, events)?;
                continue;
            }
            if self.nx == 0 {
                // nothing to integrate: straight to the next event or the end
                t = target;
                self.evaluate(inst, t)?;
                if self.next_time_event.is_some_and(|te| te <= t + tiny(t)) {
                    events += 1;
                    self.time_event(inst, t, events)?;
                }
                continue;
            }
            steps += 1;
            if steps > MAX_STEPS_PER_STEP {
                let hint = match self.integrator.method {
                    Method::Dopri5 => "; a stiff model needs --me-solver esdirk3",
                    Method::Esdirk3 => "",
                };
                return Err(self.other(format!(
                    "{MAX_STEPS_PER_STEP} integrator steps from t = {t_start} without reaching t = {t_end} (at \
                     t = {t}){hint}"
                )));
            }
            if self.integrator.h == 0.0 {
                self.integrator.h = self.integrator.initial_step(&self.x, &self.f, target - t);
            }
            // a step the clock can hardly resolve: the tolerance cannot be met (a blow-up, a
            // discontinuity no indicator announces, an implicit stage that does not converge)
            if !(self.integrator.h > 4.0 * tiny(t)) {
                return Err(self.other(format!(
                    "the {} solver cannot meet the tolerance (rtol {:e}, atol {:e}) at t = {t}: its step fell to \
                     {:e} s ({})",
                    self.integrator.method.name(),
                    self.integrator.tol.rtol,
                    self.integrator.tol.atol,
                    self.integrator.h,
                    last_trouble.describe(&self.state_names, &self.x)
                )));
            }
            let mut h = self.integrator.h.min(target - t);
            if t + 1.01 * h >= target {
                h = target - t;
            }
            let (x, f) = (std::mem::take(&mut self.x), std::mem::take(&mut self.f));
            let attempt = {
                let (mut rhs, integrator) = self.rhs(inst, t_start);
                integrator.attempt(&mut rhs, t, h, &x, &f)
            };
            (self.x, self.f) = (x, f);
            let attempt = attempt?;
            last_trouble = if attempt.failed { Trouble::Newton } else { Trouble::Error(attempt.err) };
            if attempt.failed || !(attempt.err <= 1.0) {
                self.stats.rejected += 1;
                self.integrator.h =
                    if attempt.failed { h / 4.0 } else { self.integrator.next_size(h, attempt.err.min(1e10), false) };
                continue;
            }
            self.stats.steps += 1;
            self.integrator.h = self.integrator.next_size(h, attempt.err, true);
            let t1 = t + h;
            // the FMU is at (t1, x_new): its indicators there
            let mut state_event = false;
            if self.nz > 0 {
                inst.get_event_indicators(&mut self.z_new)?;
                self.check_indicators(t1, &self.z_new)?;
                state_event = (0..self.nz).any(|i| crossed(self.z[i], self.z_new[i]));
            }
            if state_event {
                t = self.locate(inst, t_start, t, t1)?;
            } else {
                t = t1;
                self.x.copy_from_slice(&self.integrator.x_new);
                self.f.copy_from_slice(&self.integrator.f_new);
                self.z.copy_from_slice(&self.z_new);
            }
            let mut step_event = false;
            if self.needs_completed {
                let (event, terminate) = inst.completed_integrator_step(false)?;
                if terminate {
                    let signal = "completedIntegratorStep: terminateSimulation";
                    return Err(UnitError::Ended { last_successful_time: Some(t), terminated: true, signal });
                }
                step_event = event;
            }
            let time_event = self.next_time_event.is_some_and(|te| te <= t + tiny(t));
            if state_event || step_event || time_event {
                events += 1;
                self.stats.state_events += u64::from(state_event);
                self.stats.step_events += u64::from(step_event && !state_event);
                self.stats.time_events += u64::from(time_event && !state_event && !step_event);
                self.handle(inst, t, false, events)?;
            }
        }
        // the FMU at the end, with the inputs there
        if self.nx > 0 || self.sloped {
            self.evaluate(inst, t_end)?;
        } else {
            inst.set_time(t_end)?;
        }
        Ok(())
    }

    fn time_event(&mut self, inst: &mut Instance, t: f64, events: u64) -> Result<(), UnitError> {
        self.stats.time_events += 1;
        self.handle(inst, t, true, events)
    }

    /// An event at `t`: event mode, the event iteration, the values after it.
    fn handle(&mut self, inst: &mut Instance, t: f64, _time: bool, events: u64) -> Result<(), UnitError> {
        if events > MAX_EVENTS_PER_STEP {
            return Err(self.other(format!(
                "{MAX_EVENTS_PER_STEP} events in one macro step, the last at t = {t}: an event indicator does not \
                 settle (indicators now {:?})",
                self.z
            )));
        }
        inst.set_time(t)?;
        inst.enter_event_mode()?;
        self.event(inst, t)?;
        self.evaluate(inst, t)
    }

    /// The first zero crossing of the indicators in (t0, t1], on the integrator's dense output:
    /// regula falsi (Illinois) on the indicator that crossed most, bisection as its safeguard,
    /// to 1e-12 of the step. Leaves the unit, and the FMU, at the crossing's right end.
    fn locate(&mut self, inst: &mut Instance, t_start: f64, t0: f64, t1: f64) -> Result<f64, UnitError> {
        let (mut tl, mut tr) = (t0, t1);
        // zl: the indicators at tl (self.z); zr at tr (self.z_new)
        let width = 1e-12 * (t1 - t0) + 2.0 * f64::EPSILON * t1.abs();
        let mut side = 0i8;
        for _ in 0..200 {
            if tr - tl <= width {
                break;
            }
            // the indicator that crossed with the largest relative change picks the secant point
            let i = (0..self.nz)
                .filter(|&i| crossed(self.z[i], self.z_new[i]))
                .max_by(|&a, &b| {
                    let r = |i: usize| self.z[i].abs() / (self.z[i] - self.z_new[i]).abs();
                    r(b).total_cmp(&r(a))
                })
                .unwrap_or(0);
            let (mut zl, mut zr) = (self.z[i], self.z_new[i]);
            if side == 1 {
                zl *= 0.5;
            } else if side == -1 {
                zr *= 0.5;
            }
            let mut tm = tl + (tr - tl) * zl / (zl - zr);
            if !(tm > tl + 0.25 * width && tm < tr - 0.25 * width) {
                tm = 0.5 * (tl + tr);
            }
            self.integrator.dense_at(tm, &mut self.x_mid);
            self.stats.evaluations += 1;
            inst.set_time(tm)?;
            inst.set_continuous_states(&self.x_mid)?;
            let rhs = &mut self.rhs(inst, t_start).0;
            rhs.inputs.set(rhs.inst, tm)?;
            inst.get_event_indicators(&mut self.z_mid)?;
            self.check_indicators(tm, &self.z_mid)?;
            if (0..self.nz).any(|k| crossed(self.z[k], self.z_mid[k])) {
                tr = tm;
                self.z_new.copy_from_slice(&self.z_mid);
                side = if side == -1 { -2 } else { 1 };
            } else {
                tl = tm;
                self.z.copy_from_slice(&self.z_mid);
                side = if side == 1 { 2 } else { -1 };
            }
            if side.abs() == 2 {
                side = 0;
            }
        }
        // the unit at the crossing's right end
        self.integrator.dense_at(tr, &mut self.x);
        let (mut x, mut f) = (std::mem::take(&mut self.x), std::mem::take(&mut self.f));
        let result = self.rhs(inst, t_start).0.eval(tr, &x, &mut f);
        (self.x, self.f) = (std::mem::take(&mut x), f);
        result?;
        self.z.copy_from_slice(&self.z_new);
        Ok(tr)
    }

    pub(crate) fn method_name(&self) -> &'static str {
        self.integrator.method.name()
    }

    /// Keeps the integrator's state in rollback slot `slot` (the FMU's is kept beside it).
    pub(crate) fn save(&mut self, slot: usize) {
        let s = &mut self.saved[slot];
        s.x.copy_from_slice(&self.x);
        s.z.copy_from_slice(&self.z);
        s.t = self.t;
        s.h = self.integrator.h;
        s.next_time_event = self.next_time_event;
        s.events = [self.stats.state_events, self.stats.time_events, self.stats.step_events];
    }

    /// Restores what [`MeUnit::save`] kept, bit for bit.
    pub(crate) fn restore(&mut self, slot: usize) {
        let s = &self.saved[slot];
        self.x.copy_from_slice(&s.x);
        self.z.copy_from_slice(&s.z);
        self.t = s.t;
        self.integrator.h = s.h;
        self.next_time_event = s.next_time_event;
        [self.stats.state_events, self.stats.time_events, self.stats.step_events] = s.events;
    }
}
