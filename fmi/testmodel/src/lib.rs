//! Test model of the fmi layer: a damped mass–spring oscillator driven by a force input.
//!
//! `m ẍ + c ẋ + k x = F(t) − m g·[gravity]`, integrated with the trapezoidal rule (implicit,
//! A-stable, second order; for this linear system identical to Newmark β = 1/4, γ = 1/2) in
//! `substeps` equal steps per communication step. The input is held constant over the step, or
//! extrapolated linearly when the importer sets its first derivative. The mass comes from a
//! resource file named by the String parameter `config`, so that the resource path handling is
//! exercised the way the scene files of the real models will be.
//!
//! Directional derivatives are exact: the step map is linear in the input, and its sensitivity
//! is propagated alongside the state.

use std::path::Path;

use fmi::export::{Derivative, Model, ModelError, Seeds, StepOutcome};
use fmi::resources::{FileKind, FileParameter, SavedFile};
use fmi::{
    Causality, CoSimulationFlags, DefaultExperiment, ModelDescription, Resource, VarType, Variability, Variable,
};
use serde::{Deserialize, Serialize};

/// Standard gravity (m/s²) for the `gravity` parameter.
pub const G: f64 = 9.80665;

/// Value references (per type).
pub mod vr {
    /// Real input: the force on the mass.
    pub const F: u32 = 0;
    /// Real outputs: position, velocity, acceleration.
    pub const X: u32 = 1;
    pub const V: u32 = 2;
    pub const A: u32 = 3;
    /// Real parameters: stiffness, damping, initial position and velocity.
    pub const K: u32 = 4;
    pub const C: u32 = 5;
    pub const X0: u32 = 6;
    pub const V0: u32 = 7;
    /// Integer.
    pub const SUBSTEPS: u32 = 0;
    /// Integer output.
    pub const STEPS: u32 = 1;
    /// Integer.
    pub const MAX_STEPS: u32 = 2;
    /// Boolean.
    pub const GRAVITY: u32 = 0;
    /// String.
    pub const CONFIG: u32 = 0;
}

/// The default configuration file, shipped in `resources/` and compiled in.
pub const DEFAULT_CONFIG: &str = "oscillator.txt";

/// Configuration files: `mass_kg = <value>`, at most 4 KiB.
static CONFIG: FileKind<f64, String> =
    FileKind::new(&[(DEFAULT_CONFIG, include_str!("../resources/oscillator.txt"))], 4096, parse_config);

/// Everything but the configuration file: parameters, inputs and the state, saved as it is.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
struct Data {
    k: f64,
    c: f64,
    x0: f64,
    v0: f64,
    substeps: i32,
    max_steps: i32,
    gravity: bool,
    force: f64,
    force_rate: f64,
    initialized: bool,
    x: f64,
    v: f64,
    /// ∂(x, v)/∂F over the last communication step (zero before the first).
    sens: [f64; 2],
    steps: i32,
}

pub struct Oscillator {
    /// The mass, from the configuration file.
    config: FileParameter<f64, String>,
    data: Data,
}

/// A saved state: the configuration file's name and the rest.
#[derive(Serialize, Deserialize)]
pub struct SavedOscillator<'a> {
    #[serde(borrow)]
    config: SavedFile<'a>,
    data: Data,
}

/// `mass_kg = <value>` from a config file's text; errors name the line and the value.
pub fn parse_config(text: &str, _origin: &str) -> Result<f64, String> {
    let mut mass = None;
    for (i, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let at = format!("line {}", i + 1);
        let Some((key, value)) = line.split_once('=') else {
            return Err(format!("{at}: expected `key = value`, got `{line}`"));
        };
        let (key, value) = (key.trim(), value.trim());
        match key {
            "mass_kg" => match value.parse::<f64>() {
                Ok(m) if m.is_finite() && m > 0.0 => mass = Some(m),
                _ => return Err(format!("{at}: `mass_kg` = {value}: must be a positive number")),
            },
            _ => return Err(format!("{at}: unknown key `{key}` (known: mass_kg)")),
        }
    }
    mass.ok_or_else(|| "`mass_kg` is missing".to_owned())
}

