//! The schemes on an in-process linear coupled system with a known solution: two masses on
//! springs to the ground, joined by a spring; unit A is mass 1 (input: the coupling force, outputs
//! x₁, v₁), unit B is mass 2 and the coupling spring (input: x₁, outputs: the force on mass 1 —
//! direct feedthrough of x₁ — and x₂). Each unit integrates its step with the trapezoidal rule,
//! its input interpolated linearly from the start to the end value, so that the converged
//! co-simulation is the trapezoidal rule of the whole system; its exact solution is a sum of
//! the two normal modes.

use cosim::error_estimate::Kind;
use cosim::step_control::{Controller, Limits, Tolerances};
use cosim::{
    Capabilities, Coupled, Extrapolation, IqnOptions, JacobianUpdate, Layout, Options, Scheme, Slot, StepError,
    UnitError, UnitLayout, Units,
};

const M: f64 = 1.0;
const K: f64 = 40.0;
const KC: f64 = 120.0;
const X1: f64 = 0.1; // initial displacement of mass 1; everything else starts at rest

/// (x, v, input at the start of the step) of one mass.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Mass {
    x: f64,
    v: f64,
    u0: f64,
    u1: f64,
}

struct TwoMasses {
    layout: Layout,
    now: [Mass; 2],
    /// Per rollback slot, the saved state of each unit.
    saved: [[Mass; 2]; 2],
    /// Unit A ends the run at this time (fmi2Discard), if set.
    end_at: Option<f64>,
    steps: usize,
}

impl TwoMasses {
    fn new() -> TwoMasses {
        let layout = Layout {
            units: vec![
                UnitLayout { name: "a".into(), inputs: 0..1, outputs: 0..2 },
                UnitLayout { name: "b".into(), inputs: 1..2, outputs: 2..4 },
            ],
            // U = [force on 1 (from b's output 0), x1 (from a's output 0)]
            source: vec![2, 0],
            gain: vec![1.0, 1.0],
            offset: vec![0.0, 0.0],
            scale: vec![1.0, 1.0],
            group: vec![0, 1],
            input_names: vec!["a.force".into(), "b.x1".into()],
            output_names: vec!["a.x".into(), "a.v".into(), "b.force".into(), "b.x".into()],
            // b's force responds at once to x1; a's outputs are states
            feedthrough: vec![(2, 1)],
        };
        let a = Mass { x: X1, v: 0.0, u0: -KC * X1, u1: -KC * X1 };
        let b = Mass { x: 0.0, v: 0.0, u0: X1, u1: X1 };
        TwoMasses { layout, now: [a, b], saved: [[a, b]; 2], end_at: None, steps: 0 }
    }

    /// Force on mass k from its own springs and its input.
    fn force(k: usize, x: f64, u: f64) -> f64 {
        if k == 0 { -K * x + u } else { -K * x - KC * (x - u) }
    }
}

impl Units for TwoMasses {
    fn layout(&self) -> &Layout {
        &self.layout
    }

    fn capabilities(&self, _k: usize) -> Capabilities {
        Capabilities { rollback: true, step_derivatives: false, interpolates: false }
    }

    fn set_inputs(&mut self, k: usize, u: &[f64]) -> Result<(), UnitError> {
        self.now[k].u1 = u[0];
        Ok(())
    }

    fn set_input_slopes(&mut self, _k: usize, _s: &[f64]) -> Result<(), UnitError> {
        Err(UnitError::Other("no input slopes".into()))
    }

    fn do_step(&mut self, k: usize, t: f64, h: f64) -> Result<(), UnitError> {
        if k == 0
            && let Some(end) = self.end_at
            && t + h > end + 1e-12
        {
            return Err(UnitError::Ended {
                last_successful_time: Some(t),
                terminated: true,
                signal: "fmi2Discard, fmi2Terminated",
            });
        }
        self.steps += 1;
        // trapezoidal rule: x⁺ = x + h/2 (v + v⁺), v⁺ = v + h/2 (f(x, u0) + f(x⁺, u1)) / m
        let s = self.now[k];
        let c = if k == 0 { K } else { K + KC };
        let f0 = Self::force(k, s.x, s.u0);
        let ext = if k == 0 { s.u1 } else { KC * s.u1 };
        // v⁺ = v + h/(2m) (f0 − c x⁺ + ext), x⁺ = x + h/2 (v + v⁺)
        let a = h * h / (4.0 * M) * c;
        let x1 = (s.x + h * s.v + h * h / (4.0 * M) * (f0 + ext)) / (1.0 + a);
        let v1 = s.v + h / (2.0 * M) * (f0 - c * x1 + ext);
        self.now[k] = Mass { x: x1, v: v1, u0: s.u1, u1: s.u1 };
        Ok(())
    }

