//! Command-line options that choose and tune a method (shared by run, compare, bench,
//! stability): the one place for scheme names and scheme options.

use clap::ValueEnum;
use master::cosim::{Extrapolation, JacobianUpdate, Options, Relaxation, Scheme};
use master::simulate::Method;

/// The methods `--scheme` and `--schemes` know, and what each needs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub(crate) enum SchemeName {
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
    /// Ref. [3]: the Stewart wrench on a cabin held at its static pose, fed to the cable model.
    Decoupled,
}

impl SchemeName {
    /// The name as written on the command line.
    pub(crate) fn as_str(self) -> &'static str {
        match self {
            SchemeName::Cable => "cable",
            SchemeName::Monolithic => "monolithic",
            SchemeName::Jacobi => "jacobi",
            SchemeName::GaussSeidel => "gauss-seidel",
            SchemeName::GaussSeidelReversed => "gauss-seidel-reversed",
            SchemeName::Iterative => "iterative",
            SchemeName::Ijcsa => "ijcsa",
            SchemeName::Decoupled => "decoupled",
        }
    }

    /// Whether the scheme iterates within a macro step.
    pub(crate) fn iterates(self) -> bool {
        matches!(self, SchemeName::Iterative | SchemeName::Ijcsa)
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub(crate) enum ExtrapolationArg {
    /// The last outputs.
    Constant,
    /// Extrapolated from the last two (non-iterating schemes pass the slope to the FMUs
    /// through fmi2SetRealInputDerivatives).
    Linear,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub(crate) enum JacobianArg {
    /// Recomputed every step.
    EveryStep,
    /// Quasi-Newton: kept while Newton contracts well.
    Reuse,
}

/// `--relaxation`: `aitken` or a factor in (0, 1].
fn relaxation(text: &str) -> Result<Relaxation, String> {
    if text == "aitken" {
        return Ok(Relaxation::Aitken);
    }
    match text.parse::<f64>() {
        Ok(w) if w > 0.0 && w <= 1.0 => Ok(Relaxation::Fixed(w)),
        _ => Err(format!("`{text}`: give `aitken` or a factor in (0, 1]")),
    }
}

/// A positive finite number.
pub(crate) fn positive(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(x) if x > 0.0 && x.is_finite() => Ok(x),
        Ok(x) => Err(format!("{x} is not a positive finite number")),
        Err(e) => Err(format!("`{text}`: {e}")),
    }
}

/// Options of the coupling schemes.
#[derive(clap::Args, Clone, Debug)]
pub(crate) struct SchemeOptions {
    /// First guess of the end-of-step inputs.
    #[arg(long, value_enum, default_value_t = ExtrapolationArg::Constant)]
    pub(crate) extrapolation: ExtrapolationArg,
    /// Interface tolerance of iterating schemes: every |U − C·Y| ≤ tol · s, with s the largest
    /// start value (at least 1) among the inputs of the same FMU and unit (e.g. the weight for
    /// forces).
    #[arg(long, default_value = "1e-8", value_parser = positive)]
    pub(crate) tol: f64,
    /// Iteration limit per macro step of iterating schemes (exceeding it stops the run).
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    pub(crate) max_iter: u32,
    /// Relaxation of `iterative`: a fixed factor in (0, 1], or `aitken` (dynamic; it stalls on
    /// the LT50m scenes, whose interface couples several modes of both signs).
    #[arg(long, default_value = "0.5", value_parser = relaxation)]
    pub(crate) relaxation: Relaxation,
    /// Interface Jacobian of `ijcsa`.
    #[arg(long, value_enum, default_value_t = JacobianArg::EveryStep)]
    pub(crate) jacobian: JacobianArg,
}

impl SchemeOptions {
    pub(crate) fn method(&self, scheme: SchemeName) -> Method {
        let mut options = Options {
            scheme: Scheme::Jacobi,
            extrapolation: match self.extrapolation {
                ExtrapolationArg::Constant => Extrapolation::Constant,
                ExtrapolationArg::Linear => Extrapolation::Linear,
            },
            relaxation: self.relaxation,
            jacobian: match self.jacobian {
                JacobianArg::EveryStep => JacobianUpdate::EveryStep,
                JacobianArg::Reuse => JacobianUpdate::Reuse,
            },
            tol: self.tol,
            max_iter: self.max_iter as usize,
        };
        options.scheme = match scheme {
            SchemeName::Monolithic => return Method::Monolithic,
            SchemeName::Cable => return Method::CableOnly,
            SchemeName::Decoupled => return Method::Decoupled(options),
            SchemeName::Jacobi => Scheme::Jacobi,
            SchemeName::GaussSeidel => Scheme::GaussSeidel { reversed: false },
            SchemeName::GaussSeidelReversed => Scheme::GaussSeidel { reversed: true },
            SchemeName::Iterative => Scheme::Iterative,
            SchemeName::Ijcsa => Scheme::Ijcsa,
        };
        Method::Cosim(options)
    }
}