impl Oscillator {
    fn mass(&self) -> f64 {
        *self.config.value()
    }

    fn weight(&self, m: f64) -> f64 {
        if self.data.gravity { -m * G } else { 0.0 }
    }

    /// Position and velocity now: before initialization they follow the start parameters.
    fn state(&self) -> (f64, f64) {
        let d = &self.data;
        if d.initialized { (d.x, d.v) } else { (d.x0, d.v0) }
    }

    fn acceleration(&self) -> f64 {
        let m = self.mass();
        let (x, v) = self.state();
        (self.data.force + self.weight(m) - self.data.c * v - self.data.k * x) / m
    }
}

impl Model for Oscillator {
    type State<'a> = SavedOscillator<'a>;

    fn description() -> Result<ModelDescription, ModelError> {
        let variables = vec![
            Variable::real_input("F", vr::F, 0.0, "N").describe("force on the mass"),
            Variable::real_output("x", vr::X, "m")
                .describe("position")
                .depends_on::<&str>(&[])
                .initially_depends_on(&["x0"]),
            Variable::real_output("v", vr::V, "m/s")
                .describe("velocity")
                .depends_on::<&str>(&[])
                .initially_depends_on(&["v0"]),
            Variable::real_output("a", vr::A, "m/s2")
                .describe("acceleration")
                .depends_on(&["F"])
                .initially_depends_on(&["F", "k", "c", "x0", "v0", "gravity", "config"]),
            Variable::parameter("k", vr::K, 40.0, true).unit("N/m").describe("spring stiffness"),
            Variable::parameter("c", vr::C, 0.8, true).unit("N.s/m").describe("damping coefficient"),
            Variable::parameter("x0", vr::X0, 0.1, false).unit("m").describe("initial position"),
            Variable::parameter("v0", vr::V0, 0.0, false).unit("m/s").describe("initial velocity"),
            Variable::parameter("substeps", vr::SUBSTEPS, 1, false).describe("integrator steps per communication step"),
            Variable::parameter("max_steps", vr::MAX_STEPS, 0, false).describe(
                "communication steps after which fmi2DoStep returns fmi2Discard (the model has ended); 0: no end",
            ),
            Variable::parameter("gravity", vr::GRAVITY, false, false).describe("add the weight m g in −x"),
            Variable::parameter("config", vr::CONFIG, DEFAULT_CONFIG, false)
                .describe("configuration file (mass_kg); relative paths resolve against resources/"),
            Variable::new("steps", vr::STEPS, VarType::Integer, Causality::Output, Variability::Discrete)
                .describe("communication steps taken")
                .depends_on::<&str>(&[])
                .initially_depends_on::<&str>(&[]),
        ];
        let mut d = ModelDescription::co_simulation(
            "oscillator",
            "{6f1c2a8e-3b7d-4c59-9e21-0a4d8b7f5c32}",
            "Damped mass-spring oscillator, trapezoidal rule; test model of the fmi layer",
            env!("CARGO_PKG_VERSION"),
            CoSimulationFlags::EXPORTED_WITH_DERIVATIVES,
            variables,
        );
        d.model_name = "fmi2 test oscillator".into();
        d.default_experiment =
            Some(DefaultExperiment { stop_time: Some(5.0), ..d.default_experiment.unwrap_or_default() });
        Ok(d)
    }

    fn resources() -> Vec<Resource> {
        CONFIG.resources()
    }

    fn instantiate(resources: Option<&Path>) -> Result<Self, ModelError> {
        Ok(Oscillator {
            config: CONFIG.open(resources, DEFAULT_CONFIG)?,
            data: Data {
                k: 40.0,
                c: 0.8,
                x0: 0.1,
                v0: 0.0,
                substeps: 1,
                max_steps: 0,
                gravity: false,
                force: 0.0,
                force_rate: 0.0,
                initialized: false,
                x: 0.0,
                v: 0.0,
                sens: [0.0; 2],
                steps: 0,
            },
        })
    }

