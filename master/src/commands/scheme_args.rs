//! The command line's flags for the methods and their options. What a value may be, its
//! default and its check are the library's (`studies::options`); the flags' syntax and help
//! texts are the command line's. A test keeps the defaults equal to the library's.

use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use cosim::error_estimate::Kind;
use cosim::{Extrapolation, JacobianUpdate, Relaxation};
use fmi::import::Interface;
use studies::options::{self as lib, MEMORY_MB, Named, UNPACKED_MB};
pub(crate) use studies::options::{
    Compensation, SchemeName, below_one, factor, interface, max_iter, megabytes, positive, relaxation, tolerance, whole,
};
use studies::simulate::Method;

/// A flag's value among one of the library's named choices; `--help` lists them with their help.
pub(crate) fn named<T: Named + Clone>() -> impl TypedValueParser<Value = T> {
    PossibleValuesParser::new(T::ALL.iter().map(|v| PossibleValue::new(v.name()).help(v.help())))
        .map(|name| T::parse(&name).expect("one of the possible values"))
}

/// `--max-memory-mb`.
pub(crate) fn memory_mb(text: &str) -> Result<u64, String> {
    megabytes(text, MEMORY_MB)
}

/// Options of the coupling schemes and the adaptive step.
#[derive(clap::Args, Clone, Debug)]
pub(crate) struct SchemeOptions {
    /// First guess of the end-of-step inputs [default: linear for the iterating schemes (nearer
    /// the answer: at LT50m C fewer iterations per step — iqn-ils 2.33 against 3.12, iterative
    /// 24 against 41 — and ijcsa's reused Jacobian needs no more than a fresh one), constant for
    /// the others (linear would pass slopes to the FMUs: another method)].
    #[arg(long, value_parser = named::<Extrapolation>())]
    pub(crate) extrapolation: Option<Extrapolation>,
    /// Interface tolerance of iterating schemes: every |U − C·Y| ≤ tol · s, with s the largest
    /// start value (at least 1) among the inputs of the same FMU and unit (e.g. the weight for
    /// forces).
    #[arg(long, default_value = "1e-8", value_parser = positive)]
    pub(crate) tol: f64,
    /// Iteration limit per macro step of iterating schemes (exceeding it stops the run).
    #[arg(long, default_value = "100", value_parser = max_iter, allow_negative_numbers = true)]
    pub(crate) max_iter: u32,
    /// Relaxation of `iterative`: a fixed factor in (0, 1], or `aitken` (dynamic; it stalls on
    /// the LT50m scenes, whose interface couples several modes of both signs).
    #[arg(long, default_value = "0.5", value_parser = relaxation)]
    pub(crate) relaxation: Relaxation,
    /// Interface Jacobian of `ijcsa`.
    #[arg(long, default_value = "reuse", value_parser = named::<JacobianUpdate>())]
    pub(crate) jacobian: JacobianUpdate,
    /// Past steps (time windows) whose residual history `iqn-ils` reuses (0: this step's only).
    #[arg(long, default_value_t = lib::SchemeOptions::default().iqn_reuse, value_parser = whole,
          allow_negative_numbers = true)]
    pub(crate) iqn_reuse: usize,
    /// QR filter limit of `iqn-ils` in [0, 1): a history column keeping less than this
    /// fraction of its norm after orthogonalization against newer ones is deleted.
    #[arg(long, default_value_t = lib::SchemeOptions::default().iqn_filter, value_parser = below_one,
          allow_negative_numbers = true)]
    pub(crate) iqn_filter: f64,
    /// Relaxation of the first update of `iqn-ils`, while there is no history, in (0, 1].
    #[arg(long, default_value_t = lib::SchemeOptions::default().iqn_relaxation, value_parser = factor,
          allow_negative_numbers = true)]
    pub(crate) iqn_relaxation: f64,
    /// Adaptive step (monolithic; iterative, ijcsa, iqn-ils): a local error estimate (predictor
    /// against corrector) of the cabin pose (a co-simulation's: of the coupled inputs --watch
    /// names), rejected steps rolled back. The steps are
    /// chosen within [--h-min, --h-max] (the first ones at 10 × --h-min) and the last lands on
    /// the end time; --dt does not apply.
    #[arg(long)]
    pub(crate) adaptive: bool,
    /// Relative tolerance of the adaptive step, in (0, 1): error per step ≤ rtol × how far each
    /// watched quantity has moved from its initial value.
    #[arg(long, default_value = "1e-3", value_parser = tolerance, allow_negative_numbers = true)]
    pub(crate) rtol: f64,
    /// Absolute tolerance of the adaptive step, as a fraction of each coupled quantity's scale.
    #[arg(long, default_value = "1e-6", value_parser = positive, allow_negative_numbers = true)]
    pub(crate) atol: f64,
    /// Smallest step of the adaptive step (s).
    #[arg(long, default_value = "1e-5", value_parser = positive, allow_negative_numbers = true)]
    pub(crate) h_min: f64,
    /// Largest step of the adaptive step (s).
    #[arg(long, default_value = "0.1", value_parser = positive, allow_negative_numbers = true)]
    pub(crate) h_max: f64,
    /// The coupled inputs a co-simulation's adaptive step judges its error by (comma-separated;
    /// `component.variable`, or a prefix ending before a `.` or `[`: `stewart.cabin.r` for
    /// `stewart.cabin.r[1]` … `[3]`). Default: a scene's cabin pose (`stewart.cabin.r`,
    /// `stewart.cabin.q`, what the monolithic model watches), a --system's every coupled input.
    /// Name smooth quantities (positions, velocities): an FMU's accelerations and forces may
    /// carry its integrator's step-to-step ripple, which the estimate reads as error.
    #[arg(long, value_delimiter = ',', value_name = "INPUTS")]
    pub(crate) watch: Vec<String>,
    /// How the adaptive step estimates its local error [default: predictor].
    #[arg(long, value_parser = named::<Kind>())]
    pub(crate) estimate: Option<Kind>,
}

