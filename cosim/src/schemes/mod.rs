//! Coupling schemes: how the units of a [`Units`] system advance one macro step together.
//!
//! Schemes at macro step h (and what each needs from the units):
//! * `jacobi`: every unit steps with the inputs from the last communication point;
//! * `gauss-seidel`: the units step one after the other, each with the newest outputs;
//! * `iterative`: fixed point on `U` with rollback, constant relaxation or Aitken (rollback);
//! * `ijcsa`: interface-Jacobian co-simulation (Sicklinger et al. 2014): Newton on
//!   `R(U) = U − C·Y(U)` with the units' step-map derivatives, or central differences with
//!   rollback for a unit without them (rollback);
//! * `iqn-ils`: interface quasi-Newton (Degroote et al. 2009): the inverse Jacobian from the
//!   residual history of this and the last time windows, least squares (rollback).
//!
//! Inputs are values at the end of the macro step (the FMUs of this workspace evaluate their
//! inputs there). With `linear` extrapolation the first guess extrapolates the last two
//! communication points, and non-iterating schemes hand the slope to units that interpolate.

mod adaptive;
mod explicit;
mod fixed_point;
mod ijcsa;
mod iqn;

pub use adaptive::AdaptiveStep;

use crate::error::StepError;
use crate::iqn::IqnOptions;
use crate::system::{Layout, Slot, UnitError, Units};

/// A coupling scheme.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scheme {
    Jacobi,
    /// The units in the order of the system description, or reversed.
    GaussSeidel {
        reversed: bool,
    },
    Iterative,
    Ijcsa,
    /// Interface quasi-Newton, least squares on the residual history.
    IqnIls,
    /// Gauss–Seidel in the order of the data flow: every unit after the ones it takes inputs
    /// from (exact for a system without feedback, e.g. the decoupled model).
    Sequential,
}

impl Scheme {
    pub fn name(self) -> &'static str {
        match self {
            Scheme::Jacobi => "jacobi",
            Scheme::GaussSeidel { reversed: false } => "gauss-seidel",
            Scheme::GaussSeidel { reversed: true } => "gauss-seidel-reversed",
            Scheme::Iterative => "iterative",
            Scheme::Ijcsa => "ijcsa",
            Scheme::IqnIls => "iqn-ils",
            Scheme::Sequential => "sequential",
        }
    }

    /// Iterates every step to a converged interface (and so needs rollback).
    pub fn is_implicit(self) -> bool {
        matches!(self, Scheme::Iterative | Scheme::Ijcsa | Scheme::IqnIls)
    }
}

/// How the first guess of the end-of-step inputs is made.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Extrapolation {
    Constant,
    Linear,
}

/// Acceleration of the fixed-point iteration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Relaxation {
    Fixed(f64),
    Aitken,
}

/// Where the interface Jacobian of `ijcsa` comes from, and how often.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JacobianUpdate {
    /// Recomputed at the first iteration of every step.
    EveryStep,
    /// Kept across steps and updated by Broyden's secant from each step's iterates; a unit
    /// whose block misses the secant by more than 1e-3 is recomputed at the first iteration of
    /// each of the next 100 steps, every unit's when Newton contracts by less than 10× or the
    /// step size changes (best with linear extrapolation: a smaller first residual asks less of
    /// a reused Jacobian).
    Reuse,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Options {
    pub scheme: Scheme,
    pub extrapolation: Extrapolation,
    pub relaxation: Relaxation,
    pub jacobian: JacobianUpdate,
    pub iqn: IqnOptions,
    /// Converged when every |R_i| ≤ tol · s_i, s_i the scale of input i.
    pub tol: f64,
    pub max_iter: usize,
}

impl Default for Options {
    fn default() -> Options {
        Options {
            scheme: Scheme::Ijcsa,
            extrapolation: Extrapolation::Constant,
            relaxation: Relaxation::Fixed(0.5),
            jacobian: JacobianUpdate::EveryStep,
            iqn: IqnOptions::default(),
            tol: 1e-8,
            max_iter: 100,
        }
    }
}

