//! The co-simulation schemes on the packaged FMUs against the monolithic model.

use crate::common;

use studies::cosim::{Coupled, Extrapolation, FmuSystem, JacobianUpdate, Options, Scheme, Units};
use studies::simulate::{Method, Trace, simulate};

fn options(scheme: Scheme) -> Options {
    Options { scheme, ..Options::default() }
}

fn largest_displacement(t: &Trace) -> f64 {
    t.disp_mm.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs())) * 1e-3
}

/// The platform held still: every stable method stays at the static equilibrium. The master
/// sets the connected inputs from the outputs in initialization mode; the decoupled model's cut
/// connection leaves the Stewart FMU's cabin input unset, so it also checks that an FMU reports
/// its own scene's static values there (B's, not another pose's).
#[test]
fn held_still_every_stable_method_stays_at_rest() {
    let (scene, file) = common::scene("lt50m_B.toml", "still", |s| s.motion.speed_m_s = 0.0);
    for method in [
        Method::Monolithic,
        Method::Cosim(options(Scheme::Ijcsa)),
        Method::Cosim(options(Scheme::Iterative)),
        Method::Cosim(options(Scheme::IqnIls)),
        Method::Decoupled(options(Scheme::Jacobi)),
    ] {
        let t = simulate(&scene, &file, method, 0.01, 100.0).unwrap();
        let drift = largest_displacement(&t);
        eprintln!("{}: drift over 100 s {drift:.2e} m", t.method);
        assert!(drift <= 1e-9, "{}: {drift:e} m", t.method);
    }
}

/// Jacobi and Gauss–Seidel are unstable on LT50m (the platform's added inertia about the cabin
/// centre point exceeds the cabin's): the run stops and says so.
#[test]
fn explicit_schemes_report_their_instability() {
    let (scene, file) = common::scene("lt50m_C.toml", "explicit", |_| {});
    for scheme in [Scheme::Jacobi, Scheme::GaussSeidel { reversed: false }, Scheme::GaussSeidel { reversed: true }] {
        let e = simulate(&scene, &file, Method::Cosim(options(scheme)), 0.01, 5.0).unwrap_err().to_string();
        eprintln!("{}: {e}", scheme.name());
        assert!(e.contains("unstable") && e.contains("stopped at t ="), "{e}");
    }
}

/// IJCSA at h agrees with the monolithic model at h to within the monolithic model's own
/// time-step error (h against h/4), and to far better than 1 % of the peak; both converge to one
/// solution as h shrinks; at most 3 iterations per step.
#[test]
fn ijcsa_agrees_with_the_monolithic_model() {
    for name in ["lt50m_C.toml", "lt50m_B.toml"] {
        let (scene, file) = common::scene(name, "ijcsa", |_| {});
        let t_end = 10.0;
        let run = |m: Method, h: f64| simulate(&scene, &file, m, h, t_end).unwrap();
        let (mono, mono_fine) = (run(Method::Monolithic, 0.01), run(Method::Monolithic, 0.0025));
        let ijcsa = run(Method::Cosim(options(Scheme::Ijcsa)), 0.01);
        let ijcsa_fine = run(Method::Cosim(options(Scheme::Ijcsa)), 0.0025);
        let own = mono.error_against(&mono_fine).0;
        let coupling = ijcsa.error_against(&mono).0;
        let peak = mono.peak_mm();
        eprintln!(
            "{name}: ijcsa vs monolithic {coupling:.3e} mm, monolithic h vs h/4 {own:.3e} mm, peak {peak:.3} mm, {:.2} iterations/step",
            ijcsa.mean_iterations()
        );
        assert!(coupling <= own, "the coupling error {coupling:e} must stay within the time-step error {own:e}");
        assert!(coupling <= 0.01 * peak);
        assert!(ijcsa.mean_iterations() <= 3.0, "{} iterations per step", ijcsa.mean_iterations());
        // one solution as h shrinks: both fine runs closer to each other than the coarse ones
        let fine_gap = ijcsa_fine.error_against(&mono_fine).0;
        let coarse_gap = ijcsa.error_against(&mono_fine).0;
        eprintln!(
            "{name}: ijcsa(h/4) vs monolithic(h/4) {fine_gap:.3e} mm, ijcsa(h) vs monolithic(h/4) {coarse_gap:.3e} mm"
        );
        assert!(fine_gap < coarse_gap / 4.0);
    }
}

