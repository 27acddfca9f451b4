//! Test model of the fmi2 layer: a damped mass–spring oscillator driven by a force input.
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

use std::path::{Path, PathBuf};

use fmi2::export::{Model, ModelError, StepOutcome};
use fmi2::state_bytes::{StateReader, StateWriter};
use fmi2::{Capabilities, DefaultExperiment, ModelDescription, Resource, Variable};

/// Standard gravity (m/s²) for the `gravity` parameter.
pub const G: f64 = 9.80665;

/// Value references (per type).
pub mod vr {
    pub const F: u32 = 0;
    pub const X: u32 = 1;
    pub const V: u32 = 2;
    pub const A: u32 = 3;
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

/// The default configuration file shipped in `resources/`.
pub const DEFAULT_CONFIG: &str = "oscillator.txt";

pub struct Oscillator {
    resources: Option<PathBuf>,
    config: String,
    /// From the config file; `None` until a config file was read.
    mass: Option<f64>,
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

/// Read `mass_kg = <value>` from a config file; errors name the file, the line and the value.
pub fn read_config(path: &Path) -> Result<f64, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("cannot read config file {}: {e}", path.display()))?;
    let mut mass = None;
    for (i, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let at = format!("{}:{}", path.display(), i + 1);
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
    mass.ok_or_else(|| format!("{}: `mass_kg` is missing", path.display()))
}

impl Oscillator {
    fn config_path(&self, name: &str) -> Result<PathBuf, String> {
        let p = Path::new(name);
        if p.is_absolute() {
            return Ok(p.to_owned());
        }
        match &self.resources {
            Some(r) => Ok(r.join(p)),
            None => Err(format!("config `{name}` is relative but the FMU was given no resource location")),
        }
    }

    fn mass(&self) -> Result<f64, String> {
        self.mass.ok_or_else(|| format!("no configuration loaded (config = `{}`)", self.config))
    }

    fn weight(&self, m: f64) -> f64 {
        if self.gravity { -m * G } else { 0.0 }
    }

    /// Position and velocity now: before initialization they follow the start parameters.
    fn state(&self) -> (f64, f64) {
        if self.initialized { (self.x, self.v) } else { (self.x0, self.v0) }
    }

    fn acceleration(&self) -> Result<f64, String> {
        let m = self.mass()?;
        let (x, v) = self.state();
        Ok((self.force + self.weight(m) - self.c * v - self.k * x) / m)
    }

    /// `∂(x, v, a)/∂F · seed`: at the current instant (`step_map` false: only the acceleration
    /// responds, through 1/m) or of the last step's map (zero before the first step).
    fn derivative(
        &mut self,
        step_map: bool,
        unknowns: &[u32],
        knowns: &[u32],
        seed: &[f64],
        out: &mut [f64],
    ) -> Result<(), ModelError> {
        let m = self.mass()?;
        let [sx, sv] = if step_map { self.sens } else { [0.0, 0.0] };
        for &kn in knowns {
            if kn != vr::F {
                return Err(
                    format!("derivatives with respect to value reference {kn} are not provided (only F)").into()
                );
            }
        }
        let df: f64 = seed.iter().sum(); // every known is F
        for (o, &u) in out.iter_mut().zip(unknowns) {
            *o = df
                * match u {
                    vr::X => sx,
                    vr::V => sv,
                    vr::A => (1.0 - self.c * sv - self.k * sx) / m,
                    _ => return Err(format!("no derivative for value reference {u}").into()),
                };
        }
        Ok(())
    }
}

impl Model for Oscillator {
    fn description() -> Result<ModelDescription, ModelError> {
        let mut variables = vec![
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
        ];
        variables.push(
            Variable::new(
                "steps",
                vr::STEPS,
                fmi2::VarType::Integer,
                fmi2::Causality::Output,
                fmi2::Variability::Discrete,
            )
            .describe("communication steps taken")
            .depends_on::<&str>(&[])
            .initially_depends_on::<&str>(&[]),
        );
        Ok(ModelDescription {
            model_name: "fmi2 test oscillator".into(),
            model_identifier: "oscillator".into(),
            guid: "{6f1c2a8e-3b7d-4c59-9e21-0a4d8b7f5c32}".into(),
            description: "Damped mass-spring oscillator, trapezoidal rule; test model of the fmi2 layer".into(),
            version: env!("CARGO_PKG_VERSION").into(),
            capabilities: Capabilities {
                provides_directional_derivative: true,
                can_interpolate_inputs: true,
                provides_step_map_derivative: true,
            },
            default_experiment: Some(DefaultExperiment {
                start_time: 0.0,
                stop_time: 5.0,
                step_size: 0.01,
                tolerance: None,
            }),
            extra_units: vec![],
            variables,
        })
    }

    fn resources() -> Vec<Resource> {
        vec![Resource { name: DEFAULT_CONFIG.into(), bytes: include_bytes!("../resources/oscillator.txt").to_vec() }]
    }

