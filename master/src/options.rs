//! The options that choose and tune a method, as the command line and the Python package give
//! them (`--scheme`, `--tol`, `--adaptive`, ...): the one place for scheme names, scheme options,
//! their ranges and defaults.

use crate::cosim::error_estimate::Kind;
use crate::cosim::step_control::Tolerances;
use crate::cosim::{Extrapolation, IqnOptions, JacobianUpdate, Options, Relaxation, Scheme};
use crate::simulate::Method;
use crate::system::Adaptive;
use anyhow::bail;
use clap::ValueEnum;
use cosim::ssp::read::ReadLimits;
use feedcore::scene::{Control, ValidScene};

/// The methods `--scheme` and `--schemes` know, and what each needs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum SchemeName {
    /// The cable–cabin model alone, platform locked, under the scene's [disturbance]; in-process.
    Cable,
    /// Eq. (7): the whole system in one model, no FMUs; the accuracy reference.
    Monolithic,
    /// Every FMU steps with the inputs of the last communication point.
    Jacobi,
    /// The FMUs one after the other (cable first), each with the newest outputs.
    GaussSeidel,
    /// Gauss–Seidel with the Stewart FMU first.
    GaussSeidelReversed,
    /// Fixed point with rollback (needs get/set FMU state); --relaxation.
    Iterative,
    /// Newton on the interface with its Jacobian (needs get/set FMU state; directional
    /// derivatives, else finite differences).
    Ijcsa,
    /// Interface quasi-Newton: least squares on the residual history of this and the last
    /// steps, no derivatives (needs get/set FMU state); --iqn-*.
    IqnIls,
    /// Ref. [3]: the Stewart wrench on a cabin held at its static pose, fed to the cable model.
    Decoupled,
}

impl SchemeName {
    /// The coupling scheme the name selects; none for the methods that are not a co-simulation
    /// of their own (the cable model alone, the monolithic and the decoupled models).
    pub fn coupling(self) -> Option<Scheme> {
        match self {
            SchemeName::Cable | SchemeName::Monolithic | SchemeName::Decoupled => None,
            SchemeName::Jacobi => Some(Scheme::Jacobi),
            SchemeName::GaussSeidel => Some(Scheme::GaussSeidel { reversed: false }),
            SchemeName::GaussSeidelReversed => Some(Scheme::GaussSeidel { reversed: true }),
            SchemeName::Iterative => Some(Scheme::Iterative),
            SchemeName::Ijcsa => Some(Scheme::Ijcsa),
            SchemeName::IqnIls => Some(Scheme::IqnIls),
        }
    }

    /// The name as written on the command line (a coupling scheme's is its own name).
    pub fn as_str(self) -> &'static str {
        match self {
            SchemeName::Cable => "cable",
            SchemeName::Monolithic => "monolithic",
            SchemeName::Decoupled => "decoupled",
            other => other.coupling().map_or("", Scheme::name),
        }
    }

    /// Whether the scheme iterates within a macro step.
    pub fn iterates(self) -> bool {
        self.coupling().is_some_and(Scheme::is_implicit)
    }

    /// Whether the method has an adaptive step: the monolithic model and the schemes that
    /// iterate (they can take a step back).
    pub fn has_adaptive_step(self) -> bool {
        self == SchemeName::Monolithic || self.iterates()
    }

    /// Cost of a step against the monolithic model's, to order parallel runs longest first
    /// (measured at LT50m, 100 s at h = 0.01: IJCSA 1.2×, IQN-ILS 1.3×; the fixed point 10–20×
    /// IJCSA; the explicit schemes step each FMU once, the cable model and the decoupled model
    /// carry one net). An estimate: only the order it gives counts.
    pub fn relative_cost(self) -> f64 {
        match self {
            SchemeName::Cable => 0.3,
            SchemeName::Decoupled => 0.5,
            SchemeName::Jacobi | SchemeName::GaussSeidel | SchemeName::GaussSeidelReversed => 0.7,
            SchemeName::Monolithic => 1.0,
            SchemeName::Ijcsa => 1.2,
            SchemeName::IqnIls => 1.3,
            SchemeName::Iterative => 20.0,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ExtrapolationArg {
    /// The last outputs.
    Constant,
    /// Extrapolated from the last two (non-iterating schemes pass the slope to the FMUs
    /// through fmi2SetRealInputDerivatives).
    Linear,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum JacobianArg {
    /// Recomputed every step.
    EveryStep,
    /// Kept across steps and secant-updated (Broyden) from each step's iterates; a unit whose
    /// block goes stale is recomputed at each of the next 100 steps, every unit's when Newton
    /// contracts slowly.
    /// With `--extrapolation linear` as many iterations as `every-step` on LT50m at a fraction
    /// of the cost (the cable FMU's derivative once per run).
    Reuse,
}

/// `--relaxation`: `aitken` or a factor in (0, 1].
pub fn relaxation(text: &str) -> Result<Relaxation, String> {
    if text == "aitken" {
        return Ok(Relaxation::Aitken);
    }
    match text.parse::<f64>() {
        Ok(w) if w > 0.0 && w <= 1.0 => Ok(Relaxation::Fixed(w)),
        _ => Err(format!("`{text}`: give `aitken` or a factor in (0, 1]")),
    }
}

/// A positive finite number.
pub fn positive(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(x) if x > 0.0 && x.is_finite() => Ok(x),
        Ok(x) => Err(format!("{x} is not a positive finite number")),
        Err(e) => Err(format!("`{text}`: {e}")),
    }
}

/// A number in [0, 1).
pub fn below_one(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(x) if (0.0..1.0).contains(&x) => Ok(x),
        _ => Err(format!("`{text}`: give a number in [0, 1)")),
    }
}

/// A factor in (0, 1].
pub fn factor(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(x) if x > 0.0 && x <= 1.0 => Ok(x),
        _ => Err(format!("`{text}`: give a factor in (0, 1]")),
    }
}