/// IJCSA with the Jacobian reused across steps (secant-updated, a unit whose block goes stale
/// recomputed every step) and linear extrapolation: the exact-Jacobian scheme's answer to far
/// below 1e-3 of the peak, and about its iteration count while the cable FMU's step-map
/// derivative — the costly one — is computed once (over 100 s at C: 2.013 against 2.003; the
/// first 10 s, with the abrupt start, 2.13 against 2.03).
#[test]
fn ijcsa_with_a_reused_jacobian_keeps_the_answer_and_the_iterations() {
    for name in ["lt50m_C.toml", "lt50m_B.toml"] {
        let (scene, file) = common::scene(name, "reuse", |_| {});
        let run = |m: Method| simulate(&scene, &file, m, 0.01, 10.0).unwrap();
        let mono = run(Method::Monolithic);
        let exact = run(Method::Cosim(options(Scheme::Ijcsa)));
        let mut o = options(Scheme::Ijcsa);
        (o.jacobian, o.extrapolation) = (JacobianUpdate::Reuse, Extrapolation::Linear);
        let reused = run(Method::Cosim(o));
        let (gap, coupling, peak) = (reused.error_against(&exact).0, reused.error_against(&mono).0, mono.peak_mm());
        eprintln!(
            "{name}: reused − exact {gap:.2e} mm, reused − monolithic {coupling:.2e} mm (exact: {:.2e}), peak {peak:.3} mm, {:.3} iterations/step (exact {:.3})",
            exact.error_against(&mono).0,
            reused.mean_iterations(),
            exact.mean_iterations()
        );
        assert!(coupling <= 1e-3 * peak && gap <= 1e-5 * peak, "{gap:e} / {coupling:e} mm");
        assert!(
            reused.mean_iterations() <= exact.mean_iterations() + 0.15,
            "{} iterations per step",
            reused.mean_iterations()
        );
    }
}

/// The fixed-point iteration converges with constant relaxation, to the IJCSA solution (with
/// the ramp start: after a kink IJCSA takes its first step in substeps, which the fixed point,
/// whose loop gain grows as the step shrinks, does not).
#[test]
fn iterative_converges_to_the_ijcsa_solution() {
    let (scene, file) = common::scene("lt50m_C.toml", "iter", |s| s.motion.start = feedcore::scene::Start::Ramp);
    let it = simulate(&scene, &file, Method::Cosim(options(Scheme::Iterative)), 0.01, 2.0).unwrap();
    let nj = simulate(&scene, &file, Method::Cosim(options(Scheme::Ijcsa)), 0.01, 2.0).unwrap();
    let gap = it.error_against(&nj).0;
    eprintln!("iterative: {:.1} iterations per step, {gap:.2e} mm from ijcsa", it.mean_iterations());
    assert!(gap < 1e-5 * nj.peak_mm().max(1e-3) + 1e-6);
}

/// A scheme that cannot converge within its limit stops with the time, the residual and the
/// variable.
#[test]
fn non_convergence_names_time_residual_and_variable() {
    let (scene, file) = common::scene("lt50m_C.toml", "limit", |_| {});
    let mut o = options(Scheme::Iterative);
    o.max_iter = 3;
    let e = simulate(&scene, &file, Method::Cosim(o), 0.01, 1.0).unwrap_err().to_string();
    assert!(
        e.contains("did not converge in 3 iterations") && e.contains("t = 0.010000") && e.contains("residual"),
        "{e}"
    );
    assert!(e.contains("`stewart.cabin") || e.contains("`cable.wrench"), "{e}");
}

/// IQN-ILS, without any derivative, agrees with the monolithic model like IJCSA does: within the
/// monolithic model's own time-step error and 1e-3 of the peak, at most 5 iterations per step.
#[test]
fn iqn_ils_agrees_with_the_monolithic_model() {
    for name in ["lt50m_C.toml", "lt50m_B.toml"] {
        let (scene, file) = common::scene(name, "iqn", |_| {});
        let run = |m: Method, h: f64| simulate(&scene, &file, m, h, 10.0).unwrap();
        let (mono, mono_fine) = (run(Method::Monolithic, 0.01), run(Method::Monolithic, 0.0025));
        let iqn = run(Method::Cosim(options(Scheme::IqnIls)), 0.01);
        let own = mono.error_against(&mono_fine).0;
        let coupling = iqn.error_against(&mono).0;
        let peak = mono.peak_mm();
        eprintln!(
            "{name}: iqn-ils vs monolithic {coupling:.3e} mm (own step error {own:.3e} mm, peak {peak:.3} mm), {:.2} iterations/step",
            iqn.mean_iterations()
        );
        assert!(coupling <= own && coupling <= 1e-3 * peak);
        assert!(iqn.mean_iterations() <= 5.0, "{} iterations per step", iqn.mean_iterations());
    }
}

