//! Co-simulation of FMUs coupled through their connected inputs and outputs.
//!
//! The system comes from the scene's `[system]` section: FMU archives, prefix connections and
//! parameters. The interface unknowns are all connected inputs, stacked FMU by FMU: `U`. After a
//! step every FMU `k` has outputs `Y_k(U_k)`; the coupling asks `U = C Y` (C picks, for every
//! input, the output connected to it).
//!
//! Schemes at macro step h (what each needs from the FMUs):
//! * `jacobi`: every FMU steps with the inputs from the last communication point;
//! * `gauss-seidel`: the FMUs step one after the other, each with the newest outputs;
//! * `iterative`: fixed point on `U` with rollback (get/set FMU state), relaxation or Aitken
//!   acceleration — needs `canGetAndSetFMUstate`;
//! * `ijcsa`: interface-Jacobian-based co-simulation (Sicklinger et al. 2014): Newton on
//!   `R(U) = U − C Y(U)` with `∂Y/∂U` from `fmi2GetDirectionalDerivative` (finite differences
//!   with rollback for an FMU that does not provide them), optionally kept across steps
//!   (quasi-Newton) — needs `canGetAndSetFMUstate`.
//!
//! Inputs are values at the end of the macro step (both FMUs of this workspace evaluate their
//! inputs there). With `linear` extrapolation the first guess extrapolates the last two
//! communication points, and non-iterating schemes hand the slope to the FMU through
//! `fmi2SetRealInputDerivatives` (needs `canInterpolateInputs`).

use std::fmt;
use std::path::{Path, PathBuf};

use feedcore::scene::Scene;
use fmi2::import::{Capability, Fmu, FmuState, Instance};
use fmi2::{Causality, VarType};

/// A coupling scheme.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scheme {
    Jacobi,
    /// The FMUs in the order of the system description, or reversed.
    GaussSeidel {
        reversed: bool,
    },
    Iterative,
    Ijcsa,
    /// Gauss–Seidel in the order of the data flow: every FMU after the ones it takes inputs
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
            Scheme::Sequential => "sequential",
        }
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

/// Where the interface Jacobian comes from, and how often.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JacobianUpdate {
    /// Recomputed at the first iteration of every step.
    EveryStep,
    /// Kept across steps while Newton contracts well (quasi-Newton); recomputed otherwise.
    Reuse,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Options {
    pub scheme: Scheme,
    pub extrapolation: Extrapolation,
    pub relaxation: Relaxation,
    pub jacobian: JacobianUpdate,
    /// Converged when every |R_i| ≤ tol · s_i, s_i the largest start value (at least 1) among
    /// the inputs of the same FMU with the same unit as input i.
    pub tol: f64,
    pub max_iter: usize,
}

/// A co-simulation that could not go on.
#[derive(Debug)]
pub struct CosimError {
    pub time: f64,
    pub reason: String,
}

impl fmt::Display for CosimError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "co-simulation stopped at t = {:.6} s: {}", self.time, self.reason)
    }
}

impl std::error::Error for CosimError {}

/// One FMU instance and its connected variables.
struct Unit {
    name: String,
    inst: Instance,
    /// Connected inputs (value references) and their position in U.
    inputs: Vec<u32>,
    input_offset: usize,
    /// Connected outputs and their position in Y.
    outputs: Vec<u32>,
    output_offset: usize,
    derivatives: bool,
    interpolates: bool,
    state: Option<FmuState>,
}

/// What one macro step cost and how well it converged.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepReport {
    /// FMU step evaluations of the whole system (1 for non-iterating schemes).
    pub iterations: usize,
    /// Largest scaled interface residual at the end of the step.
    pub residual: f64,
}

