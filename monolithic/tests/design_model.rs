//! The linear design model against the nonlinear coupled model, and the LQG law run in it.

use design::plant::{Instruments, build};
use feedcore::scene::{Scene, ValidScene};
use monolithic::linear::{Options, frequency_response, linearize, sinusoids};
use monolithic::{Monolithic, feed};
use nalgebra::{Complex, DMatrix};

fn scene(name: &str, edit: impl FnOnce(&mut Scene)) -> ValidScene {
    let path = format!("{}/../scenes/{name}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap();
    Scene::from_toml(&text, &path).unwrap().edited(edit).unwrap()
}

fn options() -> Options {
    Options {
        modes: 90,
        keep_below_hz: 3.0,
        min_cabin_share: 0.02,
        wind_sections: 6,
        delay_s: 0.02,
        model_error: (0.0, 0.0),
        tilt_weight_m: 1.0,
        stroke_weight: 1e-3,
        force_weight_m_per_n: 1e-7,
        command_weight: 1e-4,
    }
}

/// Instruments for a model read only for its responses.
fn any_instruments() -> Instruments {
    Instruments {
        period: 0.01,
        fix_every: 1,
        delay_steps: 0,
        accel_noise_density: 1e-3,
        gyro_noise_density: 1e-5,
        accel_bias_walk: 1e-4,
        gyro_bias_walk: 1e-7,
        fix_noise_m: 1e-4,
        fix_noise_rad: 1e-5,
        servo_hz: 4.5,
        servo_stages: 3,
    }
}

/// The platform's reaction to the cabin's acceleration, from the Stewart model (the bodies'
/// Newton–Euler equations), is minus the spatial mass of the payload the cable model locks on
/// the cabin: one physics, two codes.
#[test]
fn the_platforms_added_mass_is_the_locked_payloads() {
    let lin = linearize(&scene("lt50m_C_compensated.toml", |_| {}), &options()).unwrap();
    let gap = (lin.added_mass + lin.locked_payload).norm() / lin.locked_payload.norm();
    assert!(gap < 1e-12, "{gap:e}\n{}\n{}", lin.added_mass, lin.locked_payload);
}

/// Relative gap of two complex vectors, against the larger's norm.
fn gap(a: &[Complex<f64>], b: &[Complex<f64>]) -> f64 {
    let d: f64 = a.iter().zip(b).map(|(x, y)| (x - y).norm_sqr()).sum::<f64>().sqrt();
    let n = |v: &[Complex<f64>]| v.iter().map(|x| x.norm_sqr()).sum::<f64>().sqrt();
    d / n(a).max(n(b))
}

/// Frequency responses below 3 Hz, the linear model's against the nonlinear model's (least-squares
/// sinusoids fitted to runs of 60 s after a 20 s start): the wind's force on the cabin to the
/// feed's error (platform held; a single harmonic of the wind at each frequency, the drag a
/// hundredth of the scene's so that the mean wind moves the cabin by 0.1 mm), and the platform's
/// commanded motion (a circle of 2 mm at each frequency, `[motion]`, started at full speed) to
/// the cabin's motion (displacement and rotation): within 3 % at frequencies away from the modes
/// (2 % of them apart), their complex amplitudes compared whole. The modes' free ringing the
/// start leaves is fitted out with them. (Measured: at most 0.2 % wind → feed, 1.8 % command →
/// cabin, at 2.8 Hz, where the model's 2.5 ms step shifts the phase by 2 %.)
#[test]
fn frequency_responses_match_the_nonlinear_model_below_3_hz() {
    let h = 0.0025;
    let lqg = scene("lt50m_C_lqg.toml", |_| {});
    let design = lqg.control.as_ref().unwrap().lqg.clone().unwrap();
    let cp = build(&lqg, &design, &any_instruments()).unwrap();
    let modes = design.modes_hz.clone();
    // the free ringing of the modes (damped frequency, decay rate) the fits take out: one per
    // cluster (modes within 0.5 % ring alike over a minute, and their columns would be as one)
    let mut ringing: Vec<(f64, f64)> = Vec::new();
    for (f, z) in modes.iter().zip(&design.damping_ratios) {
        // (a pseudo-mode has died out long before the window)
        if *z < 0.1 && ringing.last().is_none_or(|(g, _)| f / g > 1.005) {
            ringing.push((f * (1.0 - z * z).sqrt(), z * std::f64::consts::TAU * f));
        }
    }
    let clear = |f: f64| modes.iter().all(|m| (f / m - 1.0).abs() > 0.02);
    let (start, end) = (20.0, 80.0);
    let mut worst: f64 = 0.0;
    for f in [0.2, 0.35, 0.6, 1.1, 2.2, 2.8] {
        assert!(clear(f), "{f} Hz lies at a mode");
        // the wind: one harmonic within ±0.1 % of f
        let run = lqg
            .edited(|s| {
                s.control.as_mut().unwrap().switch_off();
                let w = s.wind.as_mut().unwrap();
                (w.band_hz, w.harmonics, w.drag_area_m2, w.ramp_s) =
                    ([f * 0.999, f * 1.001], 1, w.drag_area_m2 * 0.01, 10.0);
            })
            .unwrap();
        let load = feedcore::wind::WindLoad::new(run.wind.as_ref().unwrap());
        let (fk, ak, phase) = load.harmonics().next().unwrap();
        let w = run.wind.as_ref().unwrap();
        let force = Complex::from_polar(w.air_density_kg_m3 * w.drag_area_m2 * w.mean_speed_m_s * ak, phase);
        let mut m = Monolithic::new(&run).unwrap();
        let comp = m.compensation().cloned().unwrap();
        let (mut t, mut e) = (Vec::new(), [Vec::new(), Vec::new(), Vec::new()]);
        for k in 1..=(end / h) as usize {
            m.step(h).unwrap();
            let s = m.sample();
            if s.time >= start {
                let (p, r) = (&s.cabin.position, &s.cabin.orientation);
                let (err, _) = comp.feed_error(&(p + r * s.platform), &(r * s.platform_rotation), s.time);
                t.push(k as f64 * h);
                for i in 0..3 {
                    e[i].push(err[i]);
                }
            }
        }
        let nonlinear: Vec<Complex<f64>> = e.iter().map(|v| sinusoids(&t, v, &[fk], &ringing)[0]).collect();
        let direction =
            DMatrix::from_row_slice(6, 1, &[design.wind_direction[0], design.wind_direction[1], 0.0, 0.0, 0.0, 0.0]);
        let hf = frequency_response(&cp.plant.a, &(&cp.wrench_input * direction), &cp.feed.0, fk);
        let linear: Vec<Complex<f64>> = (0..3).map(|i| hf[(i, 0)] * force).collect();
        let g = gap(&nonlinear, &linear);
        eprintln!(
            "wind → feed at {fk:.4} Hz: gap {g:.2e} (|response| {:.3e} m)",
            linear.iter().map(|z| z.norm_sqr()).sum::<f64>().sqrt()
        );
        worst = worst.max(g);
        assert!(g < 0.03, "wind → feed at {fk} Hz: {g}");
    }
    // the platform's motion: the model of the plain scene (no [control]: the platform on its circle)
    for f in [0.2, 0.6, 1.1, 2.2, 2.8] {
        let radius = 0.002;
        let circle = scene("lt50m_C.toml", |s| {
            (s.motion.radius_m, s.motion.speed_m_s) = (radius, std::f64::consts::TAU * f * radius);
            s.motion.start = feedcore::scene::Start::Abrupt;
            s.motion.ramp_time_s = 10.0;
            s.solver.dt_s = h;
        });
        let lin = linearize(&circle, &options()).unwrap();
        let plant = build(&circle, &lin.design, &any_instruments()).unwrap();
        let mut m = Monolithic::new(&circle).unwrap();
        let p0 = m.sample().cabin.position;
        let (mut t, mut y, mut platform) = (Vec::new(), vec![Vec::new(); 6], vec![Vec::new(); 2]);
        for k in 1..=(end / h) as usize {
            m.step(h).unwrap();
            let s = m.sample();
            if s.time >= start {
                t.push(k as f64 * h);
                let d = s.cabin.position - p0;
                let r = s.cabin.orientation.scaled_axis();
                for (i, v) in [d.x, d.y, d.z, r.x, r.y, r.z].iter().enumerate() {
                    y[i].push(*v);
                }
                platform[0].push(s.platform.x);
                platform[1].push(s.platform.y);
            }
        }
        let nonlinear: Vec<Complex<f64>> = y.iter().map(|v| sinusoids(&t, v, &[f], &ringing)[0]).collect();
        // the circle's own phasors (its phase after the speed's ramp)
        let input: Vec<Complex<f64>> = platform.iter().map(|v| sinusoids(&t, v, &[f], &ringing)[0]).collect();
        // the command → relative pose: the servo's stages; the circle (x: r cos, y: r sin) is the
        // relative pose, so divide them out: H_r = H_u (1 + jωτ)³
        let hu = frequency_response(&plant.plant.a, &plant.plant.b, &plant.cabin.0, f);
        let tau = 1.0 / (std::f64::consts::TAU * 4.5);
        let servo = Complex::new(1.0, std::f64::consts::TAU * f * tau).powi(3);
        let linear: Vec<Complex<f64>> =
            (0..6).map(|i| (hu[(i, 0)] * input[0] + hu[(i, 1)] * input[1]) * servo).collect();
        let g = gap(&nonlinear, &linear);
        eprintln!(
            "command → cabin at {f} Hz: gap {g:.2e} (|response| {:.3e})",
            nonlinear.iter().map(|z| z.norm_sqr()).sum::<f64>().sqrt()
        );

        worst = worst.max(g);
        assert!(g < 0.03, "command → cabin at {f} Hz: {g}");
    }
    eprintln!("largest gap {worst:.2e}");
}

/// The LQG law in the nonlinear model against its bound: at a tenth of the scene's drag (the cabin
/// sways 1.4 mm, where the linear model holds) the design meets its predicted feed RMS within
/// 1.25× over 100 s on a wind seed the design did not see; at the scene's full wind (±12 mrad
/// of sway, whose second order the linear model lacks) it stays within 2.5× and far below the
/// tuned filter's error on another seed (60 s).
#[test]
fn the_lqg_law_meets_its_bound_where_the_model_holds() {
    let small = scene("lt50m_C_compensated.toml", |s| s.wind.as_mut().unwrap().drag_area_m2 *= 0.1);
    let lin = linearize(&small, &Options { model_error: (0.0, 0.0), ..options() }).unwrap();
    let error = monolithic::linear::model_error(&small, &lin.design, 100.0, 10.0, 0.0025).unwrap();
    let mut d = lin.design.clone();
    (d.model_error_force_n, d.model_error_moment_nm) = (error.force_density, error.moment_density);
    let ins = Instruments::of(&small).unwrap();
    let (_, _, bound) = design::study::evaluate(&small, &d, &ins).unwrap();
    let designed = small
        .edited(|s| {
            let c = s.control.as_mut().unwrap();
            (c.law, c.lqg, c.notch_hz, c.notch_q) = (feedcore::scene::Law::Lqg, Some(d.clone()), None, None);
            s.wind.as_mut().unwrap().seed = 7;
        })
        .unwrap();
    let h = feed::step_for(&designed);
    let run = feed::feed_run(&designed, h, (100.0 / h).round() as usize).unwrap();
    eprintln!(
        "a tenth of the drag: nonlinear {:.4} mm against the bound {:.4} mm",
        run.rms_m * 1e3,
        bound.feed_m * 1e3
    );
    assert!(run.rms_m < 1.25 * bound.feed_m, "{} vs {}", run.rms_m, bound.feed_m);
    // the scene's own wind: the shipped design, the tuned filter on the same seed
    let shipped = scene("lt50m_C_lqg.toml", |s| s.wind.as_mut().unwrap().seed = 8);
    let (_, _, full) = design::study::evaluate(
        &shipped,
        shipped.control.as_ref().unwrap().lqg.as_ref().unwrap(),
        &Instruments::of(&shipped).unwrap(),
    )
    .unwrap();
    let tuned = scene("lt50m_C_compensated.toml", |s| s.wind.as_mut().unwrap().seed = 8);
    let steps = (60.0 / h).round() as usize;
    let (a, b) = (feed::feed_run(&shipped, h, steps).unwrap(), feed::feed_run(&tuned, h, steps).unwrap());
    eprintln!(
        "full wind: LQG {:.4} mm (bound {:.4}), tuned filter {:.4} mm",
        a.rms_m * 1e3,
        full.feed_m * 1e3,
        b.rms_m * 1e3
    );
    assert!(a.rms_m < 2.5 * full.feed_m && a.rms_m < 0.1 * b.rms_m);
    assert_eq!(a.steps_beyond_limits, 0);
}

/// A snapshot restores the LQG law's state bit for bit: the run from it is the run that went on.
#[test]
fn the_lqg_state_is_restored_bit_for_bit() {
    let s = scene("lt50m_C_lqg.toml", |_| {});
    let h = 0.0025;
    let mut m = Monolithic::new(&s).unwrap();
    for _ in 0..200 {
        m.step(h).unwrap();
    }
    let snap = m.snapshot();
    let mut first = Vec::new();
    for _ in 0..60 {
        m.step(h).unwrap();
        first.push(m.sample());
    }
    m.restore(&snap);
    for expected in &first {
        m.step(h).unwrap();
        assert_eq!(&m.sample(), expected);
    }
}
