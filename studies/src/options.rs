//! The methods and the options that tune them, as every front end gives them (the command
//! line's flags, the Python package's keyword arguments): the one place for the method names,
//! the options' defaults and ranges, and the check of every value as the user typed it.

use crate::cosim::error_estimate::Kind;
use crate::cosim::step_control::Tolerances;
use crate::cosim::{Extrapolation, IqnOptions, JacobianUpdate, Options, Relaxation, Scheme};
use crate::simulate::Method;
use crate::system::Adaptive;
use anyhow::bail;
use cosim::ssp::read::ReadLimits;
use feedcore::scene::{Control, ValidScene};
use fmi::import::Interface;

/// A choice among named values, as a user gives it (a flag's value, a keyword's string): the
/// names, a line of help for each, and parsing.
pub trait Named: Copy + Send + Sync + 'static {
    /// Every value, in the order help lists them.
    const ALL: &'static [Self];
    /// The name a user gives.
    fn name(self) -> &'static str;
    /// What the value means, in a line.
    fn help(self) -> &'static str;

    /// The value named `text`, or why there is none.
    fn parse(text: &str) -> Result<Self, String> {
        Self::ALL.iter().copied().find(|v| v.name() == text).ok_or_else(|| {
            let names: Vec<&str> = Self::ALL.iter().map(|v| v.name()).collect();
            format!("`{text}` is not one of {}", names.join(", "))
        })
    }
}

/// The methods a run can take, and what each needs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
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

impl Named for SchemeName {
    const ALL: &'static [SchemeName] = &[
        SchemeName::Cable,
        SchemeName::Monolithic,
        SchemeName::Jacobi,
        SchemeName::GaussSeidel,
        SchemeName::GaussSeidelReversed,
        SchemeName::Iterative,
        SchemeName::Ijcsa,
        SchemeName::IqnIls,
        SchemeName::Decoupled,
    ];

    fn name(self) -> &'static str {
        self.as_str()
    }

    fn help(self) -> &'static str {
        match self {
            SchemeName::Cable => {
                "The cable–cabin model alone, platform locked, under the scene's [disturbance]; in-process"
            }
            SchemeName::Monolithic => "Eq. (7): the whole system in one model, no FMUs; the accuracy reference",
            SchemeName::Jacobi => "Every FMU steps with the inputs of the last communication point",
            SchemeName::GaussSeidel => "The FMUs one after the other (cable first), each with the newest outputs",
            SchemeName::GaussSeidelReversed => "Gauss–Seidel with the Stewart FMU first",
            SchemeName::Iterative => "Fixed point with rollback (needs get/set FMU state); --relaxation",
            SchemeName::Ijcsa => {
                "Newton on the interface with its Jacobian (needs get/set FMU state; directional derivatives, else \
                 finite differences)"
            }
            SchemeName::IqnIls => {
                "Interface quasi-Newton: least squares on the residual history of this and the last steps, no \
                 derivatives (needs get/set FMU state); --iqn-*"
            }
            SchemeName::Decoupled => {
                "Ref. [3]: the Stewart wrench on a cabin held at its static pose, fed to the cable model"
            }
        }
    }
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

impl Named for Extrapolation {
    const ALL: &'static [Extrapolation] = &[Extrapolation::Constant, Extrapolation::Linear];

    fn name(self) -> &'static str {
        match self {
            Extrapolation::Constant => "constant",
            Extrapolation::Linear => "linear",
        }
    }

    fn help(self) -> &'static str {
        match self {
            Extrapolation::Constant => "The last outputs",
            Extrapolation::Linear => {
                "Extrapolated from the last two (non-iterating schemes pass the slope to the FMUs through \
                 fmi2SetRealInputDerivatives)"
            }
        }
    }
}

impl Named for JacobianUpdate {
    const ALL: &'static [JacobianUpdate] = &[JacobianUpdate::EveryStep, JacobianUpdate::Reuse];