/// The coupled FMUs.
pub struct Coupled {
    units: Vec<Unit>,
    /// For every entry of U: the entry of Y connected to it.
    source: Vec<usize>,
    /// Scale of every entry of U for the convergence test.
    scale: Vec<f64>,
    /// Names of the entries of U (`fmu.variable`), for messages.
    input_names: Vec<String>,
    time: f64,
    options: Options,
    /// Outputs at the last two communication points (for extrapolation).
    y: Vec<f64>,
    y_prev: Vec<f64>,
    has_prev: bool,
    /// Interface Jacobian ∂Y/∂U (block diagonal over the units), dense; set once computed.
    dydu: nalgebra::DMatrix<f64>,
    has_jacobian: bool,
    /// The order in which Gauss–Seidel-type schemes step the units.
    order: Vec<usize>,
    work: Work,
}

/// Resolves a scene-relative path.
fn relative_to(scene_file: &Path, path: &str) -> PathBuf {
    let p = Path::new(path);
    if p.is_absolute() { p.to_owned() } else { scene_file.parent().unwrap_or(Path::new(".")).join(p) }
}

impl Coupled {
    /// Loads and initializes the FMUs of `scene` (read from `scene_file`) at t = 0.
    pub fn new(scene: &Scene, scene_file: &Path, options: Options) -> Result<Coupled, Box<dyn std::error::Error>> {
        let sys = scene.system.as_ref().ok_or_else(|| {
            format!("{}: the scene has no [system] section (FMUs and their connections)", scene_file.display())
        })?;
        let scene_abs = std::fs::canonicalize(scene_file)?;
        let mut fmus = Vec::new();
        for f in &sys.fmus {
            let path = relative_to(scene_file, &f.path);
            if !path.is_file() {
                return Err(format!(
                    "FMU `{}`: {} not found (build the FMUs with `cargo build --release --workspace && target/release/master package --out dist`)",
                    f.name,
                    path.display()
                )
                .into());
            }
            fmus.push(Fmu::load(&path)?);
        }
        let needs_rollback = matches!(options.scheme, Scheme::Iterative | Scheme::Ijcsa);
        let mut units = Vec::new();
        for (f, fmu) in sys.fmus.iter().zip(&fmus) {
            if needs_rollback {
                fmu.require(Capability::GetSetState)
                    .map_err(|e| format!("scheme {} needs rollback: {e}", options.scheme.name()))?;
            }
            let flags = &fmu.description().flags;
            let mut inst = fmu.instantiate(&f.name, false)?;
            inst.setup_experiment(None, 0.0, None)?;
            inst.enter_initialization_mode()?;
            units.push(Unit {
                name: f.name.clone(),
                // IJCSA needs the step map's derivative: the opt-in extension, not FMI 2.0's
                // instantaneous fmi2GetDirectionalDerivative.
                derivatives: flags.provides_step_map_derivative,
                interpolates: flags.can_interpolate_inputs,
                inst,
                inputs: Vec::new(),
                input_offset: 0,
                outputs: Vec::new(),
                output_offset: 0,
                state: None,
            });
        }
        let unit_of = |name: &str| sys.fmus.iter().position(|f| f.name == name);
        // parameters
        for (key, value) in &sys.parameters {
            let (fmu_name, var) = key.split_once('.').expect("validated scene");
            let k = unit_of(fmu_name).expect("validated scene");
            let v = fmus[k].variable(var).map_err(|e| format!("system.parameters.{key}: {e}"))?.clone();
            let value = if value == "@scene" { scene_abs.display().to_string() } else { value.clone() };
            let bad = |e: String| format!("system.parameters.{key} = {value}: {e}");
            let inst = &mut units[k].inst;
            match v.var_type {
                VarType::Real => {
                    inst.set_real(&[v.value_reference], &[value.parse().map_err(|e| bad(format!("{e}")))?])?
                }
                VarType::Integer => {
                    inst.set_integer(&[v.value_reference], &[value.parse().map_err(|e| bad(format!("{e}")))?])?
                }
                VarType::Boolean => {
                    inst.set_boolean(&[v.value_reference], &[value.parse().map_err(|e| bad(format!("{e}")))?])?
                }
                VarType::String => inst.set_string(&[v.value_reference], &[value.as_str()])?,
            }
        }
        // connections: prefix matching of output names to input names
        let mut links: Vec<(usize, u32, usize, u32, String)> = Vec::new();
        for c in &sys.connections {
            let (from_fmu, from_prefix) = c.from.split_once('.').expect("validated scene");
            let (to_fmu, to_prefix) = c.to.split_once('.').expect("validated scene");
            let (a, b) = (unit_of(from_fmu).expect("validated"), unit_of(to_fmu).expect("validated"));
            let mut count = 0;
            for v in &fmus[a].description().variables {
                if v.causality != Causality::Output || v.var_type != VarType::Real {
                    continue;
                }
                let Some(suffix) = v
                    .name
                    .strip_prefix(from_prefix)
                    .filter(|s| s.starts_with('.') || s.starts_with('[') || s.is_empty())
                else {
                    continue;
                };
                let target = format!("{to_prefix}{suffix}");
                let t = fmus[b].variable(&target).map_err(|_| {
                    format!(
                        "connection {} → {}: `{}` has no input `{target}` for output `{}`",
                        c.from, c.to, to_fmu, v.name
                    )
                })?;
                if t.causality != Causality::Input || t.var_type != VarType::Real {
                    return Err(
                        format!("connection {} → {}: `{to_fmu}.{target}` is not a Real input", c.from, c.to).into()
                    );
                }
                links.push((a, v.value_reference, b, t.value_reference, format!("{to_fmu}.{target}")));
                count += 1;
            }
            if count == 0 {
                return Err(format!(
                    "connection {} → {}: `{from_fmu}` has no Real output named `{from_prefix}…`",
                    c.from, c.to
                )
                .into());
            }
        }
        // layout of U and Y
        let (mut nu, mut ny) = (0, 0);
        let mut input_names = Vec::new();
        for (k, unit) in units.iter_mut().enumerate() {
            unit.input_offset = nu;
            for l in links.iter().filter(|l| l.2 == k) {
                if unit.inputs.contains(&l.3) {
                    return Err(format!("input `{}` is connected twice", l.4).into());
                }
                unit.inputs.push(l.3);
                input_names.push(l.4.clone());
            }
            nu += unit.inputs.len();
            unit.output_offset = ny;
            for l in links.iter().filter(|l| l.0 == k) {
                if !unit.outputs.contains(&l.1) {
                    unit.outputs.push(l.1);
                }
            }
            ny += unit.outputs.len();
        }
        let mut source = vec![0; nu];
        for (k, unit) in units.iter().enumerate() {
            for (j, vr) in unit.inputs.iter().enumerate() {
                let l = links.iter().find(|l| l.2 == k && l.3 == *vr).expect("listed above");
                let src = &units[l.0];
                source[unit.input_offset + j] =
                    src.output_offset + src.outputs.iter().position(|o| *o == l.1).expect("listed");
            }
        }
        // Consistent initial values: connected inputs from the connected outputs, in
        // initialization mode, until they no longer change (FMI 2.0: the FMUs start from the
        // inputs they hold at fmi2ExitInitializationMode). A minimal fixed point; the coupling
        // work replaces it with the master's own initialization.
        for _ in 0..20 {
            let mut changed = false;
            for k in 0..units.len() {
                let mut values = Vec::with_capacity(units[k].inputs.len());
                for l in links.iter().filter(|l| l.2 == k) {
                    let mut y = [0.0];
                    units[l.0].inst.get_real(&[l.1], &mut y)?;
                    values.push((l.3, y[0]));
                }
                for (vr, y) in values {
                    let mut u = [0.0];
                    units[k].inst.get_real(&[vr], &mut u)?;
                    if u[0] != y {
                        units[k].inst.set_real(&[vr], &[y])?;
                        changed = true;
                    }
                }
            }
            if !changed {
                break;
            }
        }
        for unit in units.iter_mut() {
            unit.inst.exit_initialization_mode()?;
        }
        let mut c = Coupled {
            units,
            source,
            scale: vec![1.0; nu],
            input_names,
            time: 0.0,
            options,
            y: vec![0.0; ny],
            y_prev: vec![0.0; ny],
            has_prev: false,
            dydu: nalgebra::DMatrix::zeros(ny, nu),
            has_jacobian: false,
            order: Vec::new(),
            work: Work::new(nu, ny),
        };
        c.order = c.sequence();
        c.read_outputs()?;
        // Scale of each input for the convergence test: the largest start value among the
        // inputs of its FMU with the same unit (so the components of a force share one scale),
        // at least 1.
        let mut u0 = vec![0.0; nu];
        c.read_inputs(&mut u0)?;
        let units: Vec<(usize, Option<String>)> = c
            .units
            .iter()
            .enumerate()
            .flat_map(|(k, unit)| {
                let fmu = &fmus[k];
                unit.inputs
                    .iter()
                    .map(|vr| {
                        let v = fmu
                            .description()
                            .variables
                            .iter()
                            .find(|v| v.value_reference == *vr && v.var_type == VarType::Real);
                        (k, v.and_then(|v| v.unit.clone()))
                    })
                    .collect::<Vec<_>>()
            })
            .collect();
        c.scale = (0..nu)
            .map(|i| (0..nu).filter(|&j| units[j] == units[i]).map(|j| u0[j].abs()).fold(1.0, f64::max))
            .collect();
        Ok(c)
    }

