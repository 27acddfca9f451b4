//! The generalized-α integrator and its Newton controller on a one-degree-of-freedom oscillator
//! `m ẍ + c ẋ + k x = 0`, whose exact motion and energy are known.

use feedcore::genalpha::{
    Failure, Integrator, Iterate, IterationMatrix, Newton, OptionsError, Problem, Quantity, State, StepError, Workspace,
};

/// The oscillator, with switches that break it on purpose.
struct Oscillator {
    m: f64,
    c: f64,
    k: f64,
    time: f64,
    factor: Option<(f64, f64)>,
    /// The residual turns NaN after this time.
    nan_after: f64,
    /// Steps longer than this get an iteration matrix with the wrong sign of the stiffness
    /// (Newton diverges; halves of the step are fine).
    wrong_matrix_above: f64,
    /// What `constraint_violation` reports.
    violation: f64,
}

impl Oscillator {
    fn new(m: f64, c: f64, k: f64) -> Oscillator {
        Oscillator {
            m,
            c,
            k,
            time: 0.0,
            factor: None,
            nan_after: f64::INFINITY,
            wrong_matrix_above: f64::INFINITY,
            violation: 0.0,
        }
    }

    /// At rest at x0 (the acceleration follows from the equation of motion).
    fn start(&self, x0: f64) -> State<f64> {
        State::new(0.0, x0, vec![0.0], vec![-self.k * x0 / self.m], Vec::new())
    }
}

impl Problem for Oscillator {
    type Config = f64;
    type Input = ();
    type Error = std::convert::Infallible;

    fn place(&self, base: &f64, increment: &[f64], trial: &mut f64) {
        *trial = base + increment[0];
    }

    fn begin_step(&mut self, time: f64, _: &()) -> Result<(), Self::Error> {
        self.time = time;
        Ok(())
    }

    fn residual(&mut self, at: &Iterate<'_, f64>, _: f64, residual: &mut [f64]) {
        let broken = if self.time > self.nan_after { f64::NAN } else { 0.0 };
        residual[0] = self.m * at.acceleration[0] + self.c * at.velocity[0] + self.k * at.config + broken;
    }

    fn factorize(
        &mut self,
        at: &Iterate<'_, f64>,
        s: &IterationMatrix,
        residual: &mut [f64],
    ) -> Result<(), Self::Error> {
        self.residual(at, s.constraint_scale, residual);
        let k = if s.step > self.wrong_matrix_above { -3.0 * self.k } else { self.k };
        self.factor = Some((s.mass * self.m + s.damping * self.c + k, s.step));
        Ok(())
    }

    fn factorized_step(&self) -> Option<f64> {
        self.factor.map(|f| f.1)
    }

    fn solve(&mut self, rhs: &mut [f64]) {
        rhs[0] /= self.factor.expect("factorized").0;
    }

    fn unknown_name(&self, index: usize) -> String {
        format!("the oscillator's coordinate {index}")
    }

    fn constraint_violation(&mut self, _: &f64) -> f64 {
        self.violation
    }
}

fn integrator(rho_inf: f64, tol: f64) -> Integrator {
    Integrator::new(rho_inf, Newton::new(tol, 20, 1.0).unwrap()).unwrap()
}

fn run(
    p: &mut Oscillator,
    integrator: &Integrator,
    h: f64,
    steps: usize,
) -> Result<(State<f64>, Vec<f64>), Failure<std::convert::Infallible>> {
    let mut state = p.start(1.0);
    let mut work = Workspace::new(&state);
    let mut path = Vec::with_capacity(steps);
    for _ in 0..steps {
        integrator.step(p, &mut state, &mut work, h, &(), &())?;
        path.push(state.config);
    }
    Ok((state, path))
}

/// ρ∞ = 1 is the trapezoidal rule, which keeps the energy of a linear undamped oscillator.
#[test]
fn trapezoidal_rule_keeps_the_energy() {
    let mut p = Oscillator::new(2.0, 0.0, 50.0);
    let (state, _) = run(&mut p, &integrator(1.0, 1e-13), 0.05, 2000).unwrap();
    let energy = 0.5 * p.m * state.velocity[0].powi(2) + 0.5 * p.k * state.config.powi(2);
    let e0 = 0.5 * p.k;
    eprintln!("energy after 2000 steps: {energy:.15} (start {e0})");
    assert!((energy - e0).abs() <= 1e-10 * e0);
}

