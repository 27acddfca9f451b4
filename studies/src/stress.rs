//! The long and the hard runs — 1000 s simulated, ten times stiffer cables, 50
//! elements per cable, the nearly slack cable at B, abrupt against smooth start, the platform held
//! still — each with what bounds it: drift, constraint residual, the response's growth, the
//! agreement of IJCSA with the monolithic model. (The cable-only and free-body stress tests are
//! in the test suite.)

use std::path::Path;

use feedcore::scene::{Scene, Start, ValidScene};

use crate::cosim::{Options, Scheme};
use crate::limits::Limits;
use crate::observe::Observer;
pub use crate::reproduce::Scenes;
use crate::simulate::{Method, Run, Trace};
use crate::table::Table;

/// Every case: its name, and its figures or why it failed.
pub struct Cases(pub Vec<(String, Result<String, String>)>);

impl Cases {
    /// How many cases failed.
    pub fn failures(&self) -> usize {
        self.0.iter().filter(|(_, r)| r.is_err()).count()
    }

    /// A row per case.
    pub fn table(&self) -> Table {
        let mut table = Table::new(["case", "result", "figures"]);
        for (case, r) in &self.0 {
            match r {
                Ok(figures) => table.row([case.clone(), "ok".into(), figures.clone()]),
                Err(e) => table.row([case.clone(), "FAILED".into(), e.clone()]),
            }
        }
        table
    }
}

fn ijcsa() -> Method {
    Method::Cosim(Options { scheme: Scheme::Ijcsa, ..Options::default() })
}

/// Peak |displacement| (mm) in the first and in the last third of a run.
fn thirds(t: &Trace) -> (f64, f64) {
    let n = t.disp_mm.len();
    let peak = |r: std::ops::Range<usize>| t.disp_mm[r].iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
    (peak(0..n / 3), peak(2 * n / 3..n))
}

/// RMS (mm) of the displacement's components above 0.2 Hz — the cabin's own modes (≥ 0.19 Hz)
/// on top of the 0.03 Hz response to the circle — from a Hann-windowed discrete Fourier
/// transform (the window keeps the large slow part from leaking upwards).
fn fast_part(t: &Trace) -> f64 {
    let n = t.disp_mm.len();
    let dt = t.t[1] - t.t[0];
    let hann: Vec<f64> =
        (0..n).map(|i| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / (n - 1) as f64).cos()).collect();
    let power: f64 = hann.iter().map(|w| w * w).sum::<f64>() / n as f64;
    let mut total = 0.0;
    for k in 0..3 {
        let x: Vec<f64> = (0..n).map(|i| t.disp_mm[i][k] * hann[i]).collect();
        for m in 1..n / 2 {
            if (m as f64) / (n as f64 * dt) < 0.2 {
                continue;
            }
            let (mut re, mut im) = (0.0, 0.0);
            let w = 2.0 * std::f64::consts::PI * m as f64 / n as f64;
            for (i, xi) in x.iter().enumerate() {
                let (s, c) = (w * i as f64).sin_cos();
                re += xi * c;
                im -= xi * s;
            }
            total += 2.0 * (re * re + im * im) / (n as f64 * n as f64);
        }
    }
    (total / power).sqrt()
}