    pub fn time(&self) -> f64 {
        self.time
    }

    /// The FMU named `name`, to read any of its variables.
    pub fn instance(&mut self, name: &str) -> Option<&mut Instance> {
        self.units.iter_mut().find(|u| u.name == name).map(|u| &mut u.inst)
    }

    fn read_outputs(&mut self) -> Result<(), fmi2::import::Error> {
        for u in self.units.iter_mut() {
            let (o, n) = (u.output_offset, u.outputs.len());
            u.inst.get_real(&u.outputs, &mut self.y[o..o + n])?;
        }
        Ok(())
    }

    fn read_inputs(&mut self, out: &mut [f64]) -> Result<(), fmi2::import::Error> {
        for u in self.units.iter_mut() {
            let (o, n) = (u.input_offset, u.inputs.len());
            u.inst.get_real(&u.inputs, &mut out[o..o + n])?;
        }
        Ok(())
    }

    /// Largest scaled |U − C Y|.
    fn residual(&self, u: &[f64]) -> (f64, usize) {
        let mut worst = (0.0, 0);
        for (i, (&ui, &s)) in u.iter().zip(&self.source).enumerate() {
            let r = (ui - self.y[s]).abs() / self.scale[i];
            if !(r <= worst.0) {
                worst = (r, i);
            }
        }
        worst
    }

