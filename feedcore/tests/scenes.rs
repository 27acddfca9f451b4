//! The reference scenes load, hold the numbers of lt50m.md, and bad scenes are rejected with
//! an error naming the file, the key and the value.

use approx::assert_relative_eq;
use feedcore::Vec3;
use feedcore::scene::{Scene, SceneError};

fn scene_path(name: &str) -> String {
    format!("{}/../scenes/{name}", env!("CARGO_MANIFEST_DIR"))
}

fn text(name: &str) -> String {
    std::fs::read_to_string(scene_path(name)).unwrap()
}

#[test]
fn reference_scenes_load_with_the_stated_geometry() {
    let b = Scene::load(scene_path("lt50m_B.toml")).unwrap();
    let c = Scene::load(scene_path("lt50m_C.toml")).unwrap();
    // Quaternion at B as given in lt50m.md (9 digits).
    let q = b.target_orientation();
    let given = [0.939692621, 0.326011192, 0.103414124, 0.0];
    for (x, y) in [q.w, q.i, q.j, q.k].iter().zip(given) {
        assert!((x - y).abs() < 1e-9, "{x} vs {y}");
    }
    assert_eq!(c.target_orientation(), feedcore::Quat::identity());
    // EA and mass per length as stated.
    assert_relative_eq!(b.cables.axial_stiffness(), 1.0247e7, max_relative = 1e-4);
    assert_relative_eq!(b.cables.mass_per_length(), 0.81300, max_relative = 1e-4);
    // Anchor 0 at azimuth 20°, attachment 0 at 30°.
    assert_relative_eq!(
        b.anchors()[0],
        Vec3::new(30.0 * 20f64.to_radians().cos(), 30.0 * 20f64.to_radians().sin(), 30.0)
    );
    assert_relative_eq!(b.attachments_body()[1], Vec3::new(70f64.to_radians().cos(), 70f64.to_radians().sin(), -0.25));
}

#[test]
fn stewart_geometry_matches_lt50m() {
    let s = Scene::load(scene_path("lt50m_C.toml")).unwrap();
    let g = s.stewart_geometry();
    // Nominal leg length at the circle centre, every leg (three-fold symmetric geometry).
    for k in 0..6 {
        assert_relative_eq!(g.leg_vector(k, &g.nominal_center).norm(), 1.27296, epsilon = 5e-6);
    }
    assert_relative_eq!(g.total_mass(), 184.8, epsilon = 1e-12);
    // Cabin + Stewart locked at the start: 904.8 kg, centre of mass ≈ (0.011, 0, −0.252) m.
    let all = s.cabin_mass_properties().combined(&g.locked_mass_properties(&g.start_center));
    assert_relative_eq!(all.mass, 904.8, epsilon = 1e-9);
    assert!((all.com - Vec3::new(0.011, 0.0, -0.252)).norm() < 1e-3, "{:?}", all.com);
    // The Hooke first axis is tangential to the base circle.
    for k in 0..6 {
        assert!(g.hooke_first_axis(k).dot(&g.base_joints[k]).abs() < 1e-15);
    }
}

/// Replaces `from` (exactly once) in scene C and expects an error naming `key`.
fn rejected(from: &str, to: &str) -> SceneError {
    let original = text("lt50m_C.toml");
    assert_eq!(original.matches(from).count(), 1, "pattern {from:?} must occur once");
    let edited = original.replace(from, to);
    Scene::from_toml(&edited, "edited.toml").expect_err(&format!("{from:?} -> {to:?} must be rejected"))
}