/// Every case: scene C and scene B (each with its file), the durations divided by 50 when
/// `quick`, every run within `limits`. A case that fails is a result (its error), not a reason
/// to stop.
pub fn run(scenes: Scenes<'_>, quick: bool, limits: &Limits, observer: &dyn Observer) -> Cases {
    let Scenes { c, c_file, b, b_file } = scenes;
    let simulate = |s: &ValidScene, file: &Path, method: Method, t_end: f64| -> anyhow::Result<Trace> {
        Ok(Run::prepare(s, file, method, 0.01, t_end, limits)?.execute_watched(&mut *observer.watch())?)
    };
    let scale = if quick { 1.0 / 50.0 } else { 1.0 };
    // the durations run, as the labels say them (shortened with --quick)
    let long = |t: f64| crate::limits::num(t * scale);
    let short = |t: f64| crate::limits::num(t * scale.max(0.1));
    let mut cases = Vec::new();
    let mut report = |case: &str, r: anyhow::Result<String>| {
        cases.push((case.to_string(), r.map_err(|e| format!("{e:#}"))));
        observer.point(&format!("{case}: done"));
    };
    report(
        &format!("{} s, ijcsa, C", long(1000.0)),
        (|| {
            let t = simulate(c, c_file, ijcsa(), 1000.0 * scale)?;
            let (early, late) = thirds(&t);
            Ok(format!(
                "peak first third {early:.3} mm, last third {late:.3} mm; {:.2} iterations/step; {:.1} s wall",
                t.mean_iterations(),
                t.wall_time_s
            ))
        })(),
    );
    report(
        &format!("{} s, monolithic, C", long(1000.0)),
        (|| {
            let t = simulate(c, c_file, Method::Monolithic, 1000.0 * scale)?;
            let (early, late) = thirds(&t);
            Ok(format!(
                "constraint residual ≤ {:.1e} m; peak first third {early:.3} mm, last third {late:.3} mm; {:.1} s wall",
                t.constraint_residual(),
                t.wall_time_s
            ))
        })(),
    );
    for (case, edit) in [
        ("E × 10, C", &(|s: &mut Scene| s.cables.youngs_modulus_pa *= 10.0) as &dyn Fn(&mut Scene)),
        ("50 elements per cable, C", &|s: &mut Scene| s.cables.elements = 50),
    ] {
        report(
            &format!("{case}, {} s", short(20.0)),
            (|| {
                let (v, f) = (c.edited(edit)?, c_file);
                let m = simulate(&v, f, Method::Monolithic, 20.0 * scale.max(0.1))?;
                let j = simulate(&v, f, ijcsa(), 20.0 * scale.max(0.1))?;
                Ok(format!(
                    "peak {:.3} mm; ijcsa − monolithic {:.2e} mm; {:.2} iterations/step; constraint residual ≤ {:.1e} m",
                    m.peak_mm(),
                    j.error_against(&m).0,
                    j.mean_iterations(),
                    m.constraint_residual()
                ))
            })(),
        );
    }
    report(
        &format!("B: cable 4 nearly slack, ijcsa {} s", long(100.0)),
        (|| {
            let t = simulate(b, b_file, ijcsa(), 100.0 * scale)?;
            let (early, late) = thirds(&t);
            Ok(format!(
                "peak first third {early:.3} mm, last third {late:.3} mm; {:.2} iterations/step",
                t.mean_iterations()
            ))
        })(),
    );
    report(
        &format!("abrupt against ramp start (5 s), monolithic, C, {} s", short(60.0)),
        (|| {
            let a = simulate(c, c_file, Method::Monolithic, 60.0 * scale.max(0.1))?;
            let v = c.edited(|s| s.motion.start = Start::Ramp)?;
            let r = simulate(&v, c_file, Method::Monolithic, 60.0 * scale.max(0.1))?;
            Ok(format!(
                "vibration above 0.2 Hz (RMS): abrupt {:.2e} mm, ramp {:.2e} mm; peaks {:.3} / {:.3} mm",
                fast_part(&a),
                fast_part(&r),
                a.peak_mm(),
                r.peak_mm()
            ))
        })(),
    );
    report(
        &format!("platform held still, ijcsa and monolithic, B, {} s", long(100.0)),
        (|| {
            let v = b.edited(|s| s.motion.speed_m_s = 0.0)?;
            let j = simulate(&v, b_file, ijcsa(), 100.0 * scale)?;
            let m = simulate(&v, b_file, Method::Monolithic, 100.0 * scale)?;
            Ok(format!("drift: ijcsa {:.1e} mm, monolithic {:.1e} mm", j.peak_mm(), m.peak_mm()))
        })(),
    );
    Cases(cases)
}