    fn err(&self, t: f64, reason: impl Into<String>) -> CosimError {
        CosimError { time: t, reason: reason.into() }
    }

    /// The first guess of the end-of-step inputs into `work.guess` (extrapolated linearly if
    /// asked), and for non-iterating schemes the slope into `work.slope`. Returns whether a
    /// slope is set.
    fn predict(&mut self, h: f64) -> bool {
        let Coupled { work, source, y, y_prev, has_prev, options, .. } = self;
        for (g, &s) in work.guess.iter_mut().zip(source.iter()) {
            *g = y[s];
        }
        if !(*has_prev && options.extrapolation == Extrapolation::Linear) {
            return false;
        }
        for ((sl, g), &s) in work.slope.iter_mut().zip(&work.guess).zip(source.iter()) {
            *sl = (g - y_prev[s]) / h;
        }
        true
    }

    /// The guess extrapolated to the end of the step (iterating schemes set end values).
    fn predict_end(&mut self, h: f64) {
        if self.predict(h) {
            for (g, s) in self.work.guess.iter_mut().zip(&self.work.slope) {
                *g += s * h;
            }
        }
    }

    /// An explicit scheme whose interface values grew far beyond their scale is unstable: say so.
    fn unstable(&self, e: CosimError) -> CosimError {
        let Some((i, g)) = self.largest_coupled_value() else { return e };
        if g < 10.0 {
            return e;
        }
        CosimError {
            time: e.time,
            reason: format!(
                "{}; the coupled inputs had grown to {g:.0}× their scale (`{}` = {:.3e}): {} is unstable here \
                 (the platform's added mass on the cabin); use ijcsa or iterative",
                e.reason,
                self.input_names[i],
                self.y[self.source[i]],
                self.options.scheme.name()
            ),
        }
    }