#[test]
fn non_physical_values_are_rejected_by_key_and_value() {
    let cases = [
        ("mass_kg = 720.0", "mass_kg = -720.0", "cabin.mass_kg", "-720"),
        ("mass_kg = 720.0", "mass_kg = 0.0", "cabin.mass_kg", "0"),
        ("area_m2 = 8.539e-5", "area_m2 = 0.0", "cables.area_m2", "0"),
        ("youngs_modulus_pa = 1.2e11", "youngs_modulus_pa = nan", "cables.youngs_modulus_pa", "NaN"),
        ("density_kg_m3 = 9521.02", "density_kg_m3 = inf", "cables.density_kg_m3", "inf"),
        ("elements = 20", "elements = 0", "cables.elements", "0"),
        (
            "orientation_wxyz = [1.0, 0.0, 0.0, 0.0]",
            "orientation_wxyz = [1.0, 0.1, 0.0, 0.0]",
            "pose.orientation_wxyz",
            "[1.0, 0.1, 0.0, 0.0]",
        ),
        (
            "orientation_wxyz = [1.0, 0.0, 0.0, 0.0]",
            "orientation_wxyz = [0.0, 0.0, 0.0, 0.0]",
            "pose.orientation_wxyz",
            "[0.0, 0.0, 0.0, 0.0]",
        ),
        ("mass_kg = 16.8", "mass_kg = -16.8", "stewart.platform.mass_kg", "-16.8"),
        ("rho_inf = 0.9", "rho_inf = 1.5", "solver.rho_inf", "1.5"),
        ("dt_s = 0.01", "dt_s = -0.01", "solver.dt_s", "-0.01"),
        ("ratio = 0.005", "ratio = -0.005", "damping.ratio", "-0.005"),
        ("fit_modes = [1, 6]", "fit_modes = [6, 1]", "damping.fit_modes", "[6, 1]"),
        (
            "[[266.4, 0.0, 0.0], [0.0, 266.4, 0.0], [0.0, 0.0, 360.0]]",
            "[[266.4, 0.0, 0.0], [0.0, 266.4, 0.0], [0.0, 0.0, -360.0]]",
            "cabin.inertia_kg_m2",
            "-360",
        ),
        (
            "[[266.4, 0.0, 0.0], [0.0, 266.4, 0.0], [0.0, 0.0, 360.0]]",
            "[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 360.0]]",
            "cabin.inertia_kg_m2",
            "360",
        ),
        (
            "angle_deg = [-45.0, 45.0, 75.0, 165.0, 195.0, 285.0]",
            "angle_deg = [-45.0, 45.0, 75.0]",
            "stewart.platform_joints.angle_deg",
            "75",
        ),
    ];
    for (from, to, key, value) in cases {
        let e = rejected(from, to);
        let msg = e.to_string();
        assert_eq!(e.file, "edited.toml");
        assert_eq!(e.key, key, "{msg}");
        assert!(msg.contains(value), "message must show the value {value}: {msg}");
    }
}

#[test]
fn orientation_axis_must_be_unit() {
    let original = text("lt50m_B.toml");
    let edited = original.replace("rotation_axis = [0.953192958, 0.302362671, 0.0]", "rotation_axis = [0.0, 0.0, 0.0]");
    let e = Scene::from_toml(&edited, "b.toml").unwrap_err();
    assert_eq!(e.key, "pose.rotation_axis");
    assert!(e.to_string().contains("not a unit axis"), "{e}");
}

#[test]
fn anchor_on_its_attachment_point_is_rejected() {
    // Move the cabin so that attachment 1 (at 30°, z −0.25) sits exactly on anchor 1.
    let original = text("lt50m_C.toml");
    let a = 30f64.to_radians();
    let b = 20f64.to_radians();
    let p = [30.0 * b.cos() - a.cos(), 30.0 * b.sin() - a.sin(), 30.25];
    let edited = original
        .replace("position_m = [0.0, 0.0, 9.8]", &format!("position_m = [{:.17}, {:.17}, {:.17}]", p[0], p[1], p[2]));
    let e = Scene::from_toml(&edited, "c.toml").unwrap_err();
    assert_eq!(e.key, "anchors.angle_deg[0]");
    assert!(e.to_string().contains("coincides"), "{e}");
}

#[test]
fn unknown_and_missing_keys_are_named() {
    let original = text("lt50m_C.toml");
    let e =
        Scene::from_toml(&original.replace("elements = 20", "elements = 20\nelement_count = 3"), "x.toml").unwrap_err();
    let msg = e.to_string();
    assert!(msg.starts_with("x.toml"), "{msg}");
    assert!(msg.contains("element_count"), "{msg}");

    let e = Scene::from_toml(&original.replace("youngs_modulus_pa = 1.2e11\n", ""), "y.toml").unwrap_err();
    let msg = e.to_string();
    assert!(msg.contains("youngs_modulus_pa"), "{msg}");
}