/// What one macro step cost and how well it converged.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepReport {
    /// Evaluations of the whole system (1 for non-iterating schemes).
    pub iterations: usize,
    /// Largest scaled interface residual at the end of the step.
    pub residual: f64,
}

impl StepReport {
    /// What this step and the `next` one, taken after it, cost together; converged as the last.
    pub fn then(self, next: StepReport) -> StepReport {
        StepReport { iterations: self.iterations + next.iterations, residual: next.residual }
    }
}

/// Doublings of the first macro step's substeps ([`Coupled::step_from_start`]): the first is
/// `h / 1024`.
pub const START_SUBSTEPS: u32 = 10;

/// Units coupled by a scheme, stepping in time.
pub struct Coupled<S: Units> {
    core: Core<S>,
    /// The scheme, with the state it keeps from step to step.
    scheme: Box<dyn CouplingScheme<S>>,
    adaptive: adaptive::History,
}

/// What every scheme steps: the units, the coupled values and their history, the buffers.
struct Core<S: Units> {
    units: S,
    options: Options,
    time: f64,
    /// Coupled outputs at the last two communication points (for extrapolation).
    y: Vec<f64>,
    y_prev: Vec<f64>,
    /// The time from `y_prev` to `y` (the last step's size), once there is a last step.
    prev_step: Option<f64>,
    work: Work,
}

/// A coupling scheme: how the units advance one macro step together. It owns what it keeps
/// from step to step, and keeps it for a rollback.
trait CouplingScheme<S: Units> {
    /// One macro step of size `h` from `t`, the units' outputs at `t` in `core.y`: steps every
    /// unit to `t + h` and leaves their outputs there in `core.y`.
    fn step(&mut self, core: &mut Core<S>, t: f64, h: f64) -> Result<StepReport, StepError>;

    /// Keeps what a rollback to `slot` restores of the scheme's own state (none by default).
    fn keep(&mut self, _slot: Slot) {}

    /// Restores what [`CouplingScheme::keep`] kept for `slot`.
    fn roll_back(&mut self, _slot: Slot) {}
}

/// The scheme of `options` for the units of `layout`: the one place a scheme is registered.
fn scheme_for<S: Units>(options: &Options, layout: &Layout) -> Box<dyn CouplingScheme<S>> {
    match options.scheme {
        Scheme::Jacobi => Box::new(explicit::Jacobi),
        Scheme::GaussSeidel { reversed } => Box::new(explicit::GaussSeidel::listed(layout, reversed)),
        Scheme::Sequential => Box::new(explicit::GaussSeidel::data_flow(layout)),
        Scheme::Iterative => Box::new(fixed_point::FixedPoint { relaxation: options.relaxation }),
        Scheme::Ijcsa => Box::new(ijcsa::Ijcsa::new(layout, options.jacobian)),
        Scheme::IqnIls => Box::new(iqn::Iqn::new(layout.inputs(), options.iqn)),
    }
}

impl<S: Units> Coupled<S> {
    /// Couples `units` (initialized, at t = 0) by the scheme of `options`.
    pub fn new(mut units: S, options: Options) -> Result<Coupled<S>, StepError> {
        let (nu, ny) = (units.layout().inputs(), units.layout().outputs());
        if options.scheme.is_implicit() {
            for (k, u) in units.layout().units.iter().enumerate() {
                if !units.capabilities(k).rollback {
                    return Err(StepError::Failed {
                        time: 0.0,
                        reason: format!(
                            "scheme {} needs rollback (get/set FMU state) from every unit; `{}` has none",
                            options.scheme.name(),
                            u.name
                        ),
                    });
                }
            }
        }
        if !options.scheme.is_implicit()
            && let Some(cycle) = units.layout().algebraic_loop()
        {
            let cycle = units.layout().describe_loop(&cycle);
            return Err(StepError::AlgebraicLoop { scheme: options.scheme.name(), cycle });
        }
        let mut y = vec![0.0; ny];
        for k in 0..units.layout().units.len() {
            let r = units.layout().units[k].outputs.clone();
            let name = units.layout().units[k].name.clone();
            units.get_outputs(k, &mut y[r]).map_err(|e| StepError::Unit {
                time: 0.0,
                unit: name,
                source: Box::new(e),
            })?;
        }
        Ok(Coupled {
            adaptive: adaptive::History::new(units.layout()),
            scheme: scheme_for(&options, units.layout()),
            core: Core {
                units,
                options,
                time: 0.0,
                y,
                y_prev: vec![0.0; ny],
                prev_step: None,
                work: Work::new(nu, ny),
            },
        })
    }