    fn set_real(&mut self, vr: u32, value: f64) -> Result<(), ModelError> {
        let d = &mut self.data;
        match vr {
            vr::F => d.force = value,
            vr::K if value > 0.0 => d.k = value,
            vr::C if value >= 0.0 => d.c = value,
            vr::K => return Err(format!("{value}: must be positive").into()),
            vr::C => return Err(format!("{value}: must not be negative").into()),
            vr::X0 => d.x0 = value,
            vr::V0 => d.v0 = value,
            _ => return Err(format!("value reference {vr} is not settable").into()),
        }
        Ok(())
    }

    fn get_real(&mut self, vr: u32) -> Result<f64, ModelError> {
        let (x, v) = self.state();
        let d = &self.data;
        Ok(match vr {
            vr::F => d.force,
            vr::X => x,
            vr::V => v,
            vr::A => self.acceleration(),
            vr::K => d.k,
            vr::C => d.c,
            vr::X0 => d.x0,
            vr::V0 => d.v0,
            _ => return Err(format!("unknown value reference {vr}").into()),
        })
    }

    fn set_integer(&mut self, vr: u32, value: i32) -> Result<(), ModelError> {
        match vr {
            vr::SUBSTEPS if (1..=10_000).contains(&value) => self.data.substeps = value,
            vr::SUBSTEPS => return Err(format!("{value}: must be in 1..=10000").into()),
            vr::MAX_STEPS if value >= 0 => self.data.max_steps = value,
            vr::MAX_STEPS => return Err(format!("{value}: must not be negative").into()),
            _ => return Err(format!("value reference {vr} is not settable").into()),
        }
        Ok(())
    }

    fn get_integer(&mut self, vr: u32) -> Result<i32, ModelError> {
        match vr {
            vr::SUBSTEPS => Ok(self.data.substeps),
            vr::STEPS => Ok(self.data.steps),
            vr::MAX_STEPS => Ok(self.data.max_steps),
            _ => Err(format!("unknown value reference {vr}").into()),
        }
    }

    /// `gravity`, the only Boolean (the layer has checked the value reference).
    fn set_boolean(&mut self, _vr: u32, value: bool) -> Result<(), ModelError> {
        self.data.gravity = value;
        Ok(())
    }

    fn get_boolean(&mut self, _vr: u32) -> Result<bool, ModelError> {
        Ok(self.data.gravity)
    }

    /// `config`, the only String: read at once, so that a missing or malformed file is reported
    /// by fmi2SetString.
    fn set_string(&mut self, _vr: u32, value: &str) -> Result<(), ModelError> {
        self.config.set(value)?;
        Ok(())
    }

    fn get_string(&mut self, _vr: u32) -> Result<String, ModelError> {
        Ok(self.config.name().to_owned())
    }

    fn exit_initialization(&mut self, _start_time: f64) -> Result<(), ModelError> {
        let d = &mut self.data;
        (d.x, d.v, d.initialized) = (d.x0, d.v0, true);
        Ok(())
    }