    fn instantiate(resources: Option<&Path>) -> Result<Self, ModelError> {
        let mut m = Oscillator {
            resources: resources.map(Path::to_owned),
            config: DEFAULT_CONFIG.into(),
            mass: None,
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
        };
        // Without a resource location the default config cannot be found; the importer may
        // still set an absolute path.
        if resources.is_some() {
            m.mass = Some(read_config(&m.config_path(DEFAULT_CONFIG)?)?);
        }
        Ok(m)
    }

    fn set_real(&mut self, vr: u32, value: f64) -> Result<(), ModelError> {
        match vr {
            vr::F => self.force = value,
            vr::K if value > 0.0 => self.k = value,
            vr::C if value >= 0.0 => self.c = value,
            vr::K => return Err(format!("{value}: must be positive").into()),
            vr::C => return Err(format!("{value}: must not be negative").into()),
            vr::X0 => self.x0 = value,
            vr::V0 => self.v0 = value,
            _ => return Err(format!("value reference {vr} is not settable").into()),
        }
        Ok(())
    }

    fn get_real(&mut self, vr: u32) -> Result<f64, ModelError> {
        let (x, v) = self.state();
        Ok(match vr {
            vr::F => self.force,
            vr::X => x,
            vr::V => v,
            vr::A => self.acceleration()?,
            vr::K => self.k,
            vr::C => self.c,
            vr::X0 => self.x0,
            vr::V0 => self.v0,
            _ => return Err(format!("unknown value reference {vr}").into()),
        })
    }

    fn set_integer(&mut self, vr: u32, value: i32) -> Result<(), ModelError> {
        match vr {
            vr::SUBSTEPS if (1..=10_000).contains(&value) => self.substeps = value,
            vr::SUBSTEPS => return Err(format!("{value}: must be in 1..=10000").into()),
            vr::MAX_STEPS if value >= 0 => self.max_steps = value,
            vr::MAX_STEPS => return Err(format!("{value}: must not be negative").into()),
            _ => return Err(format!("value reference {vr} is not settable").into()),
        }
        Ok(())
    }

    fn get_integer(&mut self, vr: u32) -> Result<i32, ModelError> {
        match vr {
            vr::SUBSTEPS => Ok(self.substeps),
            vr::STEPS => Ok(self.steps),
            vr::MAX_STEPS => Ok(self.max_steps),
            _ => Err(format!("unknown value reference {vr}").into()),
        }
    }

    fn set_boolean(&mut self, vr: u32, value: bool) -> Result<(), ModelError> {
        match vr {
            vr::GRAVITY => self.gravity = value,
            _ => return Err(format!("value reference {vr} is not settable").into()),
        }
        Ok(())
    }

    fn get_boolean(&mut self, vr: u32) -> Result<bool, ModelError> {
        match vr {
            vr::GRAVITY => Ok(self.gravity),
            _ => Err(format!("unknown value reference {vr}").into()),
        }
    }

    fn set_string(&mut self, vr: u32, value: &str) -> Result<(), ModelError> {
        if vr != vr::CONFIG {
            return Err(format!("value reference {vr} is not settable").into());
        }
        // Read at once, so that a missing or malformed file is reported by fmi2SetString.
        let mass = read_config(&self.config_path(value)?)?;
        (self.config, self.mass) = (value.to_owned(), Some(mass));
        Ok(())
    }

    fn get_string(&mut self, vr: u32) -> Result<String, ModelError> {
        match vr {
            vr::CONFIG => Ok(self.config.clone()),
            _ => Err(format!("unknown value reference {vr}").into()),
        }
    }

    fn exit_initialization(&mut self, _start_time: f64) -> Result<(), ModelError> {
        self.mass()?;
        (self.x, self.v, self.initialized) = (self.x0, self.v0, true);
        Ok(())
    }

    fn do_step(&mut self, t: f64, h: f64) -> Result<StepOutcome, ModelError> {
        let m = self.mass()?;
        if self.max_steps > 0 && self.steps >= self.max_steps {
            return Ok(StepOutcome::Terminated { time: t, reason: format!("max_steps = {} reached", self.max_steps) });
        }
        let hs = h / f64::from(self.substeps);
        let (k, c) = (self.k / m, self.c / m);
        // (I − hs/2 A) y⁺ = (I + hs/2 A) y + hs/(2m) (f⁻ + f⁺) e₂ with A = [[0, 1], [−k/m, −c/m]].
        let det = 1.0 + 0.5 * hs * c + 0.25 * hs * hs * k;
        let solve =
            |r0: f64, r1: f64| ((r0 * (1.0 + 0.5 * hs * c) + 0.5 * hs * r1) / det, (r1 - 0.5 * hs * k * r0) / det);
        let rhs = |x: f64, v: f64| (x + 0.5 * hs * v, v - 0.5 * hs * (k * x + c * v));
        let f0 = self.force + self.weight(m);
        let (mut x, mut v) = (self.x, self.v);
        let mut s = [0.0, 0.0];
        for j in 0..self.substeps {
            let (fa, fb) = (f0 + self.force_rate * hs * f64::from(j), f0 + self.force_rate * hs * f64::from(j + 1));
            let (r0, r1) = rhs(x, v);
            (x, v) = solve(r0, r1 + 0.5 * hs * (fa + fb) / m);
            let (q0, q1) = rhs(s[0], s[1]);
            let (s0, s1) = solve(q0, q1 + hs / m);
            s = [s0, s1];
        }
        if !(x.is_finite() && v.is_finite()) {
            return Err(format!("the state became non-finite (x = {x}, v = {v})").into());
        }
        (self.x, self.v, self.sens) = (x, v, s);
        self.force_rate = 0.0; // derivatives apply to one step; set them again for the next
        self.steps += 1;
        Ok(StepOutcome::Complete)
    }

