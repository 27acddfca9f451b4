//! A cable goes slack and taut again in the coupled system, and the monolithic model and IJCSA
//! agree through it.
//!
//! Scene C with the platform eight times heavier, circling 0.4 m off centre at 0.4 m/s: the
//! rotating weight unloads cable 5 until part of it goes slack, once a revolution (6.3 s), and
//! loads it again. Both methods carry the tension-only kink inside their cable model (the
//! monolithic model through the cable crate's assembly, IJCSA inside the cable FMU), with the
//! slack safeguards of the shared Newton controller.
//!
//! Tolerance: taken in one step, the first macro step leaves a first-order start-up defect of the
//! co-simulation (each FMU's first acceleration without the other's inertia, 8.2e-2 mm at h = 0.01
//! and 2.1e-2 mm at h/4); with the first macro step taken in substeps the gap is a floor that does not
//! depend on h (about 3e-4 mm, 2e-6 of the peak), nor on the interface tolerance (1e-8 and 1e-10
//! give the same) or the first substep (h/1024 and h/65536 too); its source is not found. What
//! "agree through it" means: (1) the gap stays below 1e-5 of the peak displacement at h and at h/4;
//! (2) the slack episodes do not widen it — the gap while cable 5 is slack is no larger than the
//! largest gap while it is taut.

use cable::element::Bar;
use feedcore::scene::Scene;
use monolithic::Monolithic;
use studies::cosim::{Options, Scheme};
use studies::simulate::{Method, simulate};
use studies::sweep::scale_platform_mass;

/// The platform `f` times heavier, on a circle of radius `r` at speed `v`.
fn heavier_and_wider(s: &mut Scene) {
    let (f, r, v) = (8.0, 0.4, 0.4);
    scale_platform_mass(s, f);
    s.motion.radius_m = r;
    s.motion.speed_m_s = v;
}

/// Smallest element force of cable `i` in the monolithic model now.
fn smallest_force(m: &Monolithic, i: usize) -> f64 {
    let (sys, cfg) = (m.cable_system(), m.cable_config());
    let k = sys.free_nodes();
    let mut points = vec![sys.net.anchors[i]];
    points.extend_from_slice(&cfg.nodes[i * k..i * k + k]);
    points.push(sys.attachment(cfg, i).0);
    points
        .windows(2)
        .map(|w| Bar::new(&(w[1] - w[0]), sys.net.spec.ea, sys.element_length[i]).force)
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn a_cable_goes_slack_and_taut_again_and_ijcsa_follows_the_monolithic_model() {
    let (scene, file) = crate::common::scene("lt50m_C.toml", "slack", heavier_and_wider);
    let (h, t_end): (f64, f64) = (0.01, 12.0);

    // the monolithic model at h and h/4, watching cable 5
    let watch = |h: f64| {
        let mut m = Monolithic::new(&scene).unwrap();
        let p0 = m.sample().cabin.position;
        let mut path = Vec::new();
        for _ in 0..(t_end / h).round() as usize {
            m.step(h).unwrap();
            let slack = smallest_force(&m, 5) == 0.0;
            path.push(((m.sample().cabin.position - p0) * 1e3, slack));
        }
        (path, smallest_force(&m, 5))
    };
    let (mono, taut_at_end) = watch(h);
    let (mono_fine, _) = watch(h / 4.0);
    let slack_steps = mono.iter().filter(|p| p.1).count();
    let episodes = mono.windows(2).filter(|w| w[1].1 && !w[0].1).count();
    eprintln!(
        "cable 5 slack in {slack_steps} steps, {episodes} episodes; smallest force at the end {taut_at_end:.1} N"
    );
    assert!(episodes >= 2 && slack_steps > 100, "cable 5 must go slack (twice)");
    assert!(taut_at_end > 0.0, "and be taut again");

    let options = Options { scheme: Scheme::Ijcsa, ..Options::default() };
    let run = |h: f64| simulate(&scene, &file, Method::Cosim(options), h, t_end).unwrap();
    let (ijcsa, ijcsa_fine) = (run(h), run(h / 4.0));
    // gaps at the common sample times (every 0.01 s), split by the state of cable 5
    let gaps = |ij: &studies::simulate::Trace, mono: &[(nalgebra::Vector3<f64>, bool)], per: usize| {
        let (mut slack, mut taut) = (0.0f64, 0.0f64);
        for (s, t) in ij.t.iter().enumerate().skip(1) {
            let k = (t / h).round() as usize;
            let (p, _) = mono[k * per - 1];
            let gap = (0..3).map(|i| (ij.disp_mm[s][i] - p[i]).powi(2)).sum::<f64>().sqrt();
            if mono[k * per - 1].1 { slack = slack.max(gap) } else { taut = taut.max(gap) }
        }
        (slack, taut)
    };
    let (slack, taut) = gaps(&ijcsa, &mono, 1);
    let (slack_fine, taut_fine) = gaps(&ijcsa_fine, &mono_fine, 4);
    let peak = mono.iter().map(|p| p.0.norm()).fold(0.0, f64::max);
    eprintln!(
        "ijcsa − monolithic at h: {slack:.3e} mm slack, {taut:.3e} mm taut; at h/4: {slack_fine:.3e} / {taut_fine:.3e} mm; peak {peak:.1} mm; {:.2} IJCSA iterations per step",
        ijcsa.mean_iterations()
    );
    let (gap, gap_fine) = (slack.max(taut), slack_fine.max(taut_fine));
    assert!(gap <= 1e-5 * peak && gap_fine <= 1e-5 * peak, "{gap:e} mm at h, {gap_fine:e} mm at h/4, peak {peak} mm");
    assert!(slack <= taut, "the slack episodes widen the gap: {slack:e} mm against {taut:e} mm while taut");
}