/// Second order: halving the step quarters the error against the exact damped motion.
#[test]
fn second_order_against_the_exact_motion() {
    let (m, c, k): (f64, f64, f64) = (1.0, 0.4, 25.0);
    let wd = (k / m - (c / (2.0 * m)).powi(2)).sqrt();
    let zeta_w = c / (2.0 * m);
    let exact = |t: f64| (-zeta_w * t).exp() * ((wd * t).cos() + zeta_w / wd * (wd * t).sin());
    let errors: Vec<f64> = [0.02, 0.01, 0.005]
        .iter()
        .map(|h| {
            let steps = (2.0 / h) as usize;
            let (_, path) = run(&mut Oscillator::new(m, c, k), &integrator(0.9, 1e-14), *h, steps).unwrap();
            path.iter().enumerate().map(|(i, x)| (x - exact((i + 1) as f64 * h)).abs()).fold(0.0, f64::max)
        })
        .collect();
    eprintln!("errors at h = 0.02, 0.01, 0.005: {errors:?}");
    for w in errors.windows(2) {
        let ratio = w[0] / w[1];
        assert!((3.5..4.5).contains(&ratio), "error ratio {ratio}");
    }
}

/// A residual that turns NaN stops the run at that step, naming the quantity and the unknown.
#[test]
fn a_non_finite_residual_stops_with_time_and_quantity() {
    let mut p = Oscillator::new(1.0, 0.0, 10.0);
    p.nan_after = 0.5;
    let e = run(&mut p, &integrator(0.9, 1e-12), 0.1, 20).unwrap_err();
    assert!((e.time - 0.6).abs() < 1e-12, "stopped at {}", e.time);
    match &e.reason {
        StepError::NotFinite { quantity, unknown, value } => {
            assert_eq!(*quantity, Quantity::Residual);
            assert_eq!(unknown, "the oscillator's coordinate 0");
            assert!(value.is_nan());
        }
        other => panic!("expected a non-finite residual, got {other:?}"),
    }
    assert!(e.to_string().contains("at t = 0.600000 s: the residual of the oscillator's coordinate 0 is NaN"), "{e}");
}

/// A step whose Newton iteration diverges is retaken in halves, which converge.
#[test]
fn a_failing_step_is_retaken_in_halves() {
    let mut p = Oscillator::new(1.0, 0.0, 10.0);
    p.wrong_matrix_above = 0.3;
    let (state, _) = run(&mut p, &integrator(0.9, 1e-12), 1.0, 1).unwrap();
    assert!((state.time - 1.0).abs() < 1e-15, "reached {}", state.time);
    // the same step taken as four quarters from the start lands on the same solution
    let mut q = Oscillator::new(1.0, 0.0, 10.0);
    let (quarters, _) = run(&mut q, &integrator(0.9, 1e-12), 0.25, 4).unwrap();
    assert!((state.config - quarters.config).abs() < 1e-10, "{} against {}", state.config, quarters.config);
}

/// A converged step whose constraints are violated beyond 100 tolerances is refused (after its
/// halves fail too).
#[test]
fn constraint_residual_above_the_bound_stops_the_run() {
    let mut p = Oscillator::new(1.0, 0.0, 10.0);
    p.violation = 1e-6;
    let e = run(&mut p, &integrator(0.9, 1e-10), 0.01, 3).unwrap_err();
    assert!(matches!(e.reason, StepError::ConstraintResidual { residual, bound } if residual == 1e-6 && bound == 1e-8));
    p.violation = 0.5e-8;
    assert!(run(&mut p, &integrator(0.9, 1e-10), 0.01, 3).is_ok());
}

/// Tolerances that cannot work are refused up front, with the value and the bound.
#[test]
fn unusable_options_are_refused() {
    assert!(matches!(Newton::new(f64::NAN, 10, 1.0), Err(OptionsError::Tolerance(x)) if x.is_nan()));
    assert!(matches!(Newton::new(0.0, 10, 1.0), Err(OptionsError::Tolerance(_))));
    assert!(matches!(Newton::new(-1e-10, 10, 1.0), Err(OptionsError::Tolerance(_))));
    for loose in [1e300, 0.1, 3e-5] {
        match Newton::new(loose, 10, 2.0) {
            Err(e @ OptionsError::ToleranceTooLoose { .. }) => {
                let text = e.to_string();
                assert!(text.contains(&format!("{loose:e}")) && text.contains("2.0e-5"), "{text}");
            }
            other => panic!("{loose}: expected a refusal, got {other:?}"),
        }
    }
    assert!(Newton::new(2e-5, 10, 2.0).is_ok());
    assert!(matches!(Newton::new(1e-10, 0, 1.0), Err(OptionsError::Iterations(0))));
    assert!(matches!(Integrator::new(1.5, Newton::new(1e-10, 5, 1.0).unwrap()), Err(OptionsError::SpectralRadius(_))));
    // a step of no length is refused with its value
    let mut p = Oscillator::new(1.0, 0.0, 1.0);
    let mut state = p.start(1.0);
    let mut work = Workspace::new(&state);
    let e = integrator(0.9, 1e-10).step(&mut p, &mut state, &mut work, 0.0, &(), &()).unwrap_err();
    assert!(matches!(e.reason, StepError::StepSize(h) if h == 0.0));
}