/// A relative tolerance in (0, 1).
pub fn tolerance(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(x) if x > 0.0 && x < 1.0 => Ok(x),
        _ => Err(format!("`{text}`: give a tolerance in (0, 1)")),
    }
}

/// `--compensation`: the second level as the scene has it, or switched off.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum CompensationArg {
    /// As the scene's `[control]` says.
    #[default]
    On,
    /// Switched off: the uncompensated reference of the same scene (the platform holds its start
    /// pose relative to the cabin; the feed error is still reported).
    Off,
}

impl CompensationArg {
    /// The scene to run; `off` needs a scene with `[control]`.
    pub fn apply(self, scene: &ValidScene) -> anyhow::Result<ValidScene> {
        match (self, &scene.control) {
            (CompensationArg::On, _) => Ok(scene.clone()),
            (CompensationArg::Off, None) => bail!(
                "--compensation off: {} has no [control] section, so there is no compensation to switch off",
                scene.file()
            ),
            (CompensationArg::Off, Some(_)) => {
                Ok(scene.edited(|s| s.control.as_mut().into_iter().for_each(Control::switch_off))?)
            }
        }
    }
}

/// A step given with the adaptive step is refused: the adaptive step chooses its own.
pub fn check_dt(adaptive: bool, dt: Option<f64>) -> anyhow::Result<()> {
    if adaptive && dt.is_some() {
        bail!(
            "--dt: the adaptive step chooses its own steps within [--h-min, --h-max] and lands on the end time; \
             drop --dt, or --adaptive for fixed steps"
        );
    }
    Ok(())
}

/// Bytes per megabyte of --max-memory-mb (decimal, as memory is quoted).
pub const MEMORY_MB: u64 = 1_000_000;
/// Bytes per megabyte of --max-unpacked-mb (binary, as archive sizes are).
pub const UNPACKED_MB: u64 = 1 << 20;

/// A number of megabytes of `bytes_per_mb` bytes each, refused if the bytes do not fit in 64
/// bits (so that no cap wraps around to a small one).
pub fn megabytes(text: &str, bytes_per_mb: u64) -> Result<u64, String> {
    let mb: u64 = text.trim().parse().map_err(|e| format!("`{text}` is not a whole number of megabytes: {e}"))?;
    let most = u64::MAX / bytes_per_mb;
    if mb > most {
        return Err(format!("{mb} MB is more bytes than can be counted (at most {most} MB)"));
    }
    Ok(mb)
}