/// The platform's masses ×5 at C: the fixed point fails at once; IQN-ILS and IJCSA converge,
/// to one solution.
#[test]
fn heavy_platform_iqn_ils_converges_where_the_fixed_point_fails() {
    let (scene, file) = common::scene("lt50m_C.toml", "heavy", |s| {
        let st = &mut s.stewart;
        st.platform.mass_kg *= 5.0;
        st.platform.inertia_kg_m2.iter_mut().flatten().for_each(|x| *x *= 5.0);
        for part in [&mut st.upper_leg, &mut st.lower_leg] {
            part.mass_kg *= 5.0;
            part.inertia_transverse_kg_m2 *= 5.0;
            part.inertia_axial_kg_m2 *= 5.0;
        }
    });
    let run = |scheme| simulate(&scene, &file, Method::Cosim(options(scheme)), 0.01, 2.0);
    // the relaxed fixed point runs away within the first step (the FMU gets a cabin attitude
    // that is no rotation any more)
    let e = run(Scheme::Iterative).unwrap_err().to_string();
    eprintln!("iterative: {e}");
    assert!(e.contains("t = 0.010000"), "{e}");
    let (iqn, ijcsa) = (run(Scheme::IqnIls).unwrap(), run(Scheme::Ijcsa).unwrap());
    let gap = iqn.error_against(&ijcsa).0;
    eprintln!(
        "mass ×5: iqn-ils {:.2} it/step, ijcsa {:.2}, gap {gap:.2e} mm",
        iqn.mean_iterations(),
        ijcsa.mean_iterations()
    );
    assert!(gap <= 1e-6 * ijcsa.peak_mm().max(1.0));
    assert!(iqn.mean_iterations() <= 6.0);
}

fn fmu_system(scene: &feedcore::scene::ValidScene, file: &std::path::Path, o: Options) -> Coupled<FmuSystem> {
    let spec = studies::system::scene_spec(scene, file).unwrap();
    Coupled::new(FmuSystem::load(&spec, &studies::system::needs(&o, true)).unwrap(), o).unwrap()
}

/// Undoing a step (what a rejected adaptive step does) restores every FMU bit for bit: the
/// serialized states are the same bytes, and the step taken again gives the same outputs.
#[test]
fn a_rejected_step_restores_every_fmu_bit_for_bit() {
    let (scene, file) = common::scene("lt50m_C.toml", "undo", |_| {});
    let reused =
        Options { jacobian: JacobianUpdate::Reuse, extrapolation: Extrapolation::Linear, ..options(Scheme::Ijcsa) };
    for o in [options(Scheme::IqnIls), options(Scheme::Ijcsa), reused] {
        let scheme = o.scheme;
        let mut c = fmu_system(&scene, &file, o);
        for _ in 0..20 {
            c.step(0.01).unwrap();
        }
        let before = c.units_mut().serialized_states().unwrap();
        let y = c.outputs().to_vec();
        c.step(0.03).unwrap();
        let first = c.outputs().to_vec();
        assert_ne!(c.units_mut().serialized_states().unwrap(), before);
        c.undo_step().unwrap();
        assert_eq!(c.units_mut().serialized_states().unwrap(), before, "{}", scheme.name());
        assert_eq!(c.outputs(), &y[..]);
        assert!((c.time() - 0.2).abs() < 1e-12);
        c.step(0.03).unwrap();
        assert_eq!(c.outputs(), &first[..], "{}: the step again", scheme.name());
    }
}

/// The same with the second level's state in the Stewart FMU's saved states (its command
/// filter, pending commands, noise generator, inertial unit and Kalman filter; with the LQG law
/// its controller's estimates and the fixes on their way): the fused and the LQG scene from
/// 100 ms on, each of eight steps undone and taken again, across readings (every 4 steps) and a
/// fix (every 8).
#[test]
fn a_rejected_step_restores_the_second_levels_state_bit_for_bit() {
    for name in ["lt50m_C_compensated.toml", "lt50m_C_lqg.toml"] {
        rejected_steps_restore(name);
    }
}