    pub fn time(&self) -> f64 {
        self.core.time
    }

    pub fn options(&self) -> &Options {
        &self.core.options
    }

    pub fn units(&self) -> &S {
        &self.core.units
    }

    /// The units, e.g. to read any variable of an FMU between steps.
    pub fn units_mut(&mut self) -> &mut S {
        &mut self.core.units
    }

    /// The coupled outputs `Y` now.
    pub fn outputs(&self) -> &[f64] {
        &self.core.y
    }

    /// One macro step of size `h`.
    pub fn step(&mut self, h: f64) -> Result<StepReport, StepError> {
        let t = self.core.time;
        let t1 = t + h;
        // what `undo_step` restores besides the units
        self.keep(Slot::Step);
        let core = &mut self.core;
        core.units.exchange_discrete().map_err(|(k, e)| core.unit_err(t, k, e))?;
        let report = self.scheme.step(core, t, h)?;
        if core.y.iter().any(|x| !x.is_finite()) {
            return Err(core.failed(t1, "an output is not finite (the coupled motion diverged)"));
        }
        // A coupling value a hundred times its scale (kilonewtons for a weight of a few, hundreds
        // of m/s² for a cabin): the coupled motion has run away; stop before the numbers lie.
        if core.largest_coupled_value().is_some_and(|(_, g)| g > 100.0) {
            let e = core.failed(t1, format!("{} diverged", core.options.scheme.name()));
            return Err(core.unstable(e));
        }
        core.time = t1;
        Ok(report)
    }

    /// The first macro step of a run, from a start the units were initialized for at rest: for
    /// the schemes that solve the interface by (quasi-)Newton (`ijcsa`, `iqn-ils`), substeps
    /// growing from `h / 2^START_SUBSTEPS` (two of that size, then each twice the last, the last
    /// `h / 2`); the others step once (the fixed point's loop gain grows as the step shrinks —
    /// the added mass — and it would not converge). A start that is not
    /// smooth (a motion that begins at full speed) leaves each unit a first acceleration that
    /// cannot include the others' inertia — FMI 2.0 initializes one instant, before the start —
    /// and that inconsistency costs an error in proportion to the first step, of first order in
    /// h. Measured at LT50m C over 2 s with the momentum-consistent start (IJCSA against the
    /// monolithic model's h = 0.0003125): 4.8e-2, 2.3e-2, 1.2e-2 mm at h = 0.01, 0.005, 0.0025 in
    /// one step; 8.2e-3, 2.1e-3, 5.1e-4 mm in substeps, the monolithic model's own second-order
    /// error (8.2e-3, 2.1e-3, 5.1e-4 mm).
    pub fn step_from_start(&mut self, h: f64) -> Result<StepReport, StepError> {
        if !matches!(self.core.options.scheme, Scheme::Ijcsa | Scheme::IqnIls) {
            return self.step(h);
        }
        let end = self.core.time + h;
        let mut piece = h / f64::from(1u32 << START_SUBSTEPS);
        let mut report = StepReport::default();
        for j in 0..=START_SUBSTEPS {
            // the pieces add up to h / 2 exactly (each partial sum is h over a power of two)
            let step = if j == START_SUBSTEPS { end - self.core.time } else { piece };
            report = report.then(self.step(step)?);
            if j > 0 {
                piece *= 2.0;
            }
        }
        Ok(report)
    }