    /// The coupled value C·Y largest relative to its scale: (index, ratio).
    fn largest_coupled_value(&self) -> Option<(usize, f64)> {
        (0..self.source.len()).map(|i| (i, (self.y[self.source[i]] / self.scale[i]).abs())).fold(
            None,
            |a: Option<(usize, f64)>, b| match a {
                Some(a) if !(b.1 > a.1) => Some(a),
                _ => Some(b),
            },
        )
    }

    /// One macro step of size `h`.
    pub fn step(&mut self, h: f64) -> Result<StepReport, CosimError> {
        let t = self.time;
        let t1 = t + h;
        let report = match self.options.scheme {
            Scheme::Jacobi => self.step_jacobi(t, h).map_err(|e| self.unstable(e))?,
            Scheme::GaussSeidel { .. } => self.step_gauss_seidel(t, h).map_err(|e| self.unstable(e))?,
            Scheme::Sequential => self.step_gauss_seidel(t, h)?,
            Scheme::Iterative => self.step_iterative(t, h)?,
            Scheme::Ijcsa => self.step_ijcsa(t, h)?,
        };
        if self.y.iter().any(|x| !x.is_finite()) {
            return Err(self.err(t1, "an output is not finite (the coupled motion diverged)"));
        }
        // A coupling value a hundred times its scale (kilonewtons for a weight of a few, hundreds
        // of m/s² for a cabin): the coupled motion has run away; stop before the numbers lie.
        if self.largest_coupled_value().is_some_and(|(_, g)| g > 100.0) {
            return Err(self.unstable(self.err(t1, format!("{} diverged", self.options.scheme.name()))));
        }
        self.time = t1;
        Ok(report)
    }

    /// The outputs before the step become the history for extrapolation.
    fn keep_history(&mut self) {
        self.y_prev.copy_from_slice(&self.y);
        self.has_prev = true;
    }

    /// Sets unit `k`'s inputs from `work.guess` (with `slope`: an FMU that interpolates inputs
    /// gets it through `fmi2SetRealInputDerivatives`, another the extrapolated end value), then
    /// steps it.
    fn advance(&mut self, k: usize, slope: bool, t: f64, h: f64) -> Result<(), CosimError> {
        let Coupled { units, work, .. } = self;
        let unit = &mut units[k];
        let (o, n) = (unit.input_offset, unit.inputs.len());
        let (u, s) = (&work.guess[o..o + n], &work.slope[o..o + n]);
        let r = (|| {
            if slope && unit.interpolates {
                unit.inst.set_real(&unit.inputs, u)?;
                unit.inst.set_real_input_derivatives(&unit.inputs, &work.ones[..n], s)?;
            } else if slope {
                for i in 0..n {
                    work.end[i] = u[i] + s[i] * h;
                }
                unit.inst.set_real(&unit.inputs, &work.end[..n])?;
            } else {
                unit.inst.set_real(&unit.inputs, u)?;
            }
            unit.inst.do_step(t, h)
        })();
        r.map_err(|e| CosimError { time: t + h, reason: format!("FMU `{}`: {e}", unit.name) })
    }

    fn step_jacobi(&mut self, t: f64, h: f64) -> Result<StepReport, CosimError> {
        // With a slope the FMUs extrapolate from the last communication point themselves.
        let slope = self.predict(h);
        self.keep_history();
        for k in 0..self.units.len() {
            self.advance(k, slope, t, h)?;
        }
        self.finish_step(t + h)
    }