/// Where a system's files may come from and what unpacking an archive may cost (--system only).
#[derive(clap::Args)]
pub struct SystemFileArgs {
    /// Let a --system load FMUs and parameter files from outside its archive (or, for an `.ssd`,
    /// outside its folder): absolute paths, `..`, symbolic links out. Off: a system file cannot
    /// make the master load a library from anywhere on the machine.
    #[arg(long)]
    pub allow_external_fmus: bool,
    /// Most entries an `.ssp` archive may hold [default: 10000].
    #[arg(long)]
    pub max_archive_entries: Option<usize>,
    /// Most megabytes unpacked from an `.ssp` archive: the entries its system references (the
    /// description, the FMUs, the parameter files; nothing else is unpacked) [default: 1024].
    #[arg(long, value_parser = |t: &str| megabytes(t, UNPACKED_MB))]
    pub max_unpacked_mb: Option<u64>,
    /// Run FMUs that offer both interfaces as Model Exchange (`me`) or Co-Simulation (`cs`, the
    /// default), all of them, or one component: `COMPONENT=me` (comma-separated). An FMU with
    /// one interface runs as that one.
    #[arg(long, value_delimiter = ',', value_name = "[COMPONENT=]me|cs")]
    pub interface: Vec<String>,
    /// The integrator of Model Exchange components: `dopri5` (explicit) or `esdirk3` (implicit,
    /// for stiff models).
    #[arg(long, default_value = "dopri5", value_parser = ["dopri5", "esdirk3"])]
    pub me_solver: String,
    /// Relative tolerance of the Model Exchange integrator, in (0, 1).
    #[arg(long, default_value = "1e-6", value_parser = tolerance, allow_negative_numbers = true)]
    pub me_rtol: f64,
    /// Absolute tolerance of the Model Exchange integrator (in the states' units).
    #[arg(long, default_value = "1e-8", value_parser = positive, allow_negative_numbers = true)]
    pub me_atol: f64,
}

impl SystemFileArgs {
    pub fn limits(&self) -> ReadLimits {
        let default = ReadLimits::default();
        ReadLimits {
            max_entries: self.max_archive_entries.unwrap_or(default.max_entries),
            max_unpacked_bytes: self.max_unpacked_mb.map_or(default.max_unpacked_bytes, |mb| mb * UNPACKED_MB),
            allow_external: self.allow_external_fmus,
        }
    }

    /// The interfaces asked for (component or all, interface) and the Model Exchange integrator.
    pub fn model_exchange(&self) -> anyhow::Result<crate::system::ModelExchangeChoice> {
        use fmi2::import::Interface;
        let mut interfaces = Vec::new();
        for item in &self.interface {
            let (component, name) = match item.split_once('=') {
                Some((c, n)) => (Some(c.trim().to_owned()), n.trim()),
                None => (None, item.trim()),
            };
            let interface = match name {
                "me" => Interface::ModelExchange,
                "cs" => Interface::CoSimulation,
                other => bail!("--interface {item}: `{other}` is neither `me` nor `cs`"),
            };
            interfaces.push((component, interface));
        }
        let method = if self.me_solver == "esdirk3" { cosim::me::Method::Esdirk3 } else { cosim::me::Method::Dopri5 };
        let tol = cosim::me::Tolerances { rtol: self.me_rtol, atol: self.me_atol };
        Ok(crate::system::ModelExchangeChoice { interfaces, options: cosim::me::MeOptions { method, tol } })
    }

    /// The options given, for a run that has no system to apply them to.
    pub fn given(&self) -> Option<&'static str> {
        [
            (self.allow_external_fmus, "--allow-external-fmus"),
            (self.max_archive_entries.is_some(), "--max-archive-entries"),
            (self.max_unpacked_mb.is_some(), "--max-unpacked-mb"),
            (!self.interface.is_empty(), "--interface"),
        ]
        .into_iter()
        .find_map(|(given, name)| given.then_some(name))
    }
}

