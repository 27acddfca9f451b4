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
    y_prev: Option<Vec<f64>>,
    /// Interface Jacobian ∂Y/∂U (block diagonal over the units), dense, and its age.
    dydu: Option<nalgebra::DMatrix<f64>>,
    // scratch
    u: Vec<f64>,
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
                derivatives: flags.provides_directional_derivative,
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
            y_prev: None,
            dydu: None,
            u: vec![0.0; nu],
        };
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

    fn set_inputs(unit: &mut Unit, u: &[f64]) -> Result<(), fmi2::import::Error> {
        let (o, n) = (unit.input_offset, unit.inputs.len());
        unit.inst.set_real(&unit.inputs, &u[o..o + n])
    }

    /// `C y` into `u`.
    fn couple(&self, y: &[f64], u: &mut [f64]) {
        for (ui, &s) in u.iter_mut().zip(&self.source) {
            *ui = y[s];
        }
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

    /// The first guess of the end-of-step inputs (and, for linear extrapolation, their slope).
    fn predict(&self, h: f64) -> (Vec<f64>, Option<Vec<f64>>) {
        let mut u = vec![0.0; self.u.len()];
        self.couple(&self.y, &mut u);
        match (&self.y_prev, self.options.extrapolation) {
            (Some(prev), Extrapolation::Linear) => {
                let mut up = vec![0.0; u.len()];
                self.couple(prev, &mut up);
                let slope: Vec<f64> = u.iter().zip(&up).map(|(a, b)| (a - b) / h).collect();
                (u, Some(slope))
            }
            _ => (u, None),
        }
    }

    /// An explicit scheme whose interface values grew far beyond their scale is unstable: say so.
    fn unstable(&self, e: CosimError) -> CosimError {
        let mut u = vec![0.0; self.u.len()];
        self.couple(&self.y, &mut u);
        let (i, g) = (0..u.len())
            .map(|i| (i, (u[i] / self.scale[i]).abs()))
            .fold((0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
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
                u[i],
                self.options.scheme.name()
            ),
        }
    }

    /// The first guess of the end-of-step inputs, extrapolated if asked.
    fn predict_end(&self, h: f64) -> Vec<f64> {
        let (mut u, slope) = self.predict(h);
        if let Some(slope) = slope {
            for (ui, s) in u.iter_mut().zip(&slope) {
                *ui += s * h;
            }
        }
        u
    }

    /// One macro step of size `h`.
    pub fn step(&mut self, h: f64) -> Result<StepReport, CosimError> {
        let t = self.time;
        let t1 = t + h;
        let report = match self.options.scheme {
            Scheme::Jacobi => self.step_jacobi(t, h).map_err(|e| self.unstable(e))?,
            Scheme::GaussSeidel { reversed } => {
                let order: Vec<usize> =
                    if reversed { (0..self.units.len()).rev().collect() } else { (0..self.units.len()).collect() };
                self.step_gauss_seidel(t, h, &order).map_err(|e| self.unstable(e))?
            }
            Scheme::Sequential => {
                let order = self.flow_order();
                self.step_gauss_seidel(t, h, &order)?
            }
            Scheme::Iterative => self.step_iterative(t, h)?,
            Scheme::Ijcsa => self.step_ijcsa(t, h)?,
        };
        if self.y.iter().any(|x| !x.is_finite()) {
            return Err(self.err(t1, "an output is not finite (the coupled motion diverged)"));
        }
        // A coupling value a hundred times its scale (kilonewtons for a weight of a few, hundreds
        // of m/s² for a cabin): the coupled motion has run away; stop before the numbers lie.
        let mut u = vec![0.0; self.u.len()];
        self.couple(&self.y, &mut u);
        if u.iter().zip(&self.scale).any(|(x, s)| (x / s).abs() > 100.0) {
            return Err(self.unstable(self.err(t1, format!("{} diverged", self.options.scheme.name()))));
        }
        self.time = t1;
        Ok(report)
    }

    /// Sets a unit's inputs from `u` (and the slope for interpolating FMUs), then steps it.
    /// With a `slope`, an FMU that interpolates inputs gets it through
    /// `fmi2SetRealInputDerivatives`; another gets the extrapolated end-of-step value.
    fn advance(&mut self, k: usize, u: &[f64], slope: Option<&[f64]>, t: f64, h: f64) -> Result<(), CosimError> {
        let unit = &mut self.units[k];
        let r = (|| {
            let (o, n) = (unit.input_offset, unit.inputs.len());
            match slope {
                Some(s) if unit.interpolates => {
                    unit.inst.set_real(&unit.inputs, &u[o..o + n])?;
                    unit.inst.set_real_input_derivatives(&unit.inputs, &vec![1; n], &s[o..o + n])?;
                }
                Some(s) => {
                    let end: Vec<f64> = (o..o + n).map(|i| u[i] + s[i] * h).collect();
                    unit.inst.set_real(&unit.inputs, &end)?;
                }
                None => Self::set_inputs(unit, u)?,
            }
            unit.inst.do_step(t, h)
        })();
        r.map_err(|e| CosimError { time: t + h, reason: format!("FMU `{}`: {e}", self.units[k].name) })
    }

    fn step_jacobi(&mut self, t: f64, h: f64) -> Result<StepReport, CosimError> {
        let (u, slope) = self.predict(h);
        // With a slope the FMUs extrapolate from the last communication point themselves.
        for k in 0..self.units.len() {
            self.advance(k, &u, slope.as_deref(), t, h)?;
        }
        self.finish_step(&u, t + h)
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

    fn step_gauss_seidel(&mut self, t: f64, h: f64, order: &[usize]) -> Result<StepReport, CosimError> {
        let (mut u, mut slope) = self.predict(h);
        for &k in order {
            self.advance(k, &u, slope.as_deref(), t, h)?;
            // the newest outputs of this unit feed the ones after it
            let unit = &mut self.units[k];
            let (o, n) = (unit.output_offset, unit.outputs.len());
            unit.inst
                .get_real(&unit.outputs, &mut self.y[o..o + n])
                .map_err(|e| CosimError { time: t + h, reason: e.to_string() })?;
            let mut fresh = vec![0.0; u.len()];
            self.couple(&self.y, &mut fresh);
            for (i, f) in fresh.iter().enumerate() {
                if self.source[i] >= o && self.source[i] < o + n {
                    u[i] = *f; // already an end-of-step value: no extrapolation
                    if let Some(s) = slope.as_mut() {
                        s[i] = 0.0;
                    }
                }
            }
        }
        self.finish_step(&u, t + h)
    }

    /// After the FMUs stepped with (end-of-step) inputs `u`: new outputs, residual, history.
    fn finish_step(&mut self, u: &[f64], t1: f64) -> Result<StepReport, CosimError> {
        let prev = self.y.clone();
        self.read_outputs().map_err(|e| self.err(t1, e.to_string()))?;
        let residual = self.residual(u).0;
        self.y_prev = Some(prev);
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

    /// Steps every unit from the saved states with inputs `u`; outputs into `self.y`.
    fn evaluate(&mut self, u: &[f64], t: f64, h: f64, rollback: bool) -> Result<(), CosimError> {
        if rollback {
            self.restore_states(t)?;
        }
        for k in 0..self.units.len() {
            self.advance(k, u, None, t, h)?;
        }
        self.read_outputs().map_err(|e| self.err(t + h, e.to_string()))
    }

    fn step_iterative(&mut self, t: f64, h: f64) -> Result<StepReport, CosimError> {
        let prev = self.y.clone();
        self.save_states(t)?;
        let u = self.predict_end(h);
        let mut u = u;
        let n = u.len();
        let mut omega = match self.options.relaxation {
            Relaxation::Fixed(w) => w,
            Relaxation::Aitken => 0.3,
        };
        let mut r_prev: Option<Vec<f64>> = None;
        let mut cu = vec![0.0; n];
        for it in 1..=self.options.max_iter {
            self.evaluate(&u, t, h, it > 1)?;
            let (res, worst) = self.residual(&u);
            if res <= self.options.tol {
                self.y_prev = Some(prev);
                return Ok(StepReport { iterations: it, residual: res });
            }
            if it == self.options.max_iter {
                return Err(self.not_converged(t + h, res, worst));
            }
            self.couple(&self.y, &mut cu);
            let r: Vec<f64> = (0..n).map(|i| cu[i] - u[i]).collect();
            if let (Relaxation::Aitken, Some(rp)) = (self.options.relaxation, &r_prev) {
                // Aitken Δ²: ω ← −ω · (r_prev · (r − r_prev)) / |r − r_prev|²
                let d: Vec<f64> = (0..n).map(|i| (r[i] - rp[i]) / self.scale[i]).collect();
                let dd: f64 = d.iter().map(|x| x * x).sum();
                if dd > 0.0 {
                    let num: f64 = (0..n).map(|i| rp[i] / self.scale[i] * d[i]).sum();
                    omega = (-omega * num / dd).clamp(0.05, 1.0);
                }
            }
            for i in 0..n {
                u[i] += omega * r[i];
            }
            r_prev = Some(r);
        }
        unreachable!("the loop returns")
    }

    fn step_ijcsa(&mut self, t: f64, h: f64) -> Result<StepReport, CosimError> {
        let prev = self.y.clone();
        self.save_states(t)?;
        let mut u = self.predict_end(h);
        let n = u.len();
        let mut cu = vec![0.0; n];
        let mut fresh_jacobian = false;
        let mut last_res = f64::INFINITY;
        for it in 1..=self.options.max_iter {
            self.evaluate(&u, t, h, it > 1)?;
            let (res, worst) = self.residual(&u);
            if res <= self.options.tol {
                self.y_prev = Some(prev);
                return Ok(StepReport { iterations: it, residual: res });
            }
            if it == self.options.max_iter {
                return Err(self.not_converged(t + h, res, worst));
            }
            // Jacobian of the step just taken (derivatives at the current inputs)
            let slow = res > 0.1 * last_res;
            if self.dydu.is_none()
                || self.options.jacobian == JacobianUpdate::EveryStep && it == 1
                || (slow && !fresh_jacobian)
            {
                let j = self.interface_jacobian(&u, t, h)?;
                self.dydu = Some(j);
                fresh_jacobian = true;
            }
            last_res = res;
            // Newton: (I − C ∂Y/∂U) ΔU = C Y − U
            self.couple(&self.y, &mut cu);
            let dydu = self.dydu.as_ref().expect("computed above");
            let mut a = nalgebra::DMatrix::<f64>::identity(n, n);
            for i in 0..n {
                let row = dydu.row(self.source[i]);
                for j in 0..n {
                    a[(i, j)] -= row[j];
                }
            }
            let rhs = nalgebra::DVector::from_iterator(n, (0..n).map(|i| cu[i] - u[i]));
            let du = a.lu().solve(&rhs).ok_or_else(|| self.err(t + h, "the interface Jacobian is singular"))?;
            for i in 0..n {
                u[i] += du[i];
            }
        }
        unreachable!("the loop returns")
    }

    /// ∂Y/∂U after stepping with `u` (the FMUs' step maps); directional derivatives where the FMU
    /// provides them, central differences with rollback otherwise.
    fn interface_jacobian(&mut self, u: &[f64], t: f64, h: f64) -> Result<nalgebra::DMatrix<f64>, CosimError> {
        let (ny, nu) = (self.y.len(), u.len());
        let mut j = nalgebra::DMatrix::zeros(ny, nu);
        let y_now = self.y.clone();
        for k in 0..self.units.len() {
            let (io, ni) = (self.units[k].input_offset, self.units[k].inputs.len());
            let (oo, no) = (self.units[k].output_offset, self.units[k].outputs.len());
            if self.units[k].derivatives {
                let unit = &mut self.units[k];
                let mut seed = vec![0.0; ni];
                let mut col = vec![0.0; no];
                for c in 0..ni {
                    seed.iter_mut().for_each(|s| *s = 0.0);
                    seed[c] = 1.0;
                    unit.inst
                        .directional_derivative(&unit.outputs, &unit.inputs, &seed, &mut col)
                        .map_err(|e| CosimError { time: t + h, reason: format!("FMU `{}`: {e}", unit.name) })?;
                    for r in 0..no {
                        j[(oo + r, io + c)] = col[r];
                    }
                }
            } else {
                for c in 0..ni {
                    let delta = 1e-6 * self.scale[io + c];
                    let mut column = vec![0.0; no];
                    for sign in [1.0, -1.0] {
                        let mut up = u.to_vec();
                        up[io + c] += sign * delta;
                        let unit = &mut self.units[k];
                        let s = unit.state.as_ref().expect("saved");
                        unit.inst.set_state(s).map_err(|e| CosimError { time: t, reason: e.to_string() })?;
                        self.advance(k, &up, None, t, h)?;
                        let unit = &mut self.units[k];
                        let mut out = vec![0.0; no];
                        unit.inst
                            .get_real(&unit.outputs, &mut out)
                            .map_err(|e| CosimError { time: t + h, reason: e.to_string() })?;
                        for r in 0..no {
                            column[r] += sign * out[r] / (2.0 * delta);
                        }
                    }
                    for r in 0..no {
                        j[(oo + r, io + c)] = column[r];
                    }
                }
                // back to the nominal step of this unit
                let unit = &mut self.units[k];
                let s = unit.state.as_ref().expect("saved");
                unit.inst.set_state(s).map_err(|e| CosimError { time: t, reason: e.to_string() })?;
                self.advance(k, u, None, t, h)?;
            }
        }
        self.y = y_now;
        Ok(j)
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