    fn name(self) -> &'static str {
        match self {
            JacobianUpdate::EveryStep => "every-step",
            JacobianUpdate::Reuse => "reuse",
        }
    }

    fn help(self) -> &'static str {
        match self {
            JacobianUpdate::EveryStep => "Recomputed every step",
            JacobianUpdate::Reuse => {
                "Kept across steps and secant-updated (Broyden) from each step's iterates; a unit whose block goes \
                 stale is recomputed at each of the next 100 steps, every unit's when Newton contracts slowly. With \
                 --extrapolation linear as many iterations as every-step on LT50m at a fraction of the cost (the \
                 cable FMU's derivative once per run)"
            }
        }
    }
}

impl Named for Kind {
    const ALL: &'static [Kind] = &[Kind::Predictor, Kind::Doubling];

    fn name(self) -> &'static str {
        match self {
            Kind::Predictor => "predictor",
            Kind::Doubling => "doubling",
        }
    }

    fn help(self) -> &'static str {
        match self {
            Kind::Predictor => {
                "The step against the parabola of the last three steps: no extra step; assumes a second-order \
                 coupled step (the FMUs of this workspace, the monolithic model)"
            }
            Kind::Doubling => {
                "The step taken again as two half steps: three steps per accepted one; assumes nothing of the FMUs \
                 (e.g. FMUs holding their inputs over the step, a first-order coupling)"
            }
        }
    }
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

/// A finite number.
pub fn finite(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        _ => Err(format!("`{text}`: give a finite number")),
    }
}

/// A whole number (a count).
pub fn whole(text: &str) -> Result<usize, String> {
    text.trim().parse().map_err(|e| format!("`{text}`: {e}"))
}

/// Worker threads: 1 to 65535.
pub fn jobs(text: &str) -> Result<usize, String> {
    match text.trim().parse::<u16>() {
        Ok(n) if n >= 1 => Ok(usize::from(n)),
        _ => Err(format!("`{text}`: give a number of threads from 1 to 65535")),
    }
}

/// A non-negative finite number.
pub fn non_negative(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(x) if x >= 0.0 && x.is_finite() => Ok(x),
        Ok(x) => Err(format!("{x} is not a non-negative finite number")),
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

/// The second level as the scene has it, or switched off.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Compensation {
    #[default]
    On,
    Off,
}

impl Named for Compensation {
    const ALL: &'static [Compensation] = &[Compensation::On, Compensation::Off];

    fn name(self) -> &'static str {
        match self {
            Compensation::On => "on",
            Compensation::Off => "off",
        }
    }

    fn help(self) -> &'static str {
        match self {
            Compensation::On => "As the scene's `[control]` says",
            Compensation::Off => {
                "Switched off: the uncompensated reference of the same scene (the platform holds its start pose \
                 relative to the cabin; the feed error is still reported)"
            }
        }
    }
}

impl Compensation {
    /// The scene to run; `off` needs a scene with `[control]`.
    pub fn apply(self, scene: &ValidScene) -> anyhow::Result<ValidScene> {
        match (self, &scene.control) {
            (Compensation::On, _) => Ok(scene.clone()),
            (Compensation::Off, None) => bail!(
                "--compensation off: {} has no [control] section, so there is no compensation to switch off",
                scene.file()
            ),
            (Compensation::Off, Some(_)) => {
                Ok(scene.edited(|s| s.control.as_mut().into_iter().for_each(Control::switch_off))?)
            }
        }
    }
}

/// A wind record's seed: a whole number from 0 to 2⁶⁴ − 1.
pub fn seed(text: &str) -> Result<u64, String> {
    text.trim().parse().map_err(|_| format!("`{text}`: a seed is a whole number from 0 to {}", u64::MAX))
}