    fn get_outputs(&mut self, k: usize, y: &mut [f64]) -> Result<(), UnitError> {
        let s = self.now[k];
        if k == 0 {
            y[0] = s.x;
            y[1] = s.v;
        } else {
            y[0] = KC * (s.x - s.u1); // force on mass 1: feedthrough of x₁
            y[1] = s.x;
        }
        Ok(())
    }

    fn save_state(&mut self, k: usize, slot: Slot) -> Result<(), UnitError> {
        self.saved[slot as usize][k] = self.now[k];
        Ok(())
    }

    fn restore_state(&mut self, k: usize, slot: Slot) -> Result<(), UnitError> {
        self.now[k] = self.saved[slot as usize][k];
        Ok(())
    }

    fn step_derivative(&mut self, _k: usize, _seed: &[f64], _out: &mut [f64]) -> Result<(), UnitError> {
        Err(UnitError::Other("no derivatives".into()))
    }
}

/// x₁(t), x₂(t) exactly: the in-phase mode ω² = K/M and the opposite mode ω² = (K + 2 KC)/M.
fn exact(t: f64) -> [f64; 2] {
    let (w1, w2) = ((K / M).sqrt(), ((K + 2.0 * KC) / M).sqrt());
    let (a, b) = (0.5 * X1 * (w1 * t).cos(), 0.5 * X1 * (w2 * t).cos());
    [a + b, a - b]
}

fn options(scheme: Scheme) -> Options {
    Options { scheme, tol: 1e-12, max_iter: 50, ..Options::default() }
}

/// The trapezoidal rule of the whole system, written out (the reference of the converged schemes).
fn monolithic(h: f64, steps: usize) -> [f64; 2] {
    let (mut x, mut v) = ([X1, 0.0], [0.0, 0.0]);
    let acc = |x: [f64; 2]| [(-K * x[0] + KC * (x[1] - x[0])) / M, (-K * x[1] - KC * (x[1] - x[0])) / M];
    for _ in 0..steps {
        // solve the 4×4 trapezoidal system by fixed-point iteration to round-off (h small)
        let (mut xn, mut vn) = (x, v);
        for _ in 0..200 {
            let (a0, a1) = (acc(x), acc(xn));
            let vn2 = [v[0] + h / 2.0 * (a0[0] + a1[0]), v[1] + h / 2.0 * (a0[1] + a1[1])];
            let xn2 = [x[0] + h / 2.0 * (v[0] + vn2[0]), x[1] + h / 2.0 * (v[1] + vn2[1])];
            (xn, vn) = (xn2, vn2);
        }
        (x, v) = (xn, vn);
    }
    x
}