    /// The units ordered so that each comes after those it takes inputs from (Kahn's algorithm;
    /// units on a feedback loop keep their listed order).
    fn flow_order(&self) -> Vec<usize> {
        let n = self.units.len();
        let owner =
            |y: usize| self.units.iter().position(|u| y >= u.output_offset && y < u.output_offset + u.outputs.len());
        let feeds = |k: usize| -> Vec<usize> {
            let u = &self.units[k];
            (u.input_offset..u.input_offset + u.inputs.len())
                .filter_map(|i| owner(self.source[i]))
                .filter(|&j| j != k)
                .collect()
        };
        let mut order = Vec::with_capacity(n);
        while order.len() < n {
            let next = (0..n)
                .filter(|k| !order.contains(k))
                .find(|&k| feeds(k).iter().all(|j| order.contains(j)))
                .or_else(|| (0..n).find(|k| !order.contains(k)));
            order.push(next.expect("a unit is left"));
        }
        order
    }

    /// The order in which Gauss–Seidel-type schemes step the units.
    fn sequence(&self) -> Vec<usize> {
        match self.options.scheme {
            Scheme::GaussSeidel { reversed: true } => (0..self.units.len()).rev().collect(),
            Scheme::Sequential => self.flow_order(),
            _ => (0..self.units.len()).collect(),
        }
    }

    fn step_gauss_seidel(&mut self, t: f64, h: f64) -> Result<StepReport, CosimError> {
        let slope = self.predict(h);
        self.keep_history();
        for step in 0..self.order.len() {
            let k = self.order[step];
            self.advance(k, slope, t, h)?;
            // the newest outputs of this unit feed the ones after it
            let Coupled { units, y, work, source, .. } = self;
            let unit = &mut units[k];
            let (o, n) = (unit.output_offset, unit.outputs.len());
            unit.inst
                .get_real(&unit.outputs, &mut y[o..o + n])
                .map_err(|e| CosimError { time: t + h, reason: e.to_string() })?;
            for (i, &src) in source.iter().enumerate() {
                if src >= o && src < o + n {
                    work.guess[i] = y[src]; // already an end-of-step value: no extrapolation
                    work.slope[i] = 0.0;
                }
            }
        }
        self.finish_step(t + h)
    }

    /// After the FMUs stepped with (end-of-step) inputs `work.guess`: new outputs and residual.
    fn finish_step(&mut self, t1: f64) -> Result<StepReport, CosimError> {
        self.read_outputs().map_err(|e| self.err(t1, e.to_string()))?;
        let residual = self.residual(&self.work.guess).0;
        Ok(StepReport { iterations: 1, residual })
    }

    fn save_states(&mut self, t: f64) -> Result<(), CosimError> {
        for unit in self.units.iter_mut() {
            let r = match unit.state.take() {
                Some(s) => unit.inst.update_state(&s).map(|_| s),
                None => unit.inst.get_state(),
            };
            unit.state = Some(r.map_err(|e| CosimError { time: t, reason: e.to_string() })?);
        }
        Ok(())
    }

    fn restore_states(&mut self, t: f64) -> Result<(), CosimError> {
        for unit in self.units.iter_mut() {
            let s = unit.state.as_ref().expect("saved at the start of the step");
            unit.inst.set_state(s).map_err(|e| CosimError { time: t, reason: e.to_string() })?;
        }
        Ok(())
    }

    /// Steps every unit from the saved states with the inputs `work.guess`; outputs into
    /// `self.y`. Returns the finished step's report once the interface residual is within the
    /// tolerance, and fails at the iteration limit.
    fn evaluate(&mut self, it: usize, t: f64, h: f64) -> Result<Option<StepReport>, CosimError> {
        if it > 1 {
            self.restore_states(t)?;
        }
        for k in 0..self.units.len() {
            self.advance(k, false, t, h)?;
        }
        self.read_outputs().map_err(|e| self.err(t + h, e.to_string()))?;
        let (res, worst) = self.residual(&self.work.guess);
        if res <= self.options.tol {
            return Ok(Some(StepReport { iterations: it, residual: res }));
        }
        if it == self.options.max_iter {
            return Err(self.not_converged(t + h, res, worst));
        }
        // the fixed-point residual C·Y − U into `work.r`
        let Coupled { work, source, y, .. } = self;
        for (i, &s) in source.iter().enumerate() {
            work.r[i] = y[s] - work.guess[i];
        }
        Ok(None)
    }