/// The scene with another record of its wind (`[wind] seed`, `--wind-seed`): the same spectrum;
/// refused for a scene without `[wind]`.
pub fn with_wind_seed(scene: &ValidScene, seed: Option<u64>) -> anyhow::Result<ValidScene> {
    let Some(seed) = seed else { return Ok(scene.clone()) };
    if scene.wind.is_none() {
        bail!("--wind-seed: {} has no [wind] section, so there is no wind record to draw", scene.file());
    }
    Ok(scene.edited(|s| s.wind.iter_mut().for_each(|w| w.seed = seed))?)
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

/// Where a system's files may come from and what unpacking an archive may cost, and how its
/// Model Exchange components are integrated.
#[derive(Clone, Debug, PartialEq)]
pub struct SystemFiles {
    /// Load FMUs and parameter files from outside the archive (or, for an `.ssd`, its folder).
    pub allow_external_fmus: bool,
    /// Most entries an `.ssp` archive may hold [default: 10000].
    pub max_archive_entries: Option<usize>,
    /// Most megabytes ([`UNPACKED_MB`]) unpacked from an `.ssp` archive [default: 1024];
    /// checked by [`megabytes`].
    pub max_unpacked_mb: Option<u64>,
    /// The interface to run FMUs that offer both as: all of them (no component), or one
    /// component; an FMU with one interface runs as that one ([`interface`]).
    pub interface: Vec<(Option<String>, Interface)>,
    /// The integrator of Model Exchange components, and its tolerances (relative in (0, 1),
    /// absolute in the states' units).
    pub me_solver: cosim::me::Method,
    pub me_rtol: f64,
    pub me_atol: f64,
}

impl Default for SystemFiles {
    fn default() -> Self {
        SystemFiles {
            allow_external_fmus: false,
            max_archive_entries: None,
            max_unpacked_mb: None,
            interface: Vec::new(),
            me_solver: cosim::me::Method::Dopri5,
            me_rtol: 1e-6,
            me_atol: 1e-8,
        }
    }
}

/// An interface choice as typed: `me` or `cs` for every FMU offering both, `COMPONENT=me` for one.
pub fn interface(text: &str) -> Result<(Option<String>, Interface), String> {
    let (component, name) = match text.split_once('=') {
        Some((c, n)) => (Some(c.trim().to_owned()), n.trim()),
        None => (None, text.trim()),
    };
    match name {
        "me" => Ok((component, Interface::ModelExchange)),
        "cs" => Ok((component, Interface::CoSimulation)),
        other => Err(format!("`{other}` is neither `me` nor `cs`")),
    }
}

impl Named for cosim::me::Method {
    const ALL: &'static [cosim::me::Method] = &[cosim::me::Method::Dopri5, cosim::me::Method::Esdirk3];

    fn name(self) -> &'static str {
        match self {
            cosim::me::Method::Dopri5 => "dopri5",
            cosim::me::Method::Esdirk3 => "esdirk3",
        }
    }

    fn help(self) -> &'static str {
        match self {
            cosim::me::Method::Dopri5 => "Dormand–Prince 5(4), explicit",
            cosim::me::Method::Esdirk3 => "ESDIRK 3(2), implicit, L-stable: for stiff models",
        }
    }
}

impl SystemFiles {
    pub fn limits(&self) -> ReadLimits {
        let default = ReadLimits::default();
        ReadLimits {
            max_entries: self.max_archive_entries.unwrap_or(default.max_entries),
            max_unpacked_bytes: self
                .max_unpacked_mb
                .map_or(default.max_unpacked_bytes, |mb| mb.saturating_mul(UNPACKED_MB)),
            allow_external: self.allow_external_fmus,
        }
    }

    /// The interfaces asked for (component or all, interface) and the Model Exchange integrator.
    pub fn model_exchange(&self) -> crate::system::ModelExchangeChoice {
        let tol = cosim::me::Tolerances { rtol: self.me_rtol, atol: self.me_atol };
        crate::system::ModelExchangeChoice {
            interfaces: self.interface.clone(),
            options: cosim::me::MeOptions { method: self.me_solver, tol },
        }
    }

    /// The first option given (its name), for a run that has no system to apply it to.
    pub fn given(&self) -> Option<&'static str> {
        [
            (self.allow_external_fmus, "allow-external-fmus"),
            (self.max_archive_entries.is_some(), "max-archive-entries"),
            (self.max_unpacked_mb.is_some(), "max-unpacked-mb"),
            (!self.interface.is_empty(), "interface"),
        ]
        .into_iter()
        .find_map(|(given, name)| given.then_some(name))
    }
}