/// Every implicit scheme converges to the trapezoidal rule of the whole system.
#[test]
fn implicit_schemes_reach_the_monolithic_trapezoidal_rule() {
    let (h, steps) = (0.01, 300);
    let reference = monolithic(h, steps);
    for scheme in [Scheme::IqnIls, Scheme::Ijcsa, Scheme::Iterative] {
        let mut o = options(scheme);
        o.iqn = IqnOptions { reuse: 0, ..IqnOptions::default() };
        let mut c = Coupled::new(TwoMasses::new(), o).unwrap();
        let mut worst = 0;
        for _ in 0..steps {
            worst = worst.max(c.step(h).unwrap().iterations);
        }
        let y = c.outputs();
        let (x1, x2) = (y[0], y[3]);
        eprintln!("{}: x = ({x1:.9}, {x2:.9}), reference {reference:?}, at most {worst} evaluations", scheme.name());
        assert!((x1 - reference[0]).abs() < 1e-10 && (x2 - reference[1]).abs() < 1e-10, "{}", scheme.name());
    }
    // IJCSA with its Jacobian reused (a linear, time-invariant step map: the first one stays
    // exact, and a secant update keeps it so): the same answer, one Newton update per step
    let mut o = options(Scheme::Ijcsa);
    (o.jacobian, o.extrapolation) = (JacobianUpdate::Reuse, Extrapolation::Linear);
    let mut c = Coupled::new(TwoMasses::new(), o).unwrap();
    let iterations: Vec<usize> = (0..steps).map(|_| c.step(h).unwrap().iterations).collect();
    let (x1, x2) = (c.outputs()[0], c.outputs()[3]);
    eprintln!("ijcsa, reused Jacobian: x = ({x1:.9}, {x2:.9}), at most {:?} evaluations", iterations.iter().max());
    assert!((x1 - reference[0]).abs() < 1e-10 && (x2 - reference[1]).abs() < 1e-10);
    assert!(iterations.iter().all(|&n| n <= 2), "{iterations:?}");
    // with reuse of past windows the secants of the last steps already span the interface
    let mut c = Coupled::new(TwoMasses::new(), options(Scheme::IqnIls)).unwrap();
    let total: usize = (0..steps).map(|_| c.step(h).unwrap().iterations).sum();
    let mean = total as f64 / steps as f64;
    eprintln!("iqn-ils with reuse: {mean:.2} evaluations per step");
    assert!(mean < 3.0);
}

/// The adaptive step on the known solution: the error of each coupled quantity (x₁, and the
/// spring force on mass 1) against the exact solution stays within the tolerance relative to how
/// far the quantity moves from its initial value (what the relative tolerance refers to), at
/// each of several tolerances; tightening the tolerance takes more steps.
#[test]
fn adaptive_run_meets_its_tolerance_against_the_exact_solution() {
    let t_end = 5.0;
    // how far each mass moves from where it starts, over the run
    let coupled = |t: f64| {
        let e = exact(t);
        [e[0], KC * (e[1] - e[0])]
    };
    let e0 = coupled(0.0);
    let range = (0..=50_000)
        .map(|k| coupled(k as f64 * t_end / 50_000.0))
        .fold([0.0f64; 2], |m, e| [m[0].max((e[0] - e0[0]).abs()), m[1].max((e[1] - e0[1]).abs())]);
    let mut last_steps = 0;
    for rtol in [1e-2, 1e-3, 1e-4] {
        let mut c = Coupled::new(TwoMasses::new(), options(Scheme::IqnIls)).unwrap();
        let mut ctl = Controller::new(Limits { h_min: 1e-7, h_max: 0.1, h_init: 1e-4 }).unwrap();
        let tol = Tolerances { rtol, atol: 1e-3 * rtol };
        let (mut worst, mut steps) = ([0.0f64; 2], 0);
        while c.time() < t_end {
            c.step_adaptive(&mut ctl, tol, t_end).unwrap();
            steps += 1;
            let e = coupled(c.time());
            let y = c.outputs();
            worst = [worst[0].max((y[0] - e[0]).abs()), worst[1].max((y[2] - e[1]).abs())];
        }
        assert!((c.time() - t_end).abs() < 1e-12, "ends at t_end");
        let rel = [worst[0] / range[0], worst[1] / range[1]];
        eprintln!(
            "rtol {rtol:e}: {steps} steps ({} rejected), h {:.2e} … {:.2e}, errors {:.2e}, {:.2e} of the ranges",
            ctl.rejected, ctl.h_min_used, ctl.h_max_used, rel[0], rel[1]
        );
        assert!(rel[0] <= rtol && rel[1] <= rtol, "rtol {rtol}: relative errors {rel:?}");
        assert!(steps > last_steps);
        last_steps = steps;
    }
}