    fn do_step(&mut self, t: f64, h: f64) -> Result<StepOutcome, ModelError> {
        let m = self.mass();
        let weight = self.weight(m);
        let d = &mut self.data;
        if d.max_steps > 0 && d.steps >= d.max_steps {
            return Ok(StepOutcome::Terminated { time: t, reason: format!("max_steps = {} reached", d.max_steps) });
        }
        let hs = h / f64::from(d.substeps);
        let (k, c) = (d.k / m, d.c / m);
        // (I − hs/2 A) y⁺ = (I + hs/2 A) y + hs/(2m) (f⁻ + f⁺) e₂ with A = [[0, 1], [−k/m, −c/m]].
        let det = 1.0 + 0.5 * hs * c + 0.25 * hs * hs * k;
        let solve =
            |r0: f64, r1: f64| ((r0 * (1.0 + 0.5 * hs * c) + 0.5 * hs * r1) / det, (r1 - 0.5 * hs * k * r0) / det);
        let rhs = |x: f64, v: f64| (x + 0.5 * hs * v, v - 0.5 * hs * (k * x + c * v));
        let f0 = d.force + weight;
        let (mut x, mut v) = (d.x, d.v);
        let mut s = [0.0, 0.0];
        for j in 0..d.substeps {
            let (fa, fb) = (f0 + d.force_rate * hs * f64::from(j), f0 + d.force_rate * hs * f64::from(j + 1));
            let (r0, r1) = rhs(x, v);
            (x, v) = solve(r0, r1 + 0.5 * hs * (fa + fb) / m);
            let (q0, q1) = rhs(s[0], s[1]);
            let (s0, s1) = solve(q0, q1 + hs / m);
            s = [s0, s1];
        }
        if !(x.is_finite() && v.is_finite()) {
            return Err(format!("the state became non-finite (x = {x}, v = {v})").into());
        }
        (d.x, d.v, d.sens) = (x, v, s);
        d.force_rate = 0.0; // derivatives apply to one step; set them again for the next
        d.steps += 1;
        Ok(StepOutcome::Complete)
    }

    /// `F`, the only input.
    fn set_real_input_derivative(&mut self, _vr: u32, value: f64) -> Result<(), ModelError> {
        self.data.force_rate = value;
        Ok(())
    }

    /// `∂(x, v, a)/∂F · seed`: at the current instant only the acceleration responds, through
    /// 1/m; the step map's from the sensitivities of the last step (zero before the first).
    fn derivative(&mut self, kind: Derivative, at: Seeds<'_>, out: &mut [f64]) -> Result<(), ModelError> {
        let m = self.mass();
        let [sx, sv] = if kind == Derivative::StepMap { self.data.sens } else { [0.0, 0.0] };
        if let Some(kn) = at.knowns.iter().find(|&&kn| kn != vr::F) {
            return Err(format!("derivatives with respect to value reference {kn} are not provided (only F)").into());
        }
        let df: f64 = at.seed.iter().sum(); // every known is F
        for (o, &u) in out.iter_mut().zip(at.unknowns) {
            *o = df
                * match u {
                    vr::X => sx,
                    vr::V => sv,
                    vr::A => (1.0 - self.data.c * sv - self.data.k * sx) / m,
                    _ => return Err(format!("no derivative for value reference {u}").into()),
                };
        }
        Ok(())
    }

    fn save(&mut self) -> Result<SavedOscillator<'_>, ModelError> {
        Ok(SavedOscillator { config: self.config.saved(), data: self.data })
    }

    fn restore(&mut self, saved: SavedOscillator<'_>) -> Result<(), ModelError> {
        self.config.restore(saved.config)?;
        self.data = saved.data;
        Ok(())
    }
}

fmi::export_fmu!(Oscillator);
fmi::export_fmu3!(Oscillator);

#[cfg(test)]
mod tests {
    use super::*;

    fn ready() -> Oscillator {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("resources");
        let mut m = Oscillator::instantiate(Some(&dir)).unwrap();
        m.exit_initialization(0.0).unwrap();
        m
    }

    /// Valid, and what the exporter writes reads back through the importer's parser as exactly
    /// the description declared (validated and normalized).
    #[test]
    fn the_model_description_is_valid_and_reads_back_equal() {
        let info = fmi::ModelInfo::new(Oscillator::description().unwrap()).unwrap();
        assert_eq!(info.vars.len(), 13);
        let text = fmi::xml::model_description_xml(&info.description).unwrap();
        assert_eq!(fmi::xml::parse_model_description(&text).unwrap(), info.description);
    }

