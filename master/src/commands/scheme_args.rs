//! Command-line options that choose and tune a method (shared by run, compare, bench).

use master::cosim::{Extrapolation, JacobianUpdate, Options, Relaxation, Scheme};
use master::simulate::Method;

/// Options of the coupling schemes.
#[derive(clap::Args, Clone, Debug)]
pub struct SchemeOptions {
    /// First guess of the end-of-step inputs: `constant` (the last outputs) or `linear`
    /// (extrapolated from the last two; non-iterating schemes pass the slope to the FMUs
    /// through fmi2SetRealInputDerivatives).
    #[arg(long, default_value = "constant", value_parser = ["constant", "linear"])]
    pub extrapolation: String,
    /// Interface tolerance of iterating schemes: every |U − C·Y| ≤ tol · s, with s the largest
    /// start value (at least 1) among the inputs of the same FMU and unit (e.g. the weight for
    /// forces).
    #[arg(long, default_value_t = 1e-8)]
    pub tol: f64,
    /// Iteration limit per macro step of iterating schemes (exceeding it stops the run).
    #[arg(long, default_value_t = 100)]
    pub max_iter: usize,
    /// Relaxation of `iterative`: a fixed factor in (0, 1], or `aitken` (dynamic; it stalls on
    /// the LT50m scenes, whose interface couples several modes of both signs).
    #[arg(long, default_value = "0.5")]
    pub relaxation: String,
    /// Interface Jacobian of `ijcsa`: `every-step` (recomputed each step) or `reuse`
    /// (quasi-Newton: kept while Newton contracts well).
    #[arg(long, default_value = "every-step", value_parser = ["every-step", "reuse"])]
    pub jacobian: String,
}

/// The methods `master run --scheme` knows, with what each needs from the FMUs.
pub const SCHEMES: &str = "cable (the cable–cabin model alone with the platform locked, under the scene's \
    [disturbance]; in-process), monolithic (eq. 7, no FMUs), jacobi, gauss-seidel (cable first), \
    gauss-seidel-reversed (Stewart first), iterative (needs get/set FMU state), \
    ijcsa (needs get/set FMU state; directional derivatives, else finite differences), \
    decoupled (ref. [3]: the Stewart wrench on a fixed cabin fed to the cable model)";

impl SchemeOptions {
    pub fn method(&self, scheme: &str) -> Result<Method, String> {
        let relaxation = match self.relaxation.as_str() {
            "aitken" => Relaxation::Aitken,
            x => match x.parse::<f64>() {
                Ok(w) if w > 0.0 && w <= 1.0 => Relaxation::Fixed(w),
                _ => return Err(format!("--relaxation {x}: give `aitken` or a factor in (0, 1]")),
            },
        };
        if !(self.tol > 0.0) {
            return Err(format!("--tol {}: must be positive", self.tol));
        }
        if self.max_iter < 1 {
            return Err("--max-iter must be at least 1".into());
        }
        let mut options = Options {
            scheme: Scheme::Jacobi,
            extrapolation: if self.extrapolation == "linear" { Extrapolation::Linear } else { Extrapolation::Constant },
            relaxation,
            jacobian: if self.jacobian == "reuse" { JacobianUpdate::Reuse } else { JacobianUpdate::EveryStep },
            tol: self.tol,
            max_iter: self.max_iter,
        };
        options.scheme = match scheme {
            "monolithic" => return Ok(Method::Monolithic),
            "cable" => return Ok(Method::CableOnly),
            "decoupled" => return Ok(Method::Decoupled(options)),
            "jacobi" => Scheme::Jacobi,
            "gauss-seidel" => Scheme::GaussSeidel { reversed: false },
            "gauss-seidel-reversed" => Scheme::GaussSeidel { reversed: true },
            "iterative" => Scheme::Iterative,
            "ijcsa" => Scheme::Ijcsa,
            other => return Err(format!("unknown scheme `{other}`; known: {SCHEMES}")),
        };
        Ok(Method::Cosim(options))
    }
}
