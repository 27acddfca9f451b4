//! Command-line options that choose and tune a method (shared by run, compare, bench).

use master::cosim::step_control::Tolerances;
use master::cosim::{Extrapolation, IqnOptions, JacobianUpdate, Options, Relaxation, Scheme};
use master::simulate::Method;
use master::system::Adaptive;

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
    /// Time windows whose residual history `iqn-ils` reuses (0: this step's only).
    #[arg(long, default_value_t = IqnOptions::default().reuse)]
    pub iqn_reuse: usize,
    /// QR filter limit of `iqn-ils` in [0, 1): a history column keeping less than this
    /// fraction of its norm after orthogonalization against newer ones is deleted.
    #[arg(long, default_value_t = IqnOptions::default().filter)]
    pub iqn_filter: f64,
    /// Relaxation of the first update of `iqn-ils` while there is no history, in (0, 1].
    #[arg(long, default_value_t = IqnOptions::default().initial_relaxation)]
    pub iqn_relaxation: f64,
    /// Adaptive macro step (implicit schemes: iterative, ijcsa, iqn-ils): local error
    /// estimate of the coupled quantities (predictor against corrector), rejected steps rolled
    /// back; --dt is the first step.
    #[arg(long)]
    pub adaptive: bool,
    /// Relative tolerance of the adaptive step: error per step ≤ rtol × how far each coupled
    /// quantity has moved from its initial value.
    #[arg(long, default_value_t = 1e-3)]
    pub rtol: f64,
    /// Absolute tolerance of the adaptive step, as a fraction of each coupled quantity's scale.
    #[arg(long, default_value_t = 1e-6)]
    pub atol: f64,
    /// Smallest step of the adaptive step (s).
    #[arg(long, default_value_t = 1e-5)]
    pub h_min: f64,
    /// Largest step of the adaptive step (s).
    #[arg(long, default_value_t = 0.1)]
    pub h_max: f64,
}

/// The methods `master run --scheme` knows, with what each needs from the FMUs.
pub const SCHEMES: &str = "cable (the cable–cabin model alone with the platform locked, under the scene's \
    [disturbance]; in-process), monolithic (eq. 7, no FMUs), jacobi, gauss-seidel (cable first), \
    gauss-seidel-reversed (Stewart first), iterative (needs get/set FMU state), \
    ijcsa (needs get/set FMU state; directional derivatives, else finite differences), \
    iqn-ils (interface quasi-Newton, least squares on the residual history; needs get/set FMU state), \
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
            iqn: IqnOptions { reuse: self.iqn_reuse, filter: self.iqn_filter, initial_relaxation: self.iqn_relaxation },
        };
        if !(0.0..1.0).contains(&self.iqn_filter) {
            return Err(format!("--iqn-filter {}: give a limit in [0, 1)", self.iqn_filter));
        }
        if !(self.iqn_relaxation > 0.0 && self.iqn_relaxation <= 1.0) {
            return Err(format!("--iqn-relaxation {}: give a factor in (0, 1]", self.iqn_relaxation));
        }
        if self.adaptive && !matches!(scheme, "iterative" | "ijcsa" | "iqn-ils") {
            self.adaptive_settings(scheme)?;
        }
        options.scheme = match scheme {
            "monolithic" => return Ok(Method::Monolithic),
            "cable" => return Ok(Method::CableOnly),
            "decoupled" => return Ok(Method::Decoupled(options)),
            "jacobi" => Scheme::Jacobi,
            "gauss-seidel" => Scheme::GaussSeidel { reversed: false },
            "gauss-seidel-reversed" => Scheme::GaussSeidel { reversed: true },
            "iterative" => Scheme::Iterative,
            "ijcsa" => Scheme::Ijcsa,
            "iqn-ils" => Scheme::IqnIls,
            other => return Err(format!("unknown scheme `{other}`; known: {SCHEMES}")),
        };
        if self.adaptive {
            return Ok(Method::CosimAdaptive(options, self.adaptive_settings(scheme)?));
        }
        Ok(Method::Cosim(options))
    }

    /// The same options at a fixed step (e.g. for a reference run).
    pub fn fixed_step(&self) -> SchemeOptions {
        SchemeOptions { adaptive: false, ..self.clone() }
    }

    /// The adaptive step's settings, checked; `scheme` must iterate.
    pub fn adaptive_settings(&self, scheme: &str) -> Result<Adaptive, String> {
        if !matches!(scheme, "iterative" | "ijcsa" | "iqn-ils") {
            return Err(format!(
                "--adaptive needs an implicit scheme (iterative, ijcsa, iqn-ils); `{scheme}` has no adaptive step"
            ));
        }
        if !(self.rtol > 0.0 && self.rtol < 1.0) {
            return Err(format!("--rtol {}: give a tolerance in (0, 1)", self.rtol));
        }
        if !(self.atol > 0.0) {
            return Err(format!("--atol {}: must be positive", self.atol));
        }
        if !(self.h_min > 0.0 && self.h_max >= self.h_min && self.h_max.is_finite()) {
            return Err(format!("--h-min {} and --h-max {}: need 0 < h-min ≤ h-max", self.h_min, self.h_max));
        }
        Ok(Adaptive {
            tolerances: Tolerances { rtol: self.rtol, atol: self.atol },
            h_min: self.h_min,
            h_max: self.h_max,
        })
    }
}