    /// Undoes the last step of an implicit scheme: every unit back to the state saved at its
    /// start (bit for bit), the coupled values, the quasi-Newton history, IJCSA's reused
    /// Jacobian and the time as before it — the step taken again repeats the same iterates.
    pub fn undo_step(&mut self) -> Result<(), StepError> {
        if !self.core.options.scheme.is_implicit() {
            return Err(self.core.failed(self.core.time, "only the implicit schemes save the states to undo a step"));
        }
        self.roll_back(Slot::Step)
    }
}

impl<S: Units> Core<S> {
    fn failed(&self, time: f64, reason: impl Into<String>) -> StepError {
        StepError::Failed { time, reason: reason.into() }
    }

    /// A unit's error at time `t`; an end signal (fmi2Discard) is dated at the last
    /// communication point, which every unit reached.
    fn unit_err(&self, t: f64, k: usize, e: UnitError) -> StepError {
        let unit = self.units.layout().units.get(k).map_or_else(String::new, |u| u.name.clone());
        let time = if matches!(e, UnitError::Ended { .. }) { self.time } else { t };
        StepError::Unit { time, unit, source: Box::new(e) }
    }

    /// Largest scaled |U − C Y|: (value, index).
    fn residual(&self, u: &[f64]) -> (f64, usize) {
        let l = self.units.layout();
        let mut worst = (0.0, 0);
        for (i, &ui) in u.iter().enumerate() {
            let r = (ui - l.coupled(i, &self.y)).abs() / l.scale[i];
            if !(r <= worst.0) {
                worst = (r, i);
            }
        }
        worst
    }

    /// The first guess of the end-of-step inputs into `work.guess` (extrapolated linearly if
    /// asked), and for non-iterating schemes the slope into `work.slope`. Returns whether a
    /// slope is set.
    fn predict(&mut self) -> bool {
        let Core { work, units, y, y_prev, prev_step, options, .. } = self;
        let l = units.layout();
        for (i, g) in work.guess.iter_mut().enumerate() {
            *g = l.coupled(i, y);
        }
        // the slope over the last step, whose size an adaptive step may have changed since
        let Some(h_prev) = prev_step.filter(|_| options.extrapolation == Extrapolation::Linear) else {
            return false;
        };
        for (i, sl) in work.slope.iter_mut().enumerate() {
            *sl = (work.guess[i] - l.coupled(i, y_prev)) / h_prev;
        }
        true
    }

    /// The guess extrapolated to the end of the step (iterating schemes set end values).
    fn predict_end(&mut self, h: f64) {
        if self.predict() {
            for (g, s) in self.work.guess.iter_mut().zip(&self.work.slope) {
                *g += s * h;
            }
        }
    }

    /// An explicit scheme whose interface values grew far beyond their scale is unstable: say so.
    fn unstable(&self, e: StepError) -> StepError {
        let Some((i, g)) = self.largest_coupled_value() else { return e };
        if g < 10.0 || e.ended().is_some() {
            return e;
        }
        let l = self.units.layout();
        StepError::Unstable {
            cause: Box::new(e),
            growth: g,
            variable: l.input_names[i].clone(),
            value: l.coupled(i, &self.y),
            scheme: self.options.scheme.name(),
        }
    }

    /// The coupled value C·Y largest relative to its scale: (index, ratio).
    fn largest_coupled_value(&self) -> Option<(usize, f64)> {
        let l = self.units.layout();
        (0..l.inputs()).map(|i| (i, (l.coupled(i, &self.y) / l.scale[i]).abs())).fold(
            None,
            |a: Option<(usize, f64)>, b| match a {
                Some(a) if !(b.1 > a.1) => Some(a),
                _ => Some(b),
            },
        )
    }

    /// The outputs before the step of size `h` become the history for extrapolation.
    fn keep_history(&mut self, h: f64) {
        self.y_prev.copy_from_slice(&self.y);
        self.prev_step = Some(h);
    }

