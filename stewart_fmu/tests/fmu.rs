//! The FMU adapter (called in-process through the `fmi::Model` trait) against the library and
//! against central differences.

use feedcore::scene::{Scene, ValidScene};
use fmi::ModelInfo;
use fmi::export::Model;
use stewart::{CabinMotion, Stewart};
use stewart_fmu::{INPUTS, StewartFmu, vr};

fn scene(name: &str) -> ValidScene {
    if std::path::Path::new(name).is_absolute() {
        return Scene::load(name).unwrap();
    }
    Scene::load(format!("{}/../scenes/{name}", env!("CARGO_MANIFEST_DIR"))).unwrap()
}

/// Scene B with the feed held still by an ideal sensor ([control]): the platform follows the
/// cabin inputs, so every output depends on them. Written to a private file; its absolute path.
fn ideal_scene() -> String {
    let dir = std::env::temp_dir().join(format!("stewart-fmu-tests-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("lt50m_B_ideal.toml");
    let text = std::fs::read_to_string(format!("{}/../scenes/lt50m_B.toml", env!("CARGO_MANIFEST_DIR"))).unwrap()
        + "\n[control]\nfeed_point_m = [0.0, 0.0, -0.2]\ntarget = \"hold\"\nsensor = \"ideal\"\n";
    std::fs::write(&file, text).unwrap();
    file.display().to_string()
}

/// A moving, tilted, accelerating cabin near scene B's pose, as input values.
fn moving_inputs() -> [f64; INPUTS] {
    let q = feedcore::Quat::from_scaled_axis(feedcore::Vec3::new(0.6, 0.2, 0.05));
    [-2.8, 8.9, 16.1, q.w, q.i, q.j, q.k, 0.01, -0.02, 0.005, 0.01, -0.02, 0.03, 0.2, -0.1, 0.3, 0.05, 0.02, -0.04]
}

fn ready(scene: &str) -> StewartFmu {
    let mut m = StewartFmu::instantiate(None).unwrap();
    m.set_string(vr::SCENE, scene).unwrap();
    set_rest_pose(&mut m, scene);
    m.exit_initialization(0.0).unwrap();
    m
}

/// The importer's part: the cabin inputs at the scene's pose, at rest.
fn set_rest_pose(m: &mut StewartFmu, name: &str) {
    let s = scene(name);
    let (p, q) = (s.target_position(), s.target_orientation());
    for (k, x) in p.iter().chain([q.w, q.i, q.j, q.k].iter()).enumerate() {
        m.set_real(k as u32, *x).unwrap();
    }
    for k in 7..INPUTS as u32 {
        m.set_real(k, 0.0).unwrap();
    }
}

/// The description passes packaging's checks — the exporter's validation, and the
/// modelDescription.xml it writes reads back through the importer's parser as the description
/// — and every input declares a range that holds its start value.
#[test]
fn the_description_is_valid_and_reads_back_as_written() {
    let xml = fmi::package::checked_xml(&StewartFmu::description().unwrap()).unwrap();
    let back = fmi::xml::parse_model_description(&xml).unwrap();
    for v in back.variables.iter().filter(|v| v.causality == fmi::Causality::Input) {
        let Some(fmi::Value::Real(start)) = v.start else { panic!("{}: start {:?}", v.name, v.start) };
        assert!(v.min.is_some() && v.max.is_some() && v.outside_range(start).is_none(), "{}", v.name);
    }
}

#[test]
fn at_its_start_values_it_outputs_the_static_wrench() {
    for name in ["lt50m_B.toml", "lt50m_C.toml"] {
        let s = scene(name);
        let mut m = StewartFmu::instantiate(None).unwrap();
        m.set_string(vr::SCENE, name).unwrap();
        set_rest_pose(&mut m, name);
        m.set_real(vr::SPEED, 0.0).unwrap(); // platform held still
        m.exit_initialization(0.0).unwrap();
        let lib =
            Stewart::from_scene(&s).unwrap().static_wrench(&s.target_position(), &s.target_orientation()).unwrap();
        let w = lib.to_vector();
        for k in 0..6 {
            let got = m.get_real(vr::FORCE + k as u32).unwrap();
            assert!((got - w[k]).abs() <= 1e-9 * w.amax(), "{name} component {k}: {got} vs {}", w[k]);
        }
    }
}

#[test]
fn outputs_follow_the_library_at_every_step() {
    let s = scene("lt50m_B.toml");
    let lib = Stewart::from_scene(&s).unwrap();
    let mut m = ready("lt50m_B.toml");
    let u = moving_inputs();
    for (k, x) in u.iter().enumerate() {
        m.set_real(k as u32, *x).unwrap();
    }
    for step in 0..20 {
        m.do_step(0.01 * step as f64, 0.01).unwrap();
        let t = 0.01 * (step + 1) as f64;
        let q = feedcore::Quat::from_quaternion(nalgebra::Quaternion::new(u[3], u[4], u[5], u[6]));
        let v3 = |i: usize| feedcore::Vec3::new(u[i], u[i + 1], u[i + 2]);
        let cabin = CabinMotion {
            position: v3(0),
            orientation: q,
            velocity: v3(7),
            angular_velocity: v3(10),
            acceleration: v3(13),
            angular_acceleration: v3(16),
        };
        let e = lib.evaluate(&cabin, t).unwrap();
        let w = lib.wrench(&cabin, t).unwrap().to_vector();
        for k in 0..6 {
            assert_eq!(m.get_real(vr::FORCE + k as u32).unwrap(), w[k]);
            assert_eq!(m.get_real(vr::ACTUATOR + k as u32).unwrap(), e.actuator_forces[k]);
        }
        assert_eq!(m.get_real(vr::PLATFORM_R).unwrap(), e.platform.position.x);
    }
}

#[test]
fn step_map_derivatives_are_the_instantaneous_ones() {
    let mut m = ready("lt50m_B.toml");
    for (k, x) in moving_inputs().iter().enumerate() {
        m.set_real(k as u32, *x).unwrap();
    }
    m.do_step(0.0, 0.37).unwrap();
    let unknowns: Vec<u32> = (vr::FORCE..vr::RADIUS).collect();
    for k in 0..INPUTS as u32 {
        let (mut a, mut b) = (vec![0.0; unknowns.len()], vec![1.0; unknowns.len()]);
        m.directional_derivative(&unknowns, &[k], &[1.0], &mut a).unwrap();
        m.step_map_derivative(&unknowns, &[k], &[1.0], &mut b).unwrap();
        assert_eq!(a, b);
    }
}

/// FMI 2.0 semantics, pair by pair, at B, C and B compensated by an ideal sensor, in
/// initialization and step mode, at the rest
/// pose and at a moving, tilted cabin: declared pairs match central differences of
/// fmi2GetReal after fmi2SetReal, undeclared ones do not move, and every declared pair moves
/// somewhere.
#[test]
fn derivatives_and_dependencies_follow_the_standard() {
    let info = ModelInfo::new(StewartFmu::description().unwrap()).unwrap();
    let outputs: Vec<u32> = (vr::FORCE..vr::RADIUS).collect();
    let declared = |o: u32, i: u32, initial: bool| {
        let v = info.lookup(fmi::VarType::Real, o).unwrap();
        let deps = if initial { &v.initial_dependencies } else { &v.dependencies };
        deps.as_ref().unwrap().contains(&info.lookup(fmi::VarType::Real, i).unwrap().index)
    };
    let mut seen = std::collections::HashSet::new();
    let ideal = ideal_scene();
    for name in ["lt50m_C.toml", "lt50m_B.toml", ideal.as_str()] {
        for initial in [true, false] {
            for moving in [false, true] {
                let mut m = StewartFmu::instantiate(None).unwrap();
                m.set_string(vr::SCENE, name).unwrap();
                set_rest_pose(&mut m, name);
                if moving {
                    for (k, x) in moving_inputs().iter().enumerate() {
                        m.set_real(k as u32, *x).unwrap();
                    }
                }
                if !initial {
                    m.exit_initialization(0.0).unwrap();
                    m.do_step(0.0, 0.37).unwrap();
                }
                for i in 0..INPUTS as u32 {
                    let u0 = m.get_real(i).unwrap();
                    let eps = 1e-5;
                    let mut at = |u: f64| {
                        m.set_real(i, u).unwrap();
                        outputs.iter().map(|&o| m.get_real(o).unwrap()).collect::<Vec<_>>()
                    };
                    let (p, q, y) = (at(u0 + eps), at(u0 - eps), at(u0));
                    let mut d = vec![f64::NAN; outputs.len()];
                    m.directional_derivative(&outputs, &[i], &[1.0], &mut d).unwrap();
                    for (r, &o) in outputs.iter().enumerate() {
                        let fd = (p[r] - q[r]) / (2.0 * eps);
                        let what = format!("{name} init={initial} moving={moving}: d(vr {o})/d(vr {i})");
                        if declared(o, i, initial) {
                            let scale = d[r].abs().max(fd.abs()).max(1.0);
                            assert!((d[r] - fd).abs() <= 1e-6 * scale, "{what}: exact {:e}, fd {fd:e}", d[r]);
                            if d[r].abs() > 1e-9 {
                                seen.insert((initial, o, i));
                            }
                        } else {
                            // rounding only: a few ulps of the output
                            assert!((p[r] - q[r]).abs() <= 1e-13 * y[r].abs().max(1.0), "{what}: moves by {fd:e}");
                            assert_eq!(d[r], 0.0, "{what}");
                        }
                    }
                }
            }
        }
    }
    let mut idle = Vec::new();
    for initial in [true, false] {
        for &o in &outputs {
            for i in 0..INPUTS as u32 {
                if declared(o, i, initial) && !seen.contains(&(initial, o, i)) {
                    idle.push((initial, o, i));
                }
            }
        }
    }
    assert!(idle.is_empty(), "declared but never moving (initial, output vr, input vr): {idle:?}");
}

#[test]
fn directional_derivatives_match_central_differences() {
    let mut m = ready("lt50m_B.toml");
    let u = moving_inputs();
    for (k, x) in u.iter().enumerate() {
        m.set_real(k as u32, *x).unwrap();
    }
    m.do_step(0.0, 0.37).unwrap();
    let unknowns: Vec<u32> = (vr::FORCE..vr::RADIUS).collect();
    let outputs = |m: &mut StewartFmu| unknowns.iter().map(|v| m.get_real(*v).unwrap()).collect::<Vec<_>>();
    for k in 0..INPUTS {
        let mut analytic = vec![0.0; unknowns.len()];
        m.directional_derivative(&unknowns, &[k as u32], &[1.0], &mut analytic).unwrap();
        let eps = 1e-5;
        m.set_real(k as u32, u[k] + eps).unwrap();
        let p = outputs(&mut m);
        m.set_real(k as u32, u[k] - eps).unwrap();
        let q = outputs(&mut m);
        m.set_real(k as u32, u[k]).unwrap();
        for (i, a) in analytic.iter().enumerate() {
            let fd = (p[i] - q[i]) / (2.0 * eps);
            let scale = a.abs().max(fd.abs()).max(1.0);
            assert!((a - fd).abs() <= 1e-6 * scale, "input {k}, output {}: analytic {a:e}, FD {fd:e}", unknowns[i]);
        }
    }
}

#[test]
fn bad_inputs_and_parameters_are_refused_with_their_values() {
    let mut m = ready("lt50m_C.toml");
    for k in 3..7 {
        m.set_real(k, 0.0).unwrap();
    }
    let e = m.get_real(vr::FORCE).unwrap_err().to_string();
    assert!(e.contains("cabin.q") && e.contains("not a rotation"), "{e}");
    let e = m.set_integer(vr::START, 7).unwrap_err().to_string();
    assert!(e.contains("start = 7"), "{e}");
    // a circle too large for the legs: the model names the leg
    let mut m = StewartFmu::instantiate(None).unwrap();
    m.set_real(vr::RADIUS, 1.5).unwrap();
    let e = m.exit_initialization(0.0).unwrap_err().to_string();
    assert!(e.contains("leg"), "{e}");
}

/// Scene C with a `[control]` section appended, written to a private file; its absolute path.
fn controlled_scene(tag: &str, control: &str) -> String {
    let dir = std::env::temp_dir().join(format!("stewart-fmu-tests-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join(format!("lt50m_C_{tag}.toml"));
    let text = std::fs::read_to_string(format!("{}/../scenes/lt50m_C.toml", env!("CARGO_MANIFEST_DIR"))).unwrap()
        + "\n[control]\nfeed_point_m = [0.0, 0.0, -0.3]\ntarget = \"hold\"\n"
        + control;
    std::fs::write(&file, text).unwrap();
    file.display().to_string()
}

/// The cabin displaced by a few millimetres and turning slowly at step n.
fn displaced(n: usize) -> [f64; 7] {
    let s = n as f64 * 0.01;
    let q = feedcore::Quat::from_scaled_axis(feedcore::Vec3::new(1e-3 * s, -2e-3 * s, 5e-4));
    [0.003 * s.sin(), -0.002 * s, 9.8 + 0.001 * s, q.w, q.i, q.j, q.k]
}

/// A sampled sensor (delay, noise, filter), alone and fused with an inertial unit (its biases,
/// noise, the filter's readings and fixes in flight), keeps its state in the FMU state: a step
/// retaken after restoring a saved state gives the same outputs bit for bit.
#[test]
fn a_sampled_sensor_rolls_back_bit_exactly() {
    let sampled = "sensor = \"sampled\"\nsample_rate_hz = 25.0\ndelay_s = 0.03\nnoise_m = 1e-4\nnoise_rad = 1e-5\nseed = 9\nbandwidth_hz = 1.0\n";
    let fused = format!(
        "{sampled}prediction_s = 0.02\n[control.imu]\nrate_hz = 25.0\naccel_noise_density = 1e-3\ngyro_noise_density = \
         3e-5\naccel_bias_m_s2 = [0.01, 0.0, -0.02]\naccel_bias_walk = 1e-4\ngyro_bias_walk = 1e-6\nseed = 4\n"
    );
    for (tag, control) in [("sampled", sampled.to_string()), ("fused", fused)] {
        let name = controlled_scene(tag, &control);
        let mut m = ready(&name);
        let outputs: Vec<u32> = (vr::FORCE..vr::RADIUS).collect();
        let step = |m: &mut StewartFmu, n: usize| {
            for (k, x) in displaced(n + 1).iter().enumerate() {
                m.set_real(k as u32, *x).unwrap();
            }
            // a cabin accelerating and turning, for the inertial unit to read
            let s = (n + 1) as f64 * 0.01;
            for (k, x) in
                [0.003 * s.cos(), -0.002, 0.001, 1e-3, -2e-3, 0.0, -0.003 * s.sin(), 0.0, 0.0].iter().enumerate()
            {
                m.set_real(vr::V + k as u32, *x).unwrap();
            }
            m.do_step(n as f64 * 0.01, 0.01).unwrap();
            outputs.iter().map(|&o| m.get_real(o).unwrap()).collect::<Vec<_>>()
        };
        for n in 0..20 {
            step(&mut m, n);
        }
        let saved = serde_json::to_string(&m.save().unwrap()).unwrap();
        let first: Vec<Vec<f64>> = (20..40).map(|n| step(&mut m, n)).collect();
        m.restore(serde_json::from_str(&saved).unwrap()).unwrap();
        let again: Vec<Vec<f64>> = (20..40).map(|n| step(&mut m, n)).collect();
        assert_eq!(first, again, "{tag}");
        // the platform moved to compensate: its legs changed
        let legs = |o: &Vec<f64>| o[(vr::LEG - vr::FORCE) as usize];
        assert!((legs(&first[19]) - legs(&step(&mut ready(&name), 0))).abs() > 1e-4, "{tag}");
        // a step longer than a quarter sample period is refused, naming the key
        let e = ready(&name).do_step(0.0, 0.02).unwrap_err().to_string();
        assert!(e.contains("sample_rate_hz") && e.contains("0.01"), "{tag}: {e}");
    }
}

/// An ideal sensor puts the feed on its target whatever the cabin does: zero error, to rounding.
#[test]
fn an_ideal_sensor_holds_the_feed_on_its_target() {
    let name = controlled_scene("ideal", "sensor = \"ideal\"\n");
    let mut m = ready(&name);
    for n in 0..5 {
        for (k, x) in displaced(n * 10).iter().enumerate() {
            m.set_real(k as u32, *x).unwrap();
        }
        m.do_step(n as f64 * 0.01, 0.01).unwrap();
        for k in 0..3 {
            let e = m.get_real(vr::FEED_ERR + k).unwrap();
            assert!(e.abs() < 1e-14, "step {n}: feed error {k} = {e:e} m");
        }
    }
}

/// The platform's relative motion, kept from one evaluation to the next at the same time and
/// command point, is never stale: a step retaken from a saved state with other cabin inputs, or
/// after the platform's speed changed, gives what a fresh instance gives, bit for bit.
#[test]
fn a_retaken_step_computes_what_a_fresh_instance_does() {
    let name = "lt50m_B.toml";
    let outputs: Vec<u32> = (vr::FORCE..vr::RADIUS).collect();
    let u1 = moving_inputs();
    let mut u2 = u1;
    u2[vr::A as usize] += 0.05;
    u2[vr::W as usize + 1] -= 0.01;
    let step = |m: &mut StewartFmu, u: &[f64; INPUTS], speed: Option<f64>| {
        if let Some(s) = speed {
            m.set_real(vr::SPEED, s).unwrap();
        }
        for (k, x) in u.iter().enumerate() {
            m.set_real(k as u32, *x).unwrap();
        }
        m.do_step(0.3, 0.01).unwrap();
        let mut d = [0.0; 6];
        let wrench: Vec<u32> = (vr::FORCE..vr::ACTUATOR).collect();
        m.step_map_derivative(&wrench, &[vr::A], &[1.0], &mut d).unwrap();
        let values: Vec<f64> = outputs.iter().map(|&o| m.get_real(o).unwrap()).collect();
        (values, d)
    };
    let fresh = |u: &[f64; INPUTS], speed: Option<f64>| {
        let mut m = ready(name);
        m.do_step(0.0, 0.3).unwrap();
        step(&mut m, u, speed)
    };
    let mut m = ready(name);
    m.do_step(0.0, 0.3).unwrap();
    let saved = serde_json::to_string(&m.save().unwrap()).unwrap();
    let first = step(&mut m, &u1, None);
    assert_eq!(first, fresh(&u1, None));
    m.restore(serde_json::from_str(&saved).unwrap()).unwrap();
    let again = step(&mut m, &u2, None);
    assert_eq!(again, fresh(&u2, None));
    assert_ne!(again.0, first.0);
    m.restore(serde_json::from_str(&saved).unwrap()).unwrap();
    let faster = step(&mut m, &u2, Some(0.8));
    assert_eq!(faster, fresh(&u2, Some(0.8)));
    assert_ne!(faster.0[(vr::LEG - vr::FORCE) as usize], again.0[(vr::LEG - vr::FORCE) as usize]);
}
