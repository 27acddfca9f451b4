//! A tiny benchmark harness for `harness = false` bench targets: warm up, then report the
//! median and the spread of repeated timings. No dependencies; good enough to compare kernels.

use std::time::Instant;

/// Times `f` (one call = one unit of work): runs it for about `budget_s` seconds in batches
/// and prints the median time per call with the interquartile range. Returns the median (s).
pub fn bench<R>(name: &str, budget_s: f64, mut f: impl FnMut() -> R) -> f64 {
    // calibrate a batch to about 10 ms
    let mut batch = 1usize;
    loop {
        let t = Instant::now();
        for _ in 0..batch {
            std::hint::black_box(f());
        }
        let e = t.elapsed().as_secs_f64();
        if e > 0.01 || batch > 1 << 30 {
            break;
        }
        batch *= 2;
    }
    let mut samples = Vec::new();
    let start = Instant::now();
    while samples.len() < 5 || (start.elapsed().as_secs_f64() < budget_s && samples.len() < 1000) {
        let t = Instant::now();
        for _ in 0..batch {
            std::hint::black_box(f());
        }
        samples.push(t.elapsed().as_secs_f64() / batch as f64);
    }
    samples.sort_by(f64::total_cmp);
    let q = |p: f64| samples[((samples.len() - 1) as f64 * p).round() as usize];
    let (median, lo, hi) = (q(0.5), q(0.25), q(0.75));
    println!(
        "{name:<48} {:>12} per call  (IQR {} – {}, {} samples × {batch})",
        human(median),
        human(lo),
        human(hi),
        samples.len()
    );
    median
}

/// Seconds in a readable unit.
pub fn human(s: f64) -> String {
    if s < 1e-6 {
        format!("{:.1} ns", s * 1e9)
    } else if s < 1e-3 {
        format!("{:.2} µs", s * 1e6)
    } else if s < 1.0 {
        format!("{:.2} ms", s * 1e3)
    } else {
        format!("{s:.3} s")
    }
}