    #[test]
    fn free_oscillation_matches_the_analytic_solution_to_second_order() {
        // Undamped, x(t) = x0 cos ωt. Trapezoidal rule: amplitude exact, phase error ω³h²t/12.
        let run = |h: f64| {
            let mut m = ready();
            m.set_real(vr::C, 0.0).unwrap();
            let n = (2.0 / h).round() as usize;
            for i in 0..n {
                m.do_step(i as f64 * h, h).unwrap();
            }
            let w = (40.0_f64 / 2.0).sqrt();
            (m.data.x - 0.1 * (w * 2.0).cos()).abs()
        };
        let (e1, e2) = (run(0.01), run(0.005));
        let w: f64 = 20.0_f64.sqrt();
        let predicted = 0.1 * w.powi(3) * 0.01 * 0.01 * 2.0 / 12.0; // amplitude × phase error
        assert!(e1 < 1.5 * predicted, "error {e1} vs predicted {predicted}");
        assert!((e1 / e2 - 4.0).abs() < 0.2, "order: {e1} / {e2}");
    }

    #[test]
    fn static_deflection_under_gravity_and_constant_force() {
        let mut m = ready();
        m.set_real(vr::F, 3.0).unwrap();
        m.data.gravity = true;
        m.data.c = 20.0; // heavily damped: settles quickly
        for i in 0..2000 {
            m.do_step(i as f64 * 0.01, 0.01).unwrap();
        }
        let expected = (3.0 - 2.0 * G) / 40.0;
        assert!((m.data.x - expected).abs() < 1e-12, "{} vs {expected}", m.data.x);
        assert!(m.get_real(vr::A).unwrap().abs() < 1e-10);
    }

    #[test]
    fn step_map_derivatives_match_finite_differences() {
        let mut m = ready();
        m.set_integer(vr::SUBSTEPS, 3).unwrap();
        m.do_step(0.0, 0.05).unwrap();
        let mut saved = Vec::new();
        m.save_state(&mut saved).unwrap();
        let outputs = |m: &mut Oscillator, f: f64| {
            m.restore_state(&saved).unwrap();
            m.set_real(vr::F, f).unwrap();
            m.do_step(0.05, 0.05).unwrap();
            [vr::X, vr::V, vr::A].map(|r| m.get_real(r).unwrap())
        };
        let d = 1e-3;
        let (p, q) = (outputs(&mut m, 1.0 + d), outputs(&mut m, 1.0 - d));
        outputs(&mut m, 1.0);
        let mut jac = [0.0; 3];
        m.step_map_derivative(&[vr::X, vr::V, vr::A], &[vr::F], &[1.0], &mut jac).unwrap();
        for i in 0..3 {
            let fd = (p[i] - q[i]) / (2.0 * d);
            assert!((fd - jac[i]).abs() <= 1e-9 * jac[i].abs().max(1e-3), "output {i}: fd {fd} vs {}", jac[i]);
        }
    }

    #[test]
    fn config_errors_name_the_file_and_line() {
        assert!(parse_config("# c\nmass_kg = -1\n", "x").unwrap_err().contains("line 2: `mass_kg` = -1"));
        assert!(parse_config("mass = 1\n", "x").unwrap_err().contains("unknown key `mass`"));
        assert!(parse_config("\n", "x").unwrap_err().contains("missing"));
        assert_eq!(parse_config("mass_kg = 2.5 # kg\n", "x"), Ok(2.5));
        let dir = std::env::temp_dir().join(format!("osc-config-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("bad.txt"), "# c\nmass_kg = -1\n").unwrap();
        let mut m = Oscillator::instantiate(Some(&dir)).unwrap();
        let e = m.set_string(vr::CONFIG, "bad.txt").unwrap_err().to_string();
        assert!(e.contains("bad.txt") && e.contains("line 2: `mass_kg` = -1"), "{e}");
        assert_eq!(m.get_string(vr::CONFIG).unwrap(), DEFAULT_CONFIG, "unchanged by the error");
        // Without a resource location the shipped copy is found; other relative names are not.
        let mut m = Oscillator::instantiate(None).unwrap();
        assert_eq!(m.mass(), 2.0);
        assert!(m.set_string(vr::CONFIG, "bad.txt").unwrap_err().to_string().contains("no resource location"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