    fn step_iterative(&mut self, t: f64, h: f64) -> Result<StepReport, CosimError> {
        self.predict_end(h);
        self.keep_history();
        self.save_states(t)?;
        let mut omega = match self.options.relaxation {
            Relaxation::Fixed(w) => w,
            Relaxation::Aitken => 0.3,
        };
        for it in 1..=self.options.max_iter {
            if let Some(done) = self.evaluate(it, t, h)? {
                return Ok(done);
            }
            let Coupled { work, scale, options, .. } = self;
            if options.relaxation == Relaxation::Aitken && it > 1 {
                // Aitken Δ²: ω ← −ω · (r_prev · (r − r_prev)) / |r − r_prev|², scaled entries
                let (mut num, mut dd) = (0.0, 0.0);
                for i in 0..work.r.len() {
                    let d = (work.r[i] - work.r_prev[i]) / scale[i];
                    dd += d * d;
                    num += work.r_prev[i] / scale[i] * d;
                }
                if dd > 0.0 {
                    omega = (-omega * num / dd).clamp(0.05, 1.0);
                }
            }
            for (g, r) in work.guess.iter_mut().zip(&work.r) {
                *g += omega * r;
            }
            work.r_prev.copy_from_slice(&work.r);
        }
        unreachable!("evaluate fails at the iteration limit")
    }

    fn step_ijcsa(&mut self, t: f64, h: f64) -> Result<StepReport, CosimError> {
        self.predict_end(h);
        self.keep_history();
        self.save_states(t)?;
        let mut fresh_jacobian = false;
        let mut last_res = f64::INFINITY;
        for it in 1..=self.options.max_iter {
            if let Some(done) = self.evaluate(it, t, h)? {
                return Ok(done);
            }
            // Jacobian of the step just taken (derivatives at the current inputs)
            let res = self.residual(&self.work.guess).0;
            let slow = res > 0.1 * last_res;
            if !self.has_jacobian
                || self.options.jacobian == JacobianUpdate::EveryStep && it == 1
                || (slow && !fresh_jacobian)
            {
                self.interface_jacobian(t, h)?;
                fresh_jacobian = true;
            }
            last_res = res;
            // Newton: (I − C ∂Y/∂U) ΔU = C Y − U, in place
            let Coupled { work, source, dydu, .. } = self;
            let n = work.r.len();
            for i in 0..n {
                for j in 0..n {
                    work.newton[i * n + j] = f64::from(u8::from(i == j)) - dydu[(source[i], j)];
                }
            }
            if !solve_dense_in_place(&mut work.newton, n, &mut work.r) {
                return Err(self.err(t + h, "the interface Jacobian is singular"));
            }
            for (g, d) in work.guess.iter_mut().zip(&work.r) {
                *g += d;
            }
        }
        unreachable!("evaluate fails at the iteration limit")
    }

