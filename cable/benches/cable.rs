//! Hot kernels of the cable–cabin model on the LT50m scene C (20 elements per cable):
//! residual with tangent assembly, factorization, solve, one step, and 100 s simulated at
//! h = 0.01 s under a test wrench.

use cable::model::{CableCabin, Payload};
use cable::system::Coefficients;
use feedcore::benchkit::{bench, human};
use feedcore::scene::Scene;
use nalgebra::Vector6;

fn main() {
    let path = format!("{}/../scenes/lt50m_C.toml", env!("CARGO_MANIFEST_DIR"));
    let scene = Scene::load(&path).unwrap();
    let model = CableCabin::from_scene(&scene).unwrap();
    let sys = model.system(Payload::Locked);
    let cfg = model.equilibrium_config();
    let n = sys.dim();
    let (v, a) = (vec![1e-3; n], vec![1e-3; n]);
    let mut r = vec![0.0; n];
    let mut mat = sys.new_matrix();
    let w = Vector6::zeros();
    println!("cable–cabin model, {} unknowns ({} elements per cable)", n, scene.cables.elements);
    bench("residual (no matrix)", 1.0, || sys.residual(&cfg, &v, &a, &w, &mut r));
    let damping = sys.damping.clone().expect("the scene's model carries its damping");
    bench("  of which the damping force C·v (link form)", 1.0, || damping.mul_add(&v, &mut r));
    bench("  the same, as a plain chain matrix", 1.0, || damping.matrix().mul_add(&v, &mut r));
    bench("residual + tangent assembly", 1.0, || {
        sys.assemble(&cfg, &v, &a, &w, &mut r, Some((&mut mat, Coefficients::STIFFNESS)))
    });
    let mut factor = mat.factorize(false).unwrap();
    bench("factorization (chain elimination + 6×6 LU)", 1.0, || mat.factorize_into(false, &mut factor).unwrap());
    bench("solve with a kept factorization", 1.0, || factor.solve_in_place(&mut r));

    let wrench =
        |t: f64| Vector6::new(50.0 * (0.2 * t).sin(), 50.0 * (0.2 * t).cos(), 0.0, 0.0, 0.0, 5.0 * (1.3 * t).sin());
    let mut dy = model.dynamics(Payload::Locked, 0.0).unwrap();
    let (mut ext, seed) = (model.dynamics(Payload::External, 0.0).unwrap(), Vector6::new(1.0, 0.0, 0.0, 0.0, 0.0, 0.0));
    ext.step(0.01, &model.static_payload_wrench()).unwrap();
    ext.wrench_sensitivity(&seed, true).unwrap();
    bench("wrench sensitivity, factorization kept", 1.0, || ext.wrench_sensitivity(&seed, true).unwrap());
    bench("  the cabin's motion only (no tensions)", 1.0, || ext.wrench_sensitivity(&seed, false).unwrap());
    let mut t = 0.0;
    bench("one step h = 0.01 s (forced)", 1.0, || {
        t += 0.01;
        dy.step(0.01, &wrench(t)).unwrap()
    });
    let runs: Vec<f64> = (0..5)
        .map(|_| {
            let mut dy = model.dynamics(Payload::Locked, 0.0).unwrap();
            let start = std::time::Instant::now();
            for k in 1..=10_000 {
                dy.step(0.01, &wrench(0.01 * k as f64)).unwrap();
            }
            start.elapsed().as_secs_f64()
        })
        .collect();
    let mut sorted = runs.clone();
    sorted.sort_by(f64::total_cmp);
    println!(
        "{:<48} {:>12} median of {} runs (min {})",
        "100 s simulated at h = 0.01 s (forced)",
        human(sorted[2]),
        runs.len(),
        human(sorted[0])
    );
}
