//! The tick algorithms on their own: 1-2-5 steps on linear axes, decades on log axes.

use master::plot::ticks::{Step, linear_ticks, log_auto_range, log_axis_ticks, log_decades};

fn close(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() <= 1e-12 * (1.0 + y.abs()))
}

#[test]
fn the_brief_examples() {
    let (t, step) = linear_ticks(0.13, 0.87, 6);
    assert!(close(&t, &[0.2, 0.4, 0.6, 0.8]), "{t:?}");
    assert_eq!(step, Step { mantissa: 2, exponent: -1 });
    // Tick values are the doubles nearest to the decimals (0.6, not 0.6000000000000001).
    assert_eq!(t, vec![0.2, 0.4, 0.6, 0.8]);

    let (lo, hi) = log_auto_range(3e-4, 2e1, 0.04);
    assert_eq!((lo, hi), (-4.0, 2.0));
    assert_eq!(log_decades(lo, hi), vec![-4, -3, -2, -1, 0, 1, 2]);
    let ticks = log_axis_ticks(lo, hi, 420.0, 8);
    let labelled: Vec<f64> = ticks.iter().filter(|t| t.label.is_some()).map(|t| t.pos).collect();
    assert_eq!(labelled, vec![-4.0, -3.0, -2.0, -1.0, 0.0, 1.0, 2.0]);
    let l = ticks[0].label.as_ref().unwrap();
    assert_eq!((l.text.as_str(), l.sup.as_deref()), ("10", Some("−4")));
    // 70 px per decade: minor ticks at 2…9 × 10^d, eight per decade.
    assert_eq!(ticks.iter().filter(|t| t.label.is_none()).count(), 6 * 8);
}

#[test]
fn more_linear_examples() {
    assert!(close(&linear_ticks(0.0, 100.0, 11).0, &[0., 10., 20., 30., 40., 50., 60., 70., 80., 90., 100.]));
    assert!(close(&linear_ticks(0.0, 100.0, 6).0, &[0., 20., 40., 60., 80., 100.]));
    assert!(close(&linear_ticks(-0.83, 0.77, 6).0, &[-0.5, 0.0, 0.5]));
    assert!(close(&linear_ticks(-0.83, 0.77, 9).0, &[-0.8, -0.6, -0.4, -0.2, 0.0, 0.2, 0.4, 0.6]));
    assert!(close(&linear_ticks(1e-7, 9e-7, 5).0, &[2e-7, 4e-7, 6e-7, 8e-7]));
    assert!(close(&linear_ticks(12_345.0, 12_355.0, 6).0, &[12_346.0, 12_348.0, 12_350.0, 12_352.0, 12_354.0]));
}

/// A deterministic pseudo-random sequence in [0, 1).
fn lcg(state: &mut u64) -> f64 {
    *state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    (*state >> 11) as f64 / (1u64 << 53) as f64
}

#[test]
fn linear_ticks_are_inside_few_enough_nice_and_the_finest_such() {
    let mut s = 7;
    for _ in 0..5000 {
        let centre = (lcg(&mut s) - 0.5) * 10f64.powf(12.0 * lcg(&mut s) - 6.0);
        let span = 10f64.powf(10.0 * lcg(&mut s) - 5.0);
        let (lo, hi) = (centre - span * lcg(&mut s), centre + span * lcg(&mut s) + 1e-3 * span);
        let max = 2 + (lcg(&mut s) * 10.0) as usize;
        let (t, step) = linear_ticks(lo, hi, max);
        let sv = step.value();
        assert!([1, 2, 5].contains(&step.mantissa));
        assert!(t.len() <= max, "[{lo}, {hi}] max {max}: {t:?}");
        assert!(!t.is_empty(), "[{lo}, {hi}] max {max}: no ticks");
        for (i, &v) in t.iter().enumerate() {
            assert!(v >= lo - 1e-9 * sv && v <= hi + 1e-9 * sv, "[{lo}, {hi}]: {v} outside");
            let k = v / sv;
            // v / step carries the rounding error of v, relative to its size.
            assert!((k - k.round()).abs() < 1e-6 + 1e-12 * k.abs(), "{v} is not a multiple of {sv}");
            if i > 0 {
                assert!(((v - t[i - 1]) / sv - 1.0).abs() < 1e-6 + 1e-12 * k.abs(), "uneven: {t:?}");
            }
        }
        // The next finer 1-2-5 step would put more than `max` ticks in the range.
        let finer = match step.mantissa {
            1 => 0.5 * sv,
            2 => 0.5 * sv,
            _ => 0.4 * sv,
        };
        let n_finer = ((hi / finer + 1e-9).floor() - (lo / finer - 1e-9).ceil()) as i64 + 1;
        assert!(n_finer > max as i64, "[{lo}, {hi}] max {max}: step {sv} but {finer} gives {n_finer}");
    }
}