/// Options of the coupling schemes.
#[derive(clap::Args, Clone, Debug)]
pub struct SchemeOptions {
    /// First guess of the end-of-step inputs [default: linear for the iterating schemes (nearer
    /// the answer: at LT50m C fewer iterations per step — iqn-ils 2.33 against 3.12, iterative
    /// 24 against 41 — and ijcsa's reused Jacobian needs no more than a fresh one), constant for
    /// the others (linear would pass slopes to the FMUs: another method)].
    #[arg(long, value_enum)]
    pub extrapolation: Option<ExtrapolationArg>,
    /// Interface tolerance of iterating schemes: every |U − C·Y| ≤ tol · s, with s the largest
    /// start value (at least 1) among the inputs of the same FMU and unit (e.g. the weight for
    /// forces).
    #[arg(long, default_value = "1e-8", value_parser = positive)]
    pub tol: f64,
    /// Iteration limit per macro step of iterating schemes (exceeding it stops the run).
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    pub max_iter: u32,
    /// Relaxation of `iterative`: a fixed factor in (0, 1], or `aitken` (dynamic; it stalls on
    /// the LT50m scenes, whose interface couples several modes of both signs).
    #[arg(long, default_value = "0.5", value_parser = relaxation)]
    pub relaxation: Relaxation,
    /// Interface Jacobian of `ijcsa`.
    #[arg(long, value_enum, default_value_t = JacobianArg::Reuse)]
    pub jacobian: JacobianArg,
    /// Past steps (time windows) whose residual history `iqn-ils` reuses (0: this step's only).
    #[arg(long, default_value_t = IqnOptions::default().reuse)]
    pub iqn_reuse: usize,
    /// QR filter limit of `iqn-ils` in [0, 1): a history column keeping less than this
    /// fraction of its norm after orthogonalization against newer ones is deleted.
    #[arg(long, default_value_t = IqnOptions::default().filter, value_parser = below_one,
          allow_negative_numbers = true)]
    pub iqn_filter: f64,
    /// Relaxation of the first update of `iqn-ils`, while there is no history, in (0, 1].
    #[arg(long, default_value_t = IqnOptions::default().initial_relaxation, value_parser = factor,
          allow_negative_numbers = true)]
    pub iqn_relaxation: f64,
    /// Adaptive step (monolithic; iterative, ijcsa, iqn-ils): a local error estimate (predictor
    /// against corrector) of the cabin pose (a co-simulation's: of the coupled inputs --watch
    /// names), rejected steps rolled back. The steps are
    /// chosen within [--h-min, --h-max] (the first ones at 10 × --h-min) and the last lands on
    /// the end time; --dt does not apply.
    #[arg(long)]
    pub adaptive: bool,
    /// Relative tolerance of the adaptive step, in (0, 1): error per step ≤ rtol × how far each
    /// watched quantity has moved from its initial value.
    #[arg(long, default_value = "1e-3", value_parser = tolerance, allow_negative_numbers = true)]
    pub rtol: f64,
    /// Absolute tolerance of the adaptive step, as a fraction of each coupled quantity's scale.
    #[arg(long, default_value = "1e-6", value_parser = positive, allow_negative_numbers = true)]
    pub atol: f64,
    /// Smallest step of the adaptive step (s).
    #[arg(long, default_value = "1e-5", value_parser = positive, allow_negative_numbers = true)]
    pub h_min: f64,
    /// Largest step of the adaptive step (s).
    #[arg(long, default_value = "0.1", value_parser = positive, allow_negative_numbers = true)]
    pub h_max: f64,
    /// The coupled inputs a co-simulation's adaptive step judges its error by (comma-separated;
    /// `component.variable`, or a prefix ending before a `.` or `[`: `stewart.cabin.r` for
    /// `stewart.cabin.r[1]` … `[3]`). Default: a scene's cabin pose (`stewart.cabin.r`,
    /// `stewart.cabin.q`, what the monolithic model watches), a --system's every coupled input.
    /// Name smooth quantities (positions, velocities): an FMU's accelerations and forces may
    /// carry its integrator's step-to-step ripple, which the estimate reads as error.
    #[arg(long, value_delimiter = ',', value_name = "INPUTS")]
    pub watch: Vec<String>,
    /// How the adaptive step estimates its local error [default: predictor].
    #[arg(long, value_enum)]
    pub estimate: Option<EstimateArg>,
}

/// `--estimate`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum EstimateArg {
    /// The step against the parabola of the last three steps: no extra step; assumes a
    /// second-order coupled step (the FMUs of this workspace, the monolithic model)
    Predictor,
    /// The step taken again as two half steps: three steps per accepted one; assumes nothing of the
    /// FMUs (e.g. FMUs holding their inputs over the step, a first-order coupling)
    Doubling,
}

