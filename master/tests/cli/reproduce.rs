//! The paper side by side (docs/reproduction.md): the momentum-consistent start in the
//! co-simulation against the monolithic model, and `master reproduce`.

use crate::common;

use feedcore::scene::Start;
use master::cosim::{Extrapolation, JacobianUpdate, Options, Relaxation, Scheme};
use master::simulate::{Method, simulate};

fn ijcsa() -> Method {
    Method::Cosim(Options {
        scheme: Scheme::Ijcsa,
        extrapolation: Extrapolation::Constant,
        relaxation: Relaxation::Fixed(0.5),
        jacobian: JacobianUpdate::EveryStep,
        tol: 1e-8,
        max_iter: 100,
        ..Options::default()
    })
}

/// With `start = "consistent"` the cable FMU starts the cabin with the recoil velocity the
/// monolithic model gives it: IJCSA follows the monolithic model, and the gap is a start-up
/// error of the co-simulation that shrinks with the step (the cable FMU's first acceleration
/// is taken under the static wrench, without the platform's inertia), far below the change the
/// start makes.
#[test]
fn the_consistent_start_agrees_between_ijcsa_and_the_monolithic_model() {
    let (abrupt, abrupt_file) = common::scene("lt50m_C.toml", "start-abrupt", |_| {});
    let (scene, file) = common::scene("lt50m_C.toml", "start-consistent", |s| s.motion.start = Start::Consistent);
    let t_end = 2.0;
    let run = |m: Method, h: f64| simulate(&scene, &file, m, h, t_end, true).unwrap();
    let reference = simulate(&abrupt, &abrupt_file, Method::Monolithic, 0.01, t_end, true).unwrap();
    let (mono, mono_fine) = (run(Method::Monolithic, 0.01), run(Method::Monolithic, 0.0025));
    let (nj, nj_fine) = (run(ijcsa(), 0.01), run(ijcsa(), 0.0025));
    let effect = mono.error_against(&reference).0;
    let (gap, gap_fine) = (nj.error_against(&mono).0, nj_fine.error_against(&mono_fine).0);
    eprintln!(
        "consistent − abrupt start {effect:.3e} mm; ijcsa − monolithic {gap:.3e} mm at h, {gap_fine:.3e} mm at h/4"
    );
    assert!(effect > 0.05, "the start changes the response by {effect} mm");
    assert!(gap <= 0.25 * effect);
    assert!(gap_fine <= gap / 3.0, "first order in h: {gap:e} → {gap_fine:e}");
}