    fn set_real_input_derivative(&mut self, vr: u32, _order: i32, value: f64) -> Result<(), ModelError> {
        match vr {
            vr::F => self.force_rate = value,
            _ => return Err(format!("value reference {vr} is not an input").into()),
        }
        Ok(())
    }

    /// At an instant only the acceleration responds to the force: ∂a/∂F = 1/m.
    fn directional_derivative(
        &mut self,
        unknowns: &[u32],
        knowns: &[u32],
        seed: &[f64],
        out: &mut [f64],
    ) -> Result<(), ModelError> {
        self.derivative(false, unknowns, knowns, seed, out)
    }

    fn step_map_derivative(
        &mut self,
        unknowns: &[u32],
        knowns: &[u32],
        seed: &[f64],
        out: &mut [f64],
    ) -> Result<(), ModelError> {
        self.derivative(true, unknowns, knowns, seed, out)
    }

    fn save_state(&self, out: &mut Vec<u8>) -> Result<(), ModelError> {
        let mut w = StateWriter::new(out);
        w.str(&self.config).bool(self.mass.is_some()).f64(self.mass.unwrap_or(0.0));
        w.f64(self.k).f64(self.c).f64(self.x0).f64(self.v0).i32(self.substeps).bool(self.gravity);
        w.f64(self.force).f64(self.force_rate).bool(self.initialized).f64(self.x).f64(self.v);
        w.f64(self.sens[0]).f64(self.sens[1]).i32(self.steps).i32(self.max_steps);
        Ok(())
    }

    fn restore_state(&mut self, bytes: &[u8]) -> Result<(), ModelError> {
        let mut r = StateReader::new(bytes);
        let config = r.string()?;
        let (has_mass, mass) = (r.bool()?, r.f64()?);
        let (k, c, x0, v0, substeps, gravity) = (r.f64()?, r.f64()?, r.f64()?, r.f64()?, r.i32()?, r.bool()?);
        let (force, force_rate, initialized, x, v) = (r.f64()?, r.f64()?, r.bool()?, r.f64()?, r.f64()?);
        let (s0, s1, steps, max_steps) = (r.f64()?, r.f64()?, r.i32()?, r.i32()?);
        r.finish()?;
        *self = Oscillator {
            resources: self.resources.take(),
            config,
            mass: has_mass.then_some(mass),
            k,
            c,
            x0,
            v0,
            substeps,
            max_steps,
            gravity,
            force,
            force_rate,
            initialized,
            x,
            v,
            sens: [s0, s1],
            steps,
        };
        Ok(())
    }
}

fmi2::export_fmu!(Oscillator);

#[cfg(test)]
mod tests {
    use super::*;

    fn ready() -> Oscillator {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("resources");
        let mut m = Oscillator::instantiate(Some(&dir)).unwrap();
        m.exit_initialization(0.0).unwrap();
        m
    }

    #[test]
    fn description_is_valid() {
        let info = fmi2::ModelInfo::new(Oscillator::description().unwrap()).unwrap();
        assert_eq!(info.vars.len(), 13);
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
            (m.x - 0.1 * (w * 2.0).cos()).abs()
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
        m.gravity = true;
        m.c = 20.0; // heavily damped: settles quickly
        for i in 0..2000 {
            m.do_step(i as f64 * 0.01, 0.01).unwrap();
        }
        let expected = (3.0 - 2.0 * G) / 40.0;
        assert!((m.x - expected).abs() < 1e-12, "{} vs {expected}", m.x);
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
        let dir = std::env::temp_dir().join(format!("osc-config-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let bad = dir.join("bad.txt");
        std::fs::write(&bad, "# c\nmass_kg = -1\n").unwrap();
        assert!(read_config(&bad).unwrap_err().contains("bad.txt:2: `mass_kg` = -1"));
        std::fs::write(&bad, "mass = 1\n").unwrap();
        assert!(read_config(&bad).unwrap_err().contains("unknown key `mass`"));
        std::fs::write(&bad, "\n").unwrap();
        assert!(read_config(&bad).unwrap_err().contains("missing"));
        assert!(read_config(&dir.join("none.txt")).unwrap_err().contains("cannot read config file"));
        let mut m = Oscillator::instantiate(None).unwrap();
        assert!(m.set_string(vr::CONFIG, "oscillator.txt").unwrap_err().to_string().contains("no resource location"));
        assert!(m.get_real(vr::A).unwrap_err().to_string().contains("no configuration loaded"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