#[test]
fn log_ticks_thin_out_over_many_decades() {
    let ticks = log_axis_ticks(-12.0, 2.0, 300.0, 5);
    let labelled: Vec<f64> = ticks.iter().filter(|t| t.label.is_some()).map(|t| t.pos).collect();
    assert!(labelled.len() <= 5 && labelled.len() >= 3, "{labelled:?}");
    assert!(labelled.contains(&0.0), "10^0 is labelled: {labelled:?}");
    let gaps: Vec<f64> = labelled.windows(2).map(|w| w[1] - w[0]).collect();
    assert!(gaps.iter().all(|&g| g == gaps[0]), "evenly thinned: {labelled:?}");
    // Every decade keeps a tick mark; 21 px per decade is too tight for minor ticks.
    assert_eq!(ticks.len(), 15);
}

#[test]
fn narrow_log_ranges_fall_back_to_readable_labels() {
    // [2, 8]: labels at 2 and 5, minor marks at 3, 4, 6, 7, 8.
    let ticks = log_axis_ticks(2f64.log10(), 8f64.log10(), 300.0, 6);
    let labels: Vec<String> = ticks.iter().filter_map(|t| t.label.as_ref().map(|l| l.text.clone())).collect();
    assert_eq!(labels, ["2", "5"]);
    assert_eq!(ticks.iter().filter(|t| t.label.is_none()).count(), 5);
    // [2.1, 4.9]: no 1, 2 or 5 inside, so linear ticks in value space.
    let ticks = log_axis_ticks(2.1f64.log10(), 4.9f64.log10(), 300.0, 6);
    assert!(ticks.len() >= 2);
    for t in &ticks {
        let l = t.label.as_ref().unwrap();
        let v: f64 = l.text.parse().unwrap();
        assert!((v.log10() - t.pos).abs() < 1e-12 && (2.1..=4.9).contains(&v), "{l:?} at {}", t.pos);
    }
}

#[test]
fn log_auto_range_pads_a_narrow_span_instead_of_jumping_decades() {
    let (lo, hi) = log_auto_range(0.9, 1.1, 0.04);
    let span = 1.1f64.log10() - 0.9f64.log10();
    assert!((lo - (0.9f64.log10() - 0.04 * span)).abs() < 1e-12);
    assert!((hi - (1.1f64.log10() + 0.04 * span)).abs() < 1e-12);
    // Data ending on decades are padded, not pushed a whole decade out.
    let (lo, hi) = log_auto_range(1e-3, 1e1, 0.04);
    assert!((lo - (-3.16)).abs() < 1e-12 && (hi - 1.16).abs() < 1e-12, "[{lo}, {hi}]");
    // One end near a decade, the other far from it.
    let (lo, hi) = log_auto_range(1.1e-3, 5.0, 0.04);
    assert!((lo - (1.1e-3f64.log10() - 0.04 * (5.0f64 / 1.1e-3).log10())).abs() < 1e-12 && hi == 1.0, "[{lo}, {hi}]");
    // Constant data: half a decade each side.
    assert_eq!(log_auto_range(1e-3, 1e-3, 0.04), (-3.5, -2.5));
}