#[test]
fn scene_round_trips_through_toml() {
    let s = Scene::load(scene_path("lt50m_B.toml")).unwrap();
    let again = Scene::from_toml(&s.to_toml(), "round trip").unwrap();
    assert_eq!(s, again);
}

/// Arrays longer or shorter than their key needs are refused, naming the key (serde's own
/// fixed-size arrays would drop the extra values silently).
#[test]
fn arrays_of_the_wrong_length_are_refused_by_key() {
    let long: String = (0..1000).map(|i| format!("{i}.0")).collect::<Vec<_>>().join(", ");
    let cases = [
        ("position_m = [0.0, 0.0, 9.8]", "position_m = [0.0, 0.0, 9.8, 1.0]".to_string(), "pose.position_m"),
        ("position_m = [0.0, 0.0, 9.8]", "position_m = [0.0, 0.0]".to_string(), "pose.position_m"),
        ("position_m = [0.0, 0.0, 9.8]", format!("position_m = [{long}]"), "pose.position_m"),
        (
            "orientation_wxyz = [1.0, 0.0, 0.0, 0.0]",
            "orientation_wxyz = [1.0, 0.0, 0.0, 0.0, 0.0]".to_string(),
            "pose.orientation_wxyz",
        ),
        ("fit_modes = [1, 6]", "fit_modes = [1, 6, 7]".to_string(), "damping.fit_modes"),
        (
            "inertia_kg_m2 = [[266.4, 0.0, 0.0], [0.0, 266.4, 0.0], [0.0, 0.0, 360.0]]",
            "inertia_kg_m2 = [[266.4, 0.0, 0.0, 1.0], [0.0, 266.4, 0.0], [0.0, 0.0, 360.0]]".to_string(),
            "cabin.inertia_kg_m2",
        ),
        (
            "inertia_kg_m2 = [[266.4, 0.0, 0.0], [0.0, 266.4, 0.0], [0.0, 0.0, 360.0]]",
            "inertia_kg_m2 = [[266.4, 0.0, 0.0], [0.0, 266.4, 0.0], [0.0, 0.0, 360.0], [1.0, 1.0, 1.0]]".to_string(),
            "cabin.inertia_kg_m2",
        ),
        (
            "nominal_center_m = [0.0, 0.0, -1.8]",
            "nominal_center_m = [0.0, 0.0, -1.8, 0.0]".to_string(),
            "stewart.platform.nominal_center_m",
        ),
    ];
    for (from, to, key) in cases {
        let e = rejected(from, &to);
        let msg = e.to_string();
        assert_eq!(e.key, key, "{msg}");
        assert!(msg.contains("exactly 3") || msg.contains("exactly 4") || msg.contains("exactly 2"), "{msg}");
        assert!(msg.len() < 400, "the error quotes a short excerpt only: {} chars", msg.len());
    }
}

/// A parser error quotes a short, escaped excerpt of the offending line, not the line.
#[test]
fn parser_errors_quote_a_short_escaped_excerpt() {
    let original = text("lt50m_C.toml");
    let junk = format!("junk = \"{}", "x".repeat(1 << 20));
    let e =
        Scene::from_toml(&original.replace("elements = 20", &format!("elements = 20\n{junk}")), "j.toml").unwrap_err();
    let msg = e.to_string();
    // the junk line follows `elements = 20`
    let line = original.lines().position(|l| l == "elements = 20").unwrap() + 2;
    assert!(msg.len() < 400 && msg.contains(&format!("line {line}")), "{} chars: {}", msg.len(), &msg[..200]);
    let e =
        Scene::from_toml(&original.replace("elements = 20", "elements = 20\njunk = \"\x1b[31m"), "j.toml").unwrap_err();
    let msg = e.to_string();
    assert!(!msg.contains('\x1b'), "control characters are escaped: {msg}");
    assert!(msg.contains(&format!("line {line}")) && msg.contains("\\u{1b}"), "{msg}");
    // a value quoted in a type error is cut too
    let long = "y".repeat(10_000);
    let e =
        Scene::from_toml(&original.replace("mass_kg = 720.0", &format!("mass_kg = \"{long}\"")), "t.toml").unwrap_err();
    assert_eq!(e.key, "cabin.mass_kg");
    assert!(e.to_string().len() < 400, "{e}");
    // a duplicate key is named
    let e = Scene::from_toml(&original.replace("mass_kg = 720.0", "mass_kg = 720.0\nmass_kg = 720.0"), "d.toml")
        .unwrap_err();
    assert!(e.to_string().contains("mass_kg"), "{e}");
}