fn rejected_steps_restore(name: &str) {
    let (scene, file) = common::scene(name, "undo-fused", |_| {});
    for o in [options(Scheme::IqnIls), options(Scheme::Ijcsa)] {
        let mut c = fmu_system(&scene, &file, o);
        for _ in 0..40 {
            c.step(0.0025).unwrap();
        }
        for _ in 0..8 {
            let (before, y) = (c.units_mut().serialized_states().unwrap(), c.outputs().to_vec());
            c.step(0.0025).unwrap();
            let first = c.outputs().to_vec();
            c.undo_step().unwrap();
            assert_eq!(c.units_mut().serialized_states().unwrap(), before, "{}", o.scheme.name());
            assert_eq!(c.outputs(), &y[..]);
            c.step(0.0025).unwrap();
            assert_eq!(c.outputs(), &first[..], "{}: the step again", o.scheme.name());
        }
    }
}

/// An adaptive run whose steps were rejected is the same, bit for bit, as a run that took the
/// accepted steps directly: the rejected tries leave no trace (IQN-ILS's history and IJCSA's
/// reused Jacobian included).
#[test]
fn adaptive_rejections_leave_no_trace() {
    let (scene, file) = common::scene("lt50m_C.toml", "adaptive", |_| {});
    let reused =
        Options { jacobian: JacobianUpdate::Reuse, extrapolation: Extrapolation::Linear, ..options(Scheme::Ijcsa) };
    for o in [options(Scheme::IqnIls), reused] {
        rejections_leave_no_trace(&scene, &file, o);
    }
}

fn rejections_leave_no_trace(scene: &feedcore::scene::ValidScene, file: &std::path::Path, o: Options) {
    let mut c = fmu_system(scene, file, o);
    let mut ctl =
        cosim::step_control::Controller::new(cosim::step_control::Limits { h_min: 1e-5, h_max: 0.1, h_init: 1e-4 })
            .unwrap();
    let tol = cosim::step_control::Tolerances { rtol: 1e-3, atol: 1e-6 };
    let mut steps = Vec::new();
    while c.time() < 1.0 {
        steps.push(c.step_adaptive(&mut ctl, tol, 1.0).unwrap().h);
    }
    eprintln!("{} steps, {} rejected, h {:.1e} … {:.1e}", steps.len(), ctl.rejected, ctl.h_min_used, ctl.h_max_used);
    assert!(ctl.rejected > 0, "no step was rejected: the test shows nothing");
    assert!(ctl.h_max_used > 10.0 * ctl.h_min_used, "the step did not adapt");
    let mut direct = fmu_system(scene, file, o);
    for h in &steps {
        direct.step(*h).unwrap();
    }
    assert_eq!(direct.outputs(), c.outputs());
    assert_eq!(direct.units_mut().serialized_states().unwrap(), c.units_mut().serialized_states().unwrap());
}

/// `master export-ssp` writes the scene's system as an SSP archive that runs, through the SSP
/// reader, with the same result as the scene, bit for bit.
#[test]
fn exported_ssp_runs_bit_for_bit_like_the_scene() {
    let (scene, file) = common::scene("lt50m_B.toml", "export", |_| {});
    let ssp = common::fmu_dir().join("export-B.ssp");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_master"))
        .args(["export-ssp", "--scene", file.to_str().unwrap(), "--out", ssp.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let o = options(Scheme::IqnIls);
    let mut from_scene = fmu_system(&scene, &file, o);
    let loaded = cosim::ssp::read::load(&ssp).unwrap();
    let mut from_ssp =
        Coupled::new(FmuSystem::load(&loaded.spec, &studies::system::needs(&o, false)).unwrap(), o).unwrap();
    assert_eq!(from_ssp.units().layout(), from_scene.units().layout());
    let all = |c: &mut Coupled<FmuSystem>| -> Vec<f64> {
        let mut v = Vec::new();
        for (_, inst) in c.units_mut().instances() {
            let vrs = inst.value_references(fmi::Causality::Output, fmi::VarType::Real);
            let mut y = vec![0.0; vrs.len()];
            inst.get_real(&vrs, &mut y).unwrap();
            v.extend(y);
        }
        v
    };
    assert_eq!(all(&mut from_scene), all(&mut from_ssp));
    for _ in 0..100 {
        from_scene.step(0.01).unwrap();
        from_ssp.step(0.01).unwrap();
    }
    let (a, b) = (all(&mut from_scene), all(&mut from_ssp));
    assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()), "outputs differ after 1 s");
    assert_eq!(loaded.stop_time, Some(scene.solver.t_end_s));
}