/// Options of the methods (the coupling schemes, the adaptive step); each value within the
/// range its check below gives ([`positive`], [`tolerance`], ...).
#[derive(Clone, Debug, PartialEq)]
pub struct SchemeOptions {
    /// First guess of the end-of-step inputs; `None`: linear for the iterating schemes (nearer
    /// the answer: at LT50m C fewer iterations per step — iqn-ils 2.33 against 3.12, iterative
    /// 24 against 41 — and ijcsa's reused Jacobian needs no more than a fresh one), constant for
    /// the others (linear would pass slopes to the FMUs: another method).
    pub extrapolation: Option<Extrapolation>,
    /// Interface tolerance of iterating schemes.
    pub tol: f64,
    /// Iteration limit per macro step of iterating schemes ([`MAX_ITER`]).
    pub max_iter: u32,
    /// Relaxation of `iterative`.
    pub relaxation: Relaxation,
    /// Interface Jacobian of `ijcsa`.
    pub jacobian: JacobianUpdate,
    /// Past steps whose residual history `iqn-ils` reuses.
    pub iqn_reuse: usize,
    /// QR filter limit of `iqn-ils`, in [0, 1).
    pub iqn_filter: f64,
    /// Relaxation of the first update of `iqn-ils`, in (0, 1].
    pub iqn_relaxation: f64,
    /// The adaptive step (monolithic; iterative, ijcsa, iqn-ils).
    pub adaptive: bool,
    /// Relative and absolute tolerances of the adaptive step.
    pub rtol: f64,
    pub atol: f64,
    /// Smallest and largest step of the adaptive step, s.
    pub h_min: f64,
    pub h_max: f64,
    /// What a co-simulation's adaptive step judges its error by (names or prefixes).
    pub watch: Vec<String>,
    /// How the adaptive step estimates its local error; `None`: the predictor.
    pub estimate: Option<Kind>,
}

impl Default for SchemeOptions {
    fn default() -> Self {
        let iqn = IqnOptions::default();
        SchemeOptions {
            extrapolation: None,
            tol: 1e-8,
            max_iter: 100,
            relaxation: Relaxation::Fixed(0.5),
            jacobian: JacobianUpdate::Reuse,
            iqn_reuse: iqn.reuse,
            iqn_filter: iqn.filter,
            iqn_relaxation: iqn.initial_relaxation,
            adaptive: false,
            rtol: 1e-3,
            atol: 1e-6,
            h_min: 1e-5,
            h_max: 0.1,
            watch: Vec::new(),
            estimate: None,
        }
    }
}

/// The range of `max_iter`.
pub const MAX_ITER: std::ops::RangeInclusive<u32> = 1..=100_000;

/// `max_iter` as typed: a whole number in [`MAX_ITER`].
pub fn max_iter(text: &str) -> Result<u32, String> {
    match text.trim().parse::<u32>() {
        Ok(n) if MAX_ITER.contains(&n) => Ok(n),
        _ => Err(format!("`{text}`: give a whole number in {}..={}", MAX_ITER.start(), MAX_ITER.end())),
    }
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
                Some(e) => e,
                None if scheme.iterates() => Extrapolation::Linear,
                None => Extrapolation::Constant,
            },
            relaxation: self.relaxation,
            jacobian: self.jacobian,
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
            estimate: self.estimate.unwrap_or(Kind::Predictor),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every name parses back to its value, and an unknown one is refused listing the names.
    #[test]
    fn every_named_value_parses_from_its_name() {
        fn round_trip<T: Named + PartialEq + std::fmt::Debug>() {
            for v in T::ALL {
                assert_eq!(T::parse(v.name()), Ok(*v));
                assert!(!v.help().is_empty());
            }
            let e = T::parse("nonsense").unwrap_err();
            assert!(e.contains("nonsense") && e.contains(T::ALL[0].name()), "{e}");
        }
        round_trip::<SchemeName>();
        round_trip::<Extrapolation>();
        round_trip::<JacobianUpdate>();
        round_trip::<Kind>();
        round_trip::<Compensation>();
        for name in SchemeName::ALL {
            assert_eq!(name.iterates(), matches!(name, SchemeName::Iterative | SchemeName::Ijcsa | SchemeName::IqnIls));
        }
    }
}