/// A rejected adaptive step and `undo_step` restore the units and the coupled values exactly.
#[test]
fn undo_restores_everything() {
    let mut c = Coupled::new(TwoMasses::new(), options(Scheme::IqnIls)).unwrap();
    for _ in 0..10 {
        c.step(0.01).unwrap();
    }
    let (before, y, t) = (c.units().now, c.outputs().to_vec(), c.time());
    c.step(0.05).unwrap();
    assert_ne!(c.units().now, before);
    c.undo_step().unwrap();
    assert_eq!(c.units().now, before);
    assert_eq!(c.outputs(), &y[..]);
    assert_eq!(c.time(), t);
    // the same step again gives the same result, bit for bit
    c.step(0.05).unwrap();
    let first = c.outputs().to_vec();
    c.undo_step().unwrap();
    c.step(0.05).unwrap();
    assert_eq!(c.outputs(), &first[..]);
}

/// A unit that ends the run (fmi2Discard) stops it at the last communication point, as an end
/// and not a failure.
#[test]
fn a_unit_ending_the_run_stops_it_at_the_last_communication_point() {
    for scheme in [Scheme::Jacobi, Scheme::IqnIls] {
        let mut units = TwoMasses::new();
        units.end_at = Some(0.25);
        let mut c = Coupled::new(units, options(scheme)).unwrap();
        let e = loop {
            if let Err(e) = c.step(0.1) {
                break e;
            }
        };
        let (unit, why) = e.ended().expect("an end, not a failure");
        assert_eq!(unit, "a");
        assert!((c.time() - 0.2).abs() < 1e-12 && (e.time() - 0.2).abs() < 1e-12, "{e}");
        assert!(why.to_string().contains("fmi2Terminated"), "{why}");
        assert!(matches!(e, StepError::Unit { .. }));
    }
}

/// Two units whose step maps are linear and static: `Y_k = M_k U_k + c_k` (random, a loop gain
/// beyond one, so that the plain fixed point diverges).
struct LinearMaps {
    layout: Layout,
    m: [Vec<f64>; 2],
    c: [Vec<f64>; 2],
    u: [Vec<f64>; 2],
}