/// Newton tolerances outside [1e-14, 1e-6] and iteration limits outside [1, 1000] are refused.
#[test]
fn solver_settings_outside_their_range_are_refused() {
    for (to, key) in [
        ("newton_tol = 0.1", "solver.newton_tol"),
        ("newton_tol = 1e300", "solver.newton_tol"),
        ("newton_tol = 1e-5", "solver.newton_tol"),
        ("newton_tol = 1e-16", "solver.newton_tol"),
    ] {
        let e = rejected("newton_tol = 1e-10", to);
        assert_eq!(e.key, key);
        assert!(e.to_string().contains("1e-14") && e.to_string().contains("1e-6"), "{e}");
    }
    for to in ["newton_tol = 1e-14", "newton_tol = 1e-6"] {
        let edited = text("lt50m_C.toml").replace("newton_tol = 1e-10", to);
        Scene::from_toml(&edited, "ok.toml").unwrap();
    }
    let e = rejected("newton_max_iter = 25", "newton_max_iter = 1000000000");
    assert_eq!(e.key, "solver.newton_max_iter");
}

/// Only regular files are read, and never more than the limit: a device, a FIFO, a directory
/// or a large file is refused without reading it.
#[test]
fn only_regular_files_of_bounded_size_are_read() {
    use feedcore::scene::SceneErrorKind;
    let e = Scene::load("/dev/zero").unwrap_err();
    assert_eq!(e.kind, SceneErrorKind::Unreadable);
    assert!(e.to_string().contains("/dev/zero") && e.to_string().contains("not a regular file"), "{e}");
    let dir = std::env::temp_dir().join(format!("scene-files-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    assert!(Scene::load(&dir).unwrap_err().to_string().contains("not a regular file"));
    let fifo = dir.join("fifo.toml");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status().unwrap();
    assert!(made.success());
    let e = Scene::load(&fifo).unwrap_err();
    assert!(e.to_string().contains("not a regular file"), "{e}");
    let big = dir.join("big.toml");
    std::fs::write(&big, text("lt50m_C.toml")).unwrap();
    let e = Scene::load_limited(&big, 1000).unwrap_err();
    assert_eq!(e.kind, SceneErrorKind::TooLarge { limit: 1000 });
    assert!(e.to_string().contains("limit of 1000 bytes"), "{e}");
    Scene::load_limited(&big, 1 << 20).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Where the physics gives a bound, a number beyond it is a mistake: angles beyond a turn,
/// positions beyond 1000 km, a sensor faster than 1 MHz or slower than one sample in 11.6 days,
/// a breaking load that is not positive; output quantities no command writes; a sensor key
/// given to a sensor that does not use it.
#[test]
fn values_beyond_engineering_bounds_are_refused_by_key() {
    let cases = [
        (
            "angle_deg = [20.0, 80.0, 140.0, 200.0, 260.0, 320.0]",
            "angle_deg = [1e300, 80.0, 140.0, 200.0, 260.0, 320.0]",
            "anchors.angle_deg[0]",
            "one turn",
        ),
        ("position_m = [0.0, 0.0, 9.8]", "position_m = [0.0, 0.0, 2e6]", "pose.position_m[2]", "1000 km"),
        ("elements = 20", "elements = 20\nbreaking_load_n = -5.0", "cables.breaking_load_n", "must be positive"),
        (
            r#"quantities = ["cabin_displacement", "cabin_rotation", "wrench"]"#,
            r#"quantities = ["cabin_displacement", "cable_tensions"]"#,
            "outputs.quantities",
            "no command writes its time history",
        ),
        (
            r#"quantities = ["cabin_displacement", "cabin_rotation", "wrench"]"#,
            r#"quantities = ["actuator_forces"]"#,
            "outputs.quantities",
            "with [control] only",
        ),
    ];
    for (from, to, key, why) in cases {
        let e = rejected(from, to);
        assert_eq!(e.key, key, "{e}");
        assert!(e.to_string().contains(why), "{e}");
    }
    let compensated = text("lt50m_C_sampled.toml");
    let edited = |from: &str, to: &str| {
        assert_eq!(compensated.matches(from).count(), 1, "{from}");
        Scene::from_toml(&compensated.replace(from, to), "edited.toml").unwrap_err()
    };
    for rate in ["5e-324", "5e10"] {
        let e = edited("sample_rate_hz = 50.0", &format!("sample_rate_hz = {rate}"));
        assert_eq!(e.key, "control.sample_rate_hz", "{e}");
        assert!(e.to_string().contains("1 MHz"), "{e}");
    }
    let ideal = "sensor = \"ideal\"\nseed = 1\n";
    let sampled = "sensor = \"sampled\"\nsample_rate_hz = 50.0\ndelay_s = 0.02\nnoise_m = 1e-4\nnoise_rad = 2e-5\nseed = 1\nbandwidth_hz = 0.5\n";
    let e = edited(sampled, ideal);
    assert_eq!(e.key, "control.seed", "{e}");
    assert!(e.to_string().contains("only used with sensor = \"sampled\""), "{e}");
    assert!(Scene::from_toml(&compensated.replace(sampled, "sensor = \"ideal\"\n"), "ok.toml").is_ok());
    // the feed's axis is a direction, what is compensated one of two words
    let feed = "feed_point_m = [0.0, 0.0, -0.3]";
    for axis in ["[0.0, 0.0, 0.0]", "[0.0, 1e300, 0.0]"] {
        let e = edited(feed, &format!("{feed}\nfeed_axis = {axis}"));
        assert_eq!(e.key, "control.feed_axis", "{e}");
        assert!(e.to_string().contains("unit vector"), "{e}");
    }
    let e = edited(feed, &format!("{feed}\ncompensate = \"tilt\""));
    assert!(e.to_string().contains("compensate") && e.to_string().contains("position"), "{e}");
    // the inertial unit: with the sampled sensor and its filter, every key checked by name
    let with_imu = compensated.clone()
        + "\n[control.imu]\nrate_hz = 100.0\naccel_noise_density = 6e-4\ngyro_noise_density = 4e-5\n";
    assert!(Scene::from_toml(&with_imu, "imu.toml").is_ok());
    for (text, key, why) in [
        (with_imu.replace(sampled, "sensor = \"ideal\"\n"), "control.imu", "sensor = \"sampled\""),
        (with_imu.replace("bandwidth_hz = 0.5\n", ""), "control.bandwidth_hz", "e.g. 2.0"),
        (with_imu.clone() + "accel_bias_m_s2 = [0.0, 1e3, 0.0]\n", "control.imu.accel_bias_m_s2[1]", "±100 m/s²"),
        (with_imu.replace("= 4e-5", "= -1.0"), "control.imu.gyro_noise_density", "must not be negative"),
        (with_imu.replace("rate_hz = 100.0", "rate_hz = 0.0"), "control.imu.rate_hz", "positive"),
        // the filter's own noise model
        (
            with_imu.clone() + "[control.imu.filter]\nfix_noise_m = -1e-3\n",
            "control.imu.filter.fix_noise_m",
            "must not be negative",
        ),
        (
            with_imu.clone() + "[control.imu.filter]\ngyro_bias_rad_s = 20.0\n",
            "control.imu.filter.gyro_bias_rad_s",
            "0…10 rad/s",
        ),
        // the notch: its quality only with its frequency, which lies below half the command rate
        (
            compensated.replace("bandwidth_hz = 0.5\n", "bandwidth_hz = 0.5\nnotch_q = 2.0\n"),
            "control.notch_q",
            "notch_hz",
        ),
        (
            compensated.replace("bandwidth_hz = 0.5\n", "bandwidth_hz = 0.5\nnotch_hz = 30.0\n"),
            "control.notch_hz",
            "25 Hz",
        ),
    ] {
        let e = Scene::from_toml(&text, "imu.toml").unwrap_err();
        assert_eq!(e.key, key, "{e}");
        assert!(e.to_string().contains(why), "{e}");
    }
    // the filter's model: the instruments' figures, each key given overriding its own
    let plain = Scene::from_toml(&with_imu, "imu.toml").unwrap();
    let c = plain.control.as_ref().unwrap();
    let m = c.fusion_model().unwrap();
    assert_eq!((m.accel_noise_density, m.gyro_noise_density, m.accel_bias_m_s2), (6e-4, 4e-5, 0.0));
    assert_eq!((m.fix_noise_m, m.fix_noise_rad), (c.noise_m, c.noise_rad));
    let own =
        Scene::from_toml(&(with_imu.clone() + "[control.imu.filter]\ngyro_noise_density = 1e-3\n"), "f.toml").unwrap();
    let o = own.control.as_ref().unwrap().fusion_model().unwrap();
    assert_eq!(o, feedcore::scene::FusionModel { gyro_noise_density: 1e-3, ..m });
    // written out in full it reads back as the same model
    let mut full = plain.to_scene();
    full.control.as_mut().unwrap().imu.as_mut().unwrap().filter = Some(m.as_filter());
    let back = Scene::from_toml(&full.to_toml(), "full.toml").unwrap();
    assert_eq!(back.control.as_ref().unwrap().fusion_model(), Some(m));
    let e = edited(feed, &format!("{feed}\nprediction_s = 0.1"));
    assert_eq!(e.key, "control.prediction_s", "{e}");
    assert!(e.to_string().contains("[control.imu]"), "{e}");
    let axis = Scene::from_toml(&compensated.replace(feed, &format!("{feed}\nfeed_axis = [0.0, 2.0, 0.0]")), "ok.toml");
    assert_eq!(axis.unwrap().control.as_ref().unwrap().feed_axis(), [0.0, 2.0, 0.0]);
}

/// Every scene shipped in `scenes/` is valid.
#[test]
fn every_shipped_scene_file_loads() {
    let dir = format!("{}/../scenes", env!("CARGO_MANIFEST_DIR"));
    let mut count = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
            count += 1;
        }
    }
    assert!(count >= 8, "{count} scenes in {dir}");
}

/// A scene's own step must take every sample of its sensors: a step longer than a quarter of the
/// shortest period (the sampled sensor's, or its inertial unit's when faster) is refused by the
/// scene check, naming `solver.dt_s`, the key that sets the period and the longest step that
/// works; a step exactly at the bound is accepted.
#[test]
fn a_step_the_sensors_cannot_take_is_refused_by_the_scene_check() {
    let sampled = text("lt50m_C_sampled.toml"); // 50 Hz, no inertial unit
    let fused = text("lt50m_C_compensated.toml"); // 50 Hz fused with a 100 Hz unit
    let step = "dt_s = 0.0025";
    assert_eq!(sampled.matches(step).count(), 1);
    assert_eq!(fused.matches(step).count(), 1);
    for (text, dt, key, most) in [
        (&sampled, "0.0051", "sample_rate_hz", "0.005"),
        (&sampled, "0.01", "sample_rate_hz", "0.005"),
        (&fused, "0.005", "imu.rate_hz", "0.0025"),
        (&fused, "0.0026", "imu.rate_hz", "0.0025"),
    ] {
        let e = Scene::from_toml(&text.replace(step, &format!("dt_s = {dt}")), "fast.toml").unwrap_err();
        assert_eq!((e.key.as_str(), e.value.as_str()), ("solver.dt_s", dt), "{e}");
        assert!(
            e.reason.contains(&format!("[control] {key}")) && e.reason.contains(&format!("at most {most} s")),
            "{e}"
        );
    }
    for (text, dt) in [(&sampled, "0.005"), (&fused, "0.0025"), (&fused, "0.001")] {
        Scene::from_toml(&text.replace(step, &format!("dt_s = {dt}")), "ok.toml").unwrap();
    }
    // the uncompensated reference: a sensor switched off bounds no step
    let sensor = "sensor = \"sampled\"\nsample_rate_hz = 50.0\ndelay_s = 0.02\nnoise_m = 1e-4\nnoise_rad = 2e-5\nseed = 1\nbandwidth_hz = 0.5\n";
    assert_eq!(sampled.matches(sensor).count(), 1);
    let off = sampled.replace(step, "dt_s = 0.01").replace(sensor, "sensor = \"off\"\n");
    Scene::from_toml(&off, "off.toml").unwrap();
}