    /// Sets unit `k`'s inputs from `work.guess` (with `slope`: a unit that interpolates inputs
    /// gets it as an input derivative, another the extrapolated end value), then steps it.
    fn advance(&mut self, k: usize, slope: bool, t: f64, h: f64) -> Result<(), StepError> {
        let Core { units, work, .. } = self;
        let r = units.layout().units[k].inputs.clone();
        let n = r.len();
        let interpolates = units.capabilities(k).interpolates;
        let res = (|| {
            if slope && interpolates {
                units.set_inputs(k, &work.guess[r.clone()])?;
                units.set_input_slopes(k, &work.slope[r.clone()])?;
            } else if slope {
                for (j, i) in r.clone().enumerate() {
                    work.end[j] = work.guess[i] + work.slope[i] * h;
                }
                units.set_inputs(k, &work.end[..n])?;
            } else {
                units.set_inputs(k, &work.guess[r.clone()])?;
            }
            units.do_step(k, t, h)
        })();
        res.map_err(|e| self.unit_err(t + h, k, e))
    }

    /// Reads every unit's coupled outputs into `self.y`.
    fn read_outputs(&mut self, t: f64) -> Result<(), StepError> {
        for k in 0..self.units.layout().units.len() {
            let r = self.units.layout().units[k].outputs.clone();
            if let Err(e) = self.units.get_outputs(k, &mut self.y[r]) {
                return Err(self.unit_err(t, k, e));
            }
        }
        Ok(())
    }

    fn save_states(&mut self, t: f64) -> Result<(), StepError> {
        for k in 0..self.units.layout().units.len() {
            if let Err(e) = self.units.save_state(k, Slot::Step) {
                return Err(self.unit_err(t, k, e));
            }
        }
        Ok(())
    }

    fn restore_states(&mut self, t: f64, slot: Slot) -> Result<(), StepError> {
        for k in 0..self.units.layout().units.len() {
            if let Err(e) = self.units.restore_state(k, slot) {
                return Err(self.unit_err(t, k, e));
            }
        }
        Ok(())
    }

    /// Steps every unit from the saved states with the inputs `work.guess`; outputs into
    /// `self.y`. Returns the finished step's report once the interface residual is within the
    /// tolerance, and fails at the iteration limit; otherwise leaves the fixed-point residual
    /// C·Y − U in `work.r`.
    fn evaluate(&mut self, it: usize, t: f64, h: f64) -> Result<Option<StepReport>, StepError> {
        if it > 1 {
            self.restore_states(t, Slot::Step)?;
        }
        for k in 0..self.units.layout().units.len() {
            self.advance(k, false, t, h)?;
        }
        self.read_outputs(t + h)?;
        let (res, worst) = self.residual(&self.work.guess);
        if res <= self.options.tol {
            return Ok(Some(StepReport { iterations: it, residual: res }));
        }
        if it == self.options.max_iter {
            return Err(StepError::NotConverged {
                time: t + h,
                scheme: self.options.scheme.name(),
                iterations: self.options.max_iter,
                residual: res,
                variable: self.units.layout().input_names[worst].clone(),
                tol: self.options.tol,
            });
        }
        let Core { work, units, y, .. } = self;
        let l = units.layout();
        for (i, r) in work.r.iter_mut().enumerate() {
            *r = l.coupled(i, y) - work.guess[i];
        }
        Ok(None)
    }
}

/// Buffers the schemes reuse every step (no allocation inside the time loop).
struct Work {
    /// Inputs being tried (end-of-step values), their slope, and the fixed-point residual.
    guess: Vec<f64>,
    slope: Vec<f64>,
    r: Vec<f64>,
    r_prev: Vec<f64>,
    /// One unit's input values or seeds, and output column.
    end: Vec<f64>,
    seed: Vec<f64>,
    col: Vec<f64>,
    /// Scaled iterate and fixed-point image for the quasi-Newton update.
    x: Vec<f64>,
    xt: Vec<f64>,
}

impl Work {
    fn new(nu: usize, ny: usize) -> Work {
        Work {
            guess: vec![0.0; nu],
            slope: vec![0.0; nu],
            r: vec![0.0; nu],
            r_prev: vec![0.0; nu],
            end: vec![0.0; nu],
            seed: vec![0.0; nu],
            col: vec![0.0; ny],
            x: vec![0.0; nu],
            xt: vec![0.0; nu],
        }
    }
}