impl LinearMaps {
    /// Unit 0 has `n0` inputs and outputs, unit 1 `n1`; every output of one feeds the other.
    fn new(n0: usize, n1: usize, seed: u64) -> LinearMaps {
        let mut s = seed;
        let mut rnd = move || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((s >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        let n = n0 + n1;
        let layout = Layout {
            units: vec![
                UnitLayout { name: "p".into(), inputs: 0..n0, outputs: 0..n1 },
                UnitLayout { name: "q".into(), inputs: n0..n, outputs: n1..n },
            ],
            // p's inputs come from q's outputs, q's from p's
            source: (0..n0).map(|i| n1 + i).chain(0..n1).collect(),
            gain: vec![1.0; n],
            offset: vec![0.0; n],
            scale: vec![1.0; n],
            group: (0..n).collect(),
            input_names: (0..n).map(|i| format!("u{i}")).collect(),
            output_names: (0..n).map(|i| format!("y{i}")).collect(),
            // outputs are maps of the inputs held now: every output of a unit on every input
            feedthrough: (0..n1)
                .flat_map(|y| (0..n0).map(move |u| (y, u)))
                .chain((n1..n).flat_map(|y| (n0..n).map(move |u| (y, u))))
                .collect(),
        };
        // p: n1 outputs from n0 inputs; q: n0 outputs from n1 inputs
        let m0: Vec<f64> = (0..n1 * n0).map(|_| 3.0 * rnd()).collect();
        let m1: Vec<f64> = (0..n0 * n1).map(|_| 3.0 * rnd()).collect();
        let c0: Vec<f64> = (0..n1).map(|_| rnd()).collect();
        let c1: Vec<f64> = (0..n0).map(|_| rnd()).collect();
        LinearMaps { layout, m: [m0, m1], c: [c0, c1], u: [vec![0.0; n0], vec![0.0; n1]] }
    }
}

impl Units for LinearMaps {
    fn layout(&self) -> &Layout {
        &self.layout
    }
    fn capabilities(&self, _k: usize) -> Capabilities {
        Capabilities { rollback: true, step_derivatives: false, interpolates: false }
    }
    fn set_inputs(&mut self, k: usize, u: &[f64]) -> Result<(), UnitError> {
        self.u[k].copy_from_slice(u);
        Ok(())
    }
    fn set_input_slopes(&mut self, _k: usize, _s: &[f64]) -> Result<(), UnitError> {
        Ok(())
    }
    fn do_step(&mut self, _k: usize, _t: f64, _h: f64) -> Result<(), UnitError> {
        Ok(())
    }
    fn get_outputs(&mut self, k: usize, y: &mut [f64]) -> Result<(), UnitError> {
        let ni = self.u[k].len();
        for (r, out) in y.iter_mut().enumerate() {
            *out = self.c[k][r] + (0..ni).map(|j| self.m[k][r * ni + j] * self.u[k][j]).sum::<f64>();
        }
        Ok(())
    }
    fn save_state(&mut self, _k: usize, _slot: Slot) -> Result<(), UnitError> {
        Ok(())
    }
    fn restore_state(&mut self, _k: usize, _slot: Slot) -> Result<(), UnitError> {
        Ok(())
    }
    fn step_derivative(&mut self, _k: usize, _seed: &[f64], _out: &mut [f64]) -> Result<(), UnitError> {
        Err(UnitError::Other("no derivatives".into()))
    }
}

/// On a linear coupled system of n interface unknowns IQN-ILS (no reuse) converges within n + 1
/// updates — n + 2 evaluations, the first of the initial guess — whatever the coupling; the
/// fixed-point iteration does not converge at all on the same systems.
#[test]
fn iqn_ils_converges_within_n_plus_1_updates_on_a_linear_coupled_system() {
    for (n0, n1, seed) in [(1, 1, 5), (2, 3, 2), (4, 4, 3), (6, 3, 4)] {
        let n = n0 + n1;
        let mut o = options(Scheme::IqnIls);
        o.tol = 1e-9;
        o.iqn = IqnOptions { reuse: 0, ..IqnOptions::default() };
        let mut c = Coupled::new(LinearMaps::new(n0, n1, seed), o).unwrap();
        let evaluations = c.step(0.1).unwrap().iterations;
        eprintln!("n = {n}: {evaluations} evaluations");
        assert!(evaluations <= n + 2, "n = {n}: {evaluations} evaluations");
        let mut plain = options(Scheme::Iterative);
        plain.relaxation = cosim::Relaxation::Fixed(1.0);
        let e = Coupled::new(LinearMaps::new(n0, n1, seed), plain).unwrap().step(0.1);
        assert!(matches!(e, Err(StepError::NotConverged { .. })), "n = {n}: the fixed point converged");
    }
}

/// A loop through direct feedthrough is refused to the schemes that do not iterate, naming it;
/// the iterating schemes solve it. The two masses (only b's force feeds through) are no loop.
#[test]
fn non_iterating_schemes_refuse_an_algebraic_loop() {
    for scheme in [Scheme::Jacobi, Scheme::GaussSeidel { reversed: false }, Scheme::Sequential] {
        let e = Coupled::new(LinearMaps::new(2, 1, 7), options(scheme)).err().expect("refused");
        let text = e.to_string();
        assert!(matches!(e, StepError::AlgebraicLoop { .. }), "{text}");
        assert!(text.contains(&format!("scheme {} cannot solve", scheme.name())), "{text}");
        assert!(text.contains("`u0` → `y0` → `u2` → `y1` → `u0`"), "{text}");
        assert!(text.contains("use ijcsa, iqn-ils or iterative"), "{text}");
    }
    for scheme in [Scheme::IqnIls, Scheme::Ijcsa] {
        let mut c = Coupled::new(LinearMaps::new(2, 1, 7), options(scheme)).unwrap();
        assert!(c.step(0.1).unwrap().residual <= 1e-10);
    }
    assert!(Coupled::new(TwoMasses::new(), options(Scheme::Jacobi)).is_ok());
}

/// A clock and an echo: the clock's output is its time, the echo's the input it holds (direct
/// feedthrough), each feeding the other. The coupled values are linear in time.
struct ClockAndEcho {
    layout: Layout,
    time: [f64; 2],
    saved: [[f64; 2]; 2],
    echo: f64,
}

impl ClockAndEcho {
    fn new() -> ClockAndEcho {
        let layout = Layout {
            units: vec![
                UnitLayout { name: "clock".into(), inputs: 0..1, outputs: 0..1 },
                UnitLayout { name: "echo".into(), inputs: 1..2, outputs: 1..2 },
            ],
            source: vec![1, 0],
            gain: vec![1.0, 1.0],
            offset: vec![0.0, 0.0],
            scale: vec![1.0, 1.0],
            group: vec![0, 1],
            input_names: vec!["clock.u".into(), "echo.u".into()],
            output_names: vec!["clock.t".into(), "echo.y".into()],
            feedthrough: vec![(1, 1)],
        };
        ClockAndEcho { layout, time: [0.0; 2], saved: [[0.0; 2]; 2], echo: 0.0 }
    }
}

impl Units for ClockAndEcho {
    fn layout(&self) -> &Layout {
        &self.layout
    }

    fn capabilities(&self, _k: usize) -> Capabilities {
        Capabilities { rollback: true, step_derivatives: false, interpolates: false }
    }

    fn set_inputs(&mut self, k: usize, u: &[f64]) -> Result<(), UnitError> {
        if k == 1 {
            self.echo = u[0];
        }
        Ok(())
    }

    fn set_input_slopes(&mut self, _k: usize, _s: &[f64]) -> Result<(), UnitError> {
        Err(UnitError::Other("no input slopes".into()))
    }

    fn do_step(&mut self, k: usize, t: f64, h: f64) -> Result<(), UnitError> {
        self.time[k] = t + h;
        Ok(())
    }

    fn get_outputs(&mut self, k: usize, y: &mut [f64]) -> Result<(), UnitError> {
        y[0] = if k == 0 { self.time[0] } else { self.echo };
        Ok(())
    }

    fn save_state(&mut self, k: usize, slot: Slot) -> Result<(), UnitError> {
        self.saved[slot as usize][k] = self.time[k];
        Ok(())
    }

    fn restore_state(&mut self, k: usize, slot: Slot) -> Result<(), UnitError> {
        self.time[k] = self.saved[slot as usize][k];
        Ok(())
    }

    fn step_derivative(&mut self, _k: usize, _seed: &[f64], _out: &mut [f64]) -> Result<(), UnitError> {
        Err(UnitError::Other("no derivatives".into()))
    }
}

/// Linear extrapolation takes the slope over the last step, whatever its size: on values linear
/// in time the first guess is exact at every step of a changing size (one evaluation per step,
/// none left to iterate), as the adaptive step changes it.
#[test]
fn linear_extrapolation_follows_a_changing_step() {
    let o = Options { extrapolation: Extrapolation::Linear, ..options(Scheme::Iterative) };
    let mut c = Coupled::new(ClockAndEcho::new(), o).unwrap();
    let steps = [0.1, 0.1, 0.05, 0.2, 0.01, 0.3, 0.3, 0.07];
    let iterations: Vec<usize> = steps.iter().map(|&h| c.step(h).unwrap().iterations).collect();
    eprintln!("evaluations per step: {iterations:?}");
    // the first step has no slope yet; every later one is guessed exactly
    assert!(iterations[1..].iter().all(|&n| n == 1), "{iterations:?}");
    assert!((c.outputs()[1] - steps.iter().sum::<f64>()).abs() < 1e-12);
}

/// IJCSA's reused Jacobian belongs to the step size it was computed for: with the step size
/// changing (as the adaptive step changes it) every step of the linear system still converges in
/// one Newton update (two evaluations), and the Jacobian is computed once per new size — not
/// corrected by secants of another step map and then recomputed step after step as stale.
#[test]
fn reused_jacobian_follows_a_changing_step() {
    // (central differences of the step maps are exact to 1e-10 here: the tolerance allows it)
    let mut o = Options { tol: 1e-10, ..options(Scheme::Ijcsa) };
    (o.jacobian, o.extrapolation) = (JacobianUpdate::Reuse, Extrapolation::Linear);
    let mut c = Coupled::new(TwoMasses::new(), o).unwrap();
    let pattern = [0.01, 0.01, 0.02, 0.02, 0.005, 0.013, 0.013, 0.013, 0.04, 0.01];
    let steps: Vec<f64> = (0..5).flat_map(|_| pattern).collect();
    let iterations: Vec<usize> = steps.iter().map(|&h| c.step(h).unwrap().iterations).collect();
    let sizes = 1 + steps.windows(2).filter(|w| w[0] != w[1]).count();
    eprintln!("evaluations per step: {iterations:?}; {} unit steps, {sizes} step sizes", c.units().steps);
    assert!(iterations.iter().all(|&n| n == 2), "{iterations:?}");
    // each evaluation steps both units; each Jacobian by central differences steps each unit
    // twice for its one input and once more with the nominal input
    assert_eq!(c.units().steps, 2 * 2 * steps.len() + 2 * 3 * sizes);
}

/// The adaptive step judges its error by what it is told to watch: coupled inputs by name or
/// by a prefix that ends before a `.` or `[`, else outputs; a name that is none is refused with
/// the inputs and outputs there are. Watching x₁ alone the run still meets its tolerance on x₁;
/// watching mass 1's velocity (an output no connection carries), on the velocity.
#[test]
fn the_adaptive_step_watches_what_it_is_told() {
    let mut c = Coupled::new(TwoMasses::new(), options(Scheme::IqnIls)).unwrap();
    for bad in ["b.f", "c", "b.x1[1]"] {
        let e = c.watch(&[bad.to_string()]).unwrap_err().to_string();
        assert!(e.contains(&format!("`{bad}`")), "{e}");
        assert!(e.contains("`a.force`, `b.x1`") && e.contains("`a.x`, `a.v`, `b.force`, `b.x`"), "{e}");
    }
    let (t_end, rtol) = (5.0, 1e-3);
    let tol = Tolerances { rtol, atol: 1e-3 * rtol };
    // (output, its exact value): x₁ through the input it feeds, and v₁
    let velocity = |t: f64| {
        let (w1, w2) = ((K / M).sqrt(), ((K + 2.0 * KC) / M).sqrt());
        -0.5 * X1 * (w1 * (w1 * t).sin() + w2 * (w2 * t).sin())
    };
    let displacement = |t: f64| exact(t)[0] - X1;
    let cases = [("b", 0, &displacement as &dyn Fn(f64) -> f64), ("a.v", 1, &velocity)];
    let mut counts = Vec::new();
    for (name, column, value) in cases {
        let mut c = Coupled::new(TwoMasses::new(), options(Scheme::IqnIls)).unwrap();
        c.watch(&[name.to_string()]).unwrap();
        let mut ctl = Controller::new(Limits { h_min: 1e-7, h_max: 0.1, h_init: 1e-4 }).unwrap();
        let (mut worst, mut range, mut steps) = (0.0f64, 0.0f64, 0);
        let offset = if column == 0 { X1 } else { 0.0 };
        while c.time() < t_end {
            c.step_adaptive(&mut ctl, tol, t_end).unwrap();
            steps += 1;
            worst = worst.max((c.outputs()[column] - offset - value(c.time())).abs());
            range = range.max(value(c.time()).abs());
        }
        eprintln!("watching {name}: {steps} steps, error {:.2e} of the range", worst / range);
        assert!(worst <= rtol * range, "{name}");
        counts.push(steps);
    }
    // all the coupled inputs, as by default
    let mut all = Coupled::new(TwoMasses::new(), options(Scheme::IqnIls)).unwrap();
    all.watch(&[]).unwrap();
    let mut ctl_all = Controller::new(Limits { h_min: 1e-7, h_max: 0.1, h_init: 1e-4 }).unwrap();
    let mut steps_all = 0;
    while all.time() < t_end {
        all.step_adaptive(&mut ctl_all, tol, t_end).unwrap();
        steps_all += 1;
    }
    eprintln!("watching both inputs: {steps_all} steps");
    assert!(
        counts[0] != steps_all && counts[1] != counts[0],
        "what is watched changes the steps: {counts:?}, {steps_all}"
    );
}

/// Step doubling (the whole step against two half steps) on the known solution: within the
/// tolerance, and every rejected try and every discarded whole step leaves no trace — the run is,
/// bit for bit, the run that takes each accepted step as its two half steps.
#[test]
fn step_doubling_meets_its_tolerance_and_leaves_no_trace() {
    let (t_end, rtol) = (5.0, 1e-3);
    let tol = Tolerances { rtol, atol: 1e-3 * rtol };
    for o in [options(Scheme::IqnIls), Options { jacobian: JacobianUpdate::Reuse, ..options(Scheme::Ijcsa) }] {
        let mut c = Coupled::new(TwoMasses::new(), o).unwrap();
        c.estimate_by(Kind::Doubling);
        let mut ctl = Controller::new(Limits { h_min: 1e-7, h_max: 0.1, h_init: 1e-4 }).unwrap();
        let (mut steps, mut worst, mut range, mut iterations) = (Vec::new(), 0.0f64, 0.0f64, 0);
        while c.time() < t_end {
            let accepted = c.step_adaptive(&mut ctl, tol, t_end).unwrap();
            // a doubled step reports what its three steps (whole, two halves) cost
            assert!(accepted.report.iterations >= 3, "{accepted:?}");
            iterations += accepted.report.iterations;
            steps.push(accepted.h);
            worst = worst.max((c.outputs()[0] - exact(c.time())[0]).abs());
            range = range.max((exact(c.time())[0] - X1).abs());
        }
        eprintln!(
            "{}: {} steps ({} rejected), error {:.2e} of the range",
            o.scheme.name(),
            steps.len(),
            ctl.rejected,
            worst / range
        );
        assert!(worst <= rtol * range);
        assert!(ctl.rejected > 0, "no step was rejected: the test shows nothing");
        let mut direct = Coupled::new(TwoMasses::new(), o).unwrap();
        let mut halves = 0;
        for h in &steps {
            halves += direct.step(0.5 * h).unwrap().iterations;
            halves += direct.step(0.5 * h).unwrap().iterations;
        }
        assert!(iterations > halves, "the whole steps counted too: {iterations} against {halves}");
        assert_eq!(direct.outputs(), c.outputs(), "{}", o.scheme.name());
        assert_eq!(direct.units().now, c.units().now, "{}", o.scheme.name());
    }
}

/// The first macro step from the start, for the schemes that solve the interface by
/// (quasi-)Newton: the substeps h/1024, h/1024, h/512, …, h/2, landing on h exactly — the same,
/// bit for bit, as taking those steps one by one; the fixed point steps once.
#[test]
fn the_first_step_from_the_start_is_taken_in_substeps() {
    let h = 0.01;
    let mut pieces = vec![h / 1024.0];
    while pieces.iter().sum::<f64>() < 0.5 * h {
        pieces.push(pieces.iter().sum());
    }
    pieces.push(0.5 * h);
    assert_eq!(pieces.len() as u32, cosim::START_SUBSTEPS + 1);
    for scheme in [Scheme::Ijcsa, Scheme::IqnIls] {
        let mut c = Coupled::new(TwoMasses::new(), options(scheme)).unwrap();
        let report = c.step_from_start(h).unwrap();
        assert_eq!(c.time(), h, "{}", scheme.name());
        let mut one_by_one = Coupled::new(TwoMasses::new(), options(scheme)).unwrap();
        let iterations: usize = pieces.iter().map(|&p| one_by_one.step(p).unwrap().iterations).sum();
        assert_eq!(c.outputs(), one_by_one.outputs(), "{}", scheme.name());
        assert_eq!(report.iterations, iterations, "{}: the iterations of all substeps", scheme.name());
        assert_eq!(c.units().steps, one_by_one.units().steps);
    }
    let mut c = Coupled::new(TwoMasses::new(), options(Scheme::Iterative)).unwrap();
    let mut once = Coupled::new(TwoMasses::new(), options(Scheme::Iterative)).unwrap();
    c.step_from_start(h).unwrap();
    once.step(h).unwrap();
    assert_eq!(c.outputs(), once.outputs());
}