    /// ∂Y/∂U after stepping with `work.guess` (the FMUs' step maps) into `self.dydu`: the
    /// extension `feedsimGetStepMapDerivative` where the FMU offers it, central differences with
    /// rollback otherwise.
    fn interface_jacobian(&mut self, t: f64, h: f64) -> Result<(), CosimError> {
        let fail =
            |e: fmi2::import::Error, name: &str| CosimError { time: t + h, reason: format!("FMU `{name}`: {e}") };
        for k in 0..self.units.len() {
            let Coupled { units, work, dydu, scale, .. } = self;
            let unit = &mut units[k];
            let (io, ni) = (unit.input_offset, unit.inputs.len());
            let (oo, no) = (unit.output_offset, unit.outputs.len());
            let (seed, col) = (&mut work.seed[..ni], &mut work.col[..no]);
            if unit.derivatives {
                for c in 0..ni {
                    seed.fill(0.0);
                    seed[c] = 1.0;
                    unit.inst
                        .step_map_derivative(&unit.outputs, &unit.inputs, seed, col)
                        .map_err(|e| fail(e, &unit.name))?;
                    for r in 0..no {
                        dydu[(oo + r, io + c)] = col[r];
                    }
                }
                continue;
            }
            // central differences, each from the saved state; the nominal step last
            let state = unit.state.as_ref().expect("saved");
            for c in 0..ni {
                let delta = 1e-6 * scale[io + c];
                for r in 0..no {
                    dydu[(oo + r, io + c)] = 0.0;
                }
                for sign in [1.0, -1.0] {
                    work.end[..ni].copy_from_slice(&work.guess[io..io + ni]);
                    work.end[c] += sign * delta;
                    unit.inst.set_state(state).map_err(|e| fail(e, &unit.name))?;
                    unit.inst.set_real(&unit.inputs, &work.end[..ni]).map_err(|e| fail(e, &unit.name))?;
                    unit.inst.do_step(t, h).map_err(|e| fail(e, &unit.name))?;
                    unit.inst.get_real(&unit.outputs, col).map_err(|e| fail(e, &unit.name))?;
                    for r in 0..no {
                        dydu[(oo + r, io + c)] += sign * col[r] / (2.0 * delta);
                    }
                }
            }
            unit.inst.set_state(state).map_err(|e| fail(e, &unit.name))?;
            unit.inst.set_real(&unit.inputs, &work.guess[io..io + ni]).map_err(|e| fail(e, &unit.name))?;
            unit.inst.do_step(t, h).map_err(|e| fail(e, &unit.name))?;
        }
        self.has_jacobian = true;
        Ok(())
    }

    fn not_converged(&self, t: f64, res: f64, worst: usize) -> CosimError {
        self.err(
            t,
            format!(
                "{} did not converge in {} iterations: interface residual {res:.3e} (relative) at `{}` (tolerance {:.1e}); \
                 reduce the step size, raise --max-iter or loosen --tol",
                self.options.scheme.name(),
                self.options.max_iter,
                self.input_names[worst],
                self.options.tol
            ),
        )
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
    ones: Vec<i32>,
    /// The interface Newton matrix, row-major.
    newton: Vec<f64>,
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
            ones: vec![1; nu],
            newton: vec![0.0; nu * nu],
        }
    }
}

/// Solves the dense system `a x = b` (row-major `a`, n × n) in place by Gaussian elimination
/// with partial pivoting: the interface system is small (25 unknowns here) and solved every
/// iteration, so it reuses its buffers. `b` becomes x; false if `a` is singular.
fn solve_dense_in_place(a: &mut [f64], n: usize, b: &mut [f64]) -> bool {
    for c in 0..n {
        let p = (c..n).max_by(|&i, &j| a[i * n + c].abs().total_cmp(&a[j * n + c].abs())).expect("n > c");
        if a[p * n + c] == 0.0 || !a[p * n + c].is_finite() {
            return false;
        }
        if p != c {
            for j in 0..n {
                a.swap(p * n + j, c * n + j);
            }
            b.swap(p, c);
        }
        for i in c + 1..n {
            let f = a[i * n + c] / a[c * n + c];
            if f != 0.0 {
                for j in c..n {
                    a[i * n + j] -= f * a[c * n + j];
                }
                b[i] -= f * b[c];
            }
        }
    }
    for c in (0..n).rev() {
        let s: f64 = (c + 1..n).map(|j| a[c * n + j] * b[j]).sum();
        b[c] = (b[c] - s) / a[c * n + c];
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dense_solve_needs_pivoting_and_matches_the_product() {
        // a zero leading entry forces a row swap
        let a0 = [0.0, 2.0, 1.0, 1.0, 1.0, 0.0, 3.0, 0.0, 1.0];
        let x = [1.0, -2.0, 0.5];
        let mut b: Vec<f64> = (0..3).map(|i| (0..3).map(|j| a0[i * 3 + j] * x[j]).sum()).collect();
        let mut a = a0.to_vec();
        assert!(solve_dense_in_place(&mut a, 3, &mut b));
        for k in 0..3 {
            assert!((b[k] - x[k]).abs() < 1e-14);
        }
        let mut singular = vec![1.0, 2.0, 2.0, 4.0];
        assert!(!solve_dense_in_place(&mut singular, 2, &mut [1.0, 1.0]));
    }
}