impl SchemeOptions {
    /// The method of `scheme` with these options; refused: `--adaptive` with a scheme that does
    /// not iterate.
    pub fn method(&self, scheme: SchemeName) -> anyhow::Result<Method> {
        if self.adaptive && !scheme.has_adaptive_step() {
            bail!(
                "--adaptive needs the monolithic model or a scheme that iterates (iterative, ijcsa, iqn-ils); \
                 `{}` has no adaptive step",
                scheme.as_str()
            );
        }
        if !self.adaptive && !self.watch.is_empty() {
            bail!("--watch names what the adaptive step watches: it needs --adaptive");
        }
        if !self.adaptive && self.estimate.is_some() {
            bail!("--estimate chooses how the adaptive step estimates its error: it needs --adaptive");
        }
        let mut options = Options {
            scheme: Scheme::Jacobi,
            extrapolation: match self.extrapolation {
                Some(ExtrapolationArg::Constant) => Extrapolation::Constant,
                Some(ExtrapolationArg::Linear) => Extrapolation::Linear,
                None if matches!(scheme, SchemeName::Ijcsa | SchemeName::IqnIls | SchemeName::Iterative) => {
                    Extrapolation::Linear
                }
                None => Extrapolation::Constant,
            },
            relaxation: self.relaxation,
            jacobian: match self.jacobian {
                JacobianArg::EveryStep => JacobianUpdate::EveryStep,
                JacobianArg::Reuse => JacobianUpdate::Reuse,
            },
            tol: self.tol,
            max_iter: self.max_iter as usize,
            iqn: IqnOptions { reuse: self.iqn_reuse, filter: self.iqn_filter, initial_relaxation: self.iqn_relaxation },
        };
        options.scheme = match scheme {
            SchemeName::Monolithic if self.adaptive => {
                return Ok(Method::MonolithicAdaptive(self.adaptive_settings()?));
            }
            SchemeName::Monolithic => return Ok(Method::Monolithic),
            SchemeName::Cable => return Ok(Method::CableOnly),
            SchemeName::Decoupled => return Ok(Method::Decoupled(options)),
            other => other.coupling().expect("the other methods are coupling schemes"),
        };
        if self.adaptive {
            return Ok(Method::CosimAdaptive(options, self.adaptive_settings()?));
        }
        Ok(Method::Cosim(options))
    }

    /// The same options at a fixed step (e.g. for a reference run).
    pub fn fixed_step(&self) -> SchemeOptions {
        SchemeOptions { adaptive: false, watch: Vec::new(), estimate: None, ..self.clone() }
    }

    /// The adaptive step's settings (each value range checked by its parser).
    fn adaptive_settings(&self) -> anyhow::Result<Adaptive> {
        if self.h_max < self.h_min {
            bail!(
                "--h-min {} s and --h-max {} s: the smallest step must not exceed the largest",
                self.h_min,
                self.h_max
            );
        }
        Ok(Adaptive {
            tolerances: Tolerances { rtol: self.rtol, atol: self.atol },
            h_min: self.h_min,
            h_max: self.h_max,
            watch: self.watch.clone(),
            estimate: match self.estimate {
                None | Some(EstimateArg::Predictor) => Kind::Predictor,
                Some(EstimateArg::Doubling) => Kind::Doubling,
            },
        })
    }
}

impl Default for SchemeOptions {
    /// Every option at its default, as an empty command line gives them (the defaults live in
    /// one place: the attributes above).
    fn default() -> Self {
        #[derive(clap::Parser)]
        struct Empty {
            #[command(flatten)]
            options: SchemeOptions,
        }
        <Empty as clap::Parser>::parse_from(["master"]).options
    }
}

#[cfg(test)]
mod tests {
    use super::SchemeName;
    use clap::ValueEnum;

    /// The names the tool prints are the ones its command line takes, coupling schemes' included.
    #[test]
    fn every_method_prints_the_name_it_is_given_by() {
        for name in SchemeName::value_variants() {
            let given = name.to_possible_value().expect("no method is hidden");
            assert_eq!(name.as_str(), given.get_name());
            assert_eq!(name.iterates(), matches!(name, SchemeName::Iterative | SchemeName::Ijcsa | SchemeName::IqnIls));
        }
    }
}