impl SchemeOptions {
    /// The library's options these flags give.
    pub(crate) fn options(&self) -> lib::SchemeOptions {
        lib::SchemeOptions {
            extrapolation: self.extrapolation,
            tol: self.tol,
            max_iter: self.max_iter,
            relaxation: self.relaxation,
            jacobian: self.jacobian,
            iqn_reuse: self.iqn_reuse,
            iqn_filter: self.iqn_filter,
            iqn_relaxation: self.iqn_relaxation,
            adaptive: self.adaptive,
            rtol: self.rtol,
            atol: self.atol,
            h_min: self.h_min,
            h_max: self.h_max,
            watch: self.watch.clone(),
            estimate: self.estimate,
        }
    }

    /// The method of `scheme` with these options (the library's checks of their combination).
    pub(crate) fn method(&self, scheme: SchemeName) -> anyhow::Result<Method> {
        self.options().method(scheme)
    }
}

/// Where a system's files may come from and what unpacking an archive may cost (--system only).
#[derive(clap::Args)]
pub(crate) struct SystemFileArgs {
    /// Let a --system load FMUs and parameter files from outside its archive (or, for an `.ssd`,
    /// outside its folder): absolute paths, `..`, symbolic links out. Off: a system file cannot
    /// make the master load a library from anywhere on the machine.
    #[arg(long)]
    pub(crate) allow_external_fmus: bool,
    /// Most entries an `.ssp` archive may hold [default: 10000].
    #[arg(long, value_parser = whole)]
    pub(crate) max_archive_entries: Option<usize>,
    /// Most megabytes unpacked from an `.ssp` archive: the entries its system references (the
    /// description, the FMUs, the parameter files; nothing else is unpacked) [default: 1024].
    #[arg(long, value_parser = |t: &str| megabytes(t, UNPACKED_MB))]
    pub(crate) max_unpacked_mb: Option<u64>,
    /// Run FMUs that offer both interfaces as Model Exchange (`me`) or Co-Simulation (`cs`, the
    /// default), all of them, or one component: `COMPONENT=me` (comma-separated). An FMU with
    /// one interface runs as that one.
    #[arg(long, value_delimiter = ',', value_name = "[COMPONENT=]me|cs", value_parser = interface)]
    pub(crate) interface: Vec<(Option<String>, Interface)>,
    /// The integrator of Model Exchange components.
    #[arg(long, default_value = "dopri5", value_parser = named::<cosim::me::Method>())]
    pub(crate) me_solver: cosim::me::Method,
    /// Relative tolerance of the Model Exchange integrator, in (0, 1).
    #[arg(long, default_value = "1e-6", value_parser = tolerance, allow_negative_numbers = true)]
    pub(crate) me_rtol: f64,
    /// Absolute tolerance of the Model Exchange integrator (in the states' units).
    #[arg(long, default_value = "1e-8", value_parser = positive, allow_negative_numbers = true)]
    pub(crate) me_atol: f64,
}

impl SystemFileArgs {
    pub(crate) fn files(&self) -> lib::SystemFiles {
        lib::SystemFiles {
            allow_external_fmus: self.allow_external_fmus,
            max_archive_entries: self.max_archive_entries,
            max_unpacked_mb: self.max_unpacked_mb,
            interface: self.interface.clone(),
            me_solver: self.me_solver,
            me_rtol: self.me_rtol,
            me_atol: self.me_atol,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The flags' defaults are the library's, so the command line and the Python package
    /// (which takes the library's) run the same method when nothing is given.
    #[test]
    fn the_flags_default_to_the_librarys_options() {
        #[derive(clap::Parser)]
        struct Empty {
            #[command(flatten)]
            options: SchemeOptions,
        }
        let flags = <Empty as clap::Parser>::parse_from(["master"]).options;
        assert_eq!(flags.options(), lib::SchemeOptions::default());
    }
}
