//! Tick positions and labels: 1-2-5 steps on linear axes, decades (with minor ticks at 2…9) on
//! log axes.
//!
//! Positions are returned in *axis coordinates*: the value itself on a linear axis, `log10` of
//! the value on a log axis, so that the renderer maps both the same way.

/// Tick label text, with an optional superscript (`10⁻⁴` is `"10"` + `"−4"`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Label {
    pub text: String,
    pub sup: Option<String>,
}

impl Label {
    pub fn plain(text: impl Into<String>) -> Self {
        Self { text: text.into(), sup: None }
    }

    /// Estimated rendered width in pixels at font size `size_px` (no font metrics are available,
    /// so this errs on the wide side for DejaVu Sans / Helvetica).
    pub fn width_px(&self, size_px: f64) -> f64 {
        text_width_px(&self.text, size_px) + self.sup.as_deref().map_or(0.0, |s| text_width_px(s, SUP_SCALE * size_px))
    }
}

/// Superscripts are drawn at this fraction of the label's font size.
pub const SUP_SCALE: f64 = 0.75;

/// Estimated width of `text` in pixels at font size `size_px`, from per-class advance widths
/// of DejaVu Sans (the widest of the usual sans-serif fonts).
pub fn text_width_px(text: &str, size_px: f64) -> f64 {
    let em: f64 = text
        .chars()
        .map(|c| match c {
            '0'..='9' => 0.64,
            ' ' | '.' | ',' | ':' | ';' | '!' | '|' | 'i' | 'l' | 'j' | '\'' => 0.32,
            '(' | ')' | '[' | ']' | 'f' | 't' | 'r' => 0.4,
            'm' | 'w' | 'M' | 'W' | '%' => 0.95,
            '−' | '×' | '+' | '=' | '<' | '>' => 0.84,
            c if c.is_uppercase() => 0.72,
            c if c.is_ascii() => 0.6,
            _ => 0.8,
        })
        .sum();
    em * size_px
}

/// One tick on an axis.
#[derive(Clone, Debug, PartialEq)]
pub struct Tick {
    /// Position in axis coordinates (value, or log10 of the value on a log axis).
    pub pos: f64,
    /// `None` for a minor tick (short mark, faint grid line, no label).
    pub label: Option<Label>,
}

/// The nice step chosen by [`linear_ticks`]: `mantissa × 10^exponent`, mantissa ∈ {1, 2, 5}.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Step {
    pub mantissa: i64,
    pub exponent: i32,
}

impl Step {
    pub fn value(self) -> f64 {
        scaled(self.mantissa, self.exponent)
    }
}

/// `n × 10^e`, rounded once (dividing by an exact power of ten for e < 0 gives the double
/// nearest to the decimal, e.g. 3 / 10 = 0.3, where 3 × 0.1 would not).
fn scaled(n: i64, e: i32) -> f64 {
    if e >= 0 { n as f64 * 10f64.powi(e) } else { n as f64 / 10f64.powi(-e) }
}

/// Ticks at multiples of the smallest step 1, 2 or 5 × 10^k that puts at most `max_ticks` ticks
/// in `[lo, hi]`. Ticks lie inside the interval (a tick within 1e-9 of a step from an end counts
/// as inside). Example: `[0.13, 0.87]` with at most 6 ticks gives 0.2, 0.4, 0.6, 0.8.
///
/// Panics unless `lo < hi` are finite with `hi - lo` finite and at least 1e-290 (the renderer
/// guarantees it).
pub fn linear_ticks(lo: f64, hi: f64, max_ticks: usize) -> (Vec<f64>, Step) {
    assert!(drawable_span(lo, hi), "linear_ticks needs a finite range with lo < hi, got [{lo}, {hi}]");
    let max_ticks = max_ticks.max(1) as i64;
    let mut exponent = ((hi - lo) / max_ticks as f64).log10().floor() as i32 - 1;
    loop {
        for mantissa in [1, 2, 5] {
            let step = scaled(mantissa, exponent);
            if !(step > 0.0 && step.is_finite()) {
                continue; // below the smallest normal double: try a coarser step
            }
            // Counted in floating point: a step far too fine for the range cannot overflow.
            let first = (lo / step - 1e-9).ceil();
            let last = (hi / step + 1e-9).floor();
            if last - first < max_ticks as f64 {
                let ticks = (first as i64..=last as i64).map(|i| scaled(i * mantissa, exponent)).collect();
                return (ticks, Step { mantissa, exponent });
            }
        }
        exponent += 1;
    }
}

/// Whether `[lo, hi]` can be an axis range: finite, `lo < hi`, span finite and not below
/// 1e-290 (whose 1-2-5 steps would fall below the smallest normal double).
pub fn drawable_span(lo: f64, hi: f64) -> bool {
    lo.is_finite() && hi.is_finite() && (hi - lo).is_finite() && hi - lo >= 1e-290
}

/// Label for a tick of a linear axis whose step is `step` and whose largest |tick| is `max_abs`:
/// fixed-point with just enough decimals for the step, or `m×10^e` with one exponent shared by
/// the axis when the numbers are very large or very small.
pub fn linear_label(value: f64, step: Step, max_abs: f64) -> Label {
    if value == 0.0 || value.abs() < 1e-9 * step.value() {
        return Label::plain("0");
    }
    if max_abs >= 1e6 || step.exponent < -5 {
        let e = max_abs.log10().floor() as i32;
        let decimals = (e - step.exponent).max(0) as usize;
        let mantissa = value / 10f64.powi(e);
        return Label {
            text: format!("{}×10", minus(&format!("{mantissa:.decimals$}"))),
            sup: Some(minus(&e.to_string())),
        };
    }
    let decimals = (-step.exponent).max(0) as usize;
    Label::plain(minus(&format!("{value:.decimals$}")))
}

/// Label `10^d` for a decade tick.
pub fn decade_label(d: i32) -> Label {
    Label { text: "10".into(), sup: Some(minus(&d.to_string())) }
}

/// Label for an arbitrary value (ticks placed by the caller): at most six significant digits,
/// fixed-point between 1e-4 and 1e6, `m×10^e` outside.
pub fn value_label(value: f64) -> Label {
    if value == 0.0 {
        return Label::plain("0");
    }
    let rounded: f64 = format!("{value:.5e}").parse().unwrap_or(value);
    let a = rounded.abs();
    if (1e-4..1e6).contains(&a) {
        return Label::plain(minus(&rounded.to_string()));
    }
    let s = format!("{rounded:e}");
    let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
    Label { text: format!("{}×10", minus(m)), sup: Some(minus(e)) }
}

/// Typographic minus sign instead of the hyphen.
fn minus(s: &str) -> String {
    s.replace('-', "−")
}

/// Decade exponents `d` with `10^d` in `[10^lo, 10^hi]` (axis coordinates `lo`, `hi`).
pub fn log_decades(lo: f64, hi: f64) -> Vec<i32> {
    let first = (lo - 1e-9).ceil() as i32;
    let last = (hi + 1e-9).floor() as i32;
    (first..=last).collect()
}

/// Auto range of a log axis for data in `[min, max]` (both > 0), in axis coordinates (log10).
/// When the data span a decade or more, each end is widened to the next whole decade
/// (`[3e-4, 2e1]` → `[1e-4, 1e2]`), unless the data come closer to it than `pad` of the span
/// (data ending on a decade would put markers on the frame): that end is padded by `pad` of
/// the span instead. Narrower data are padded by `pad` on both ends.
pub fn log_auto_range(min: f64, max: f64, pad: f64) -> (f64, f64) {
    log_auto_range_axis(min.log10(), max.log10(), pad)
}

/// [`log_auto_range`] for data already in axis coordinates (`a = log10(min)`, `b = log10(max)`).
pub fn log_auto_range_axis(a: f64, b: f64, pad: f64) -> (f64, f64) {
    let p = pad * (b - a);
    if b - a >= 1.0 {
        let lo = if a - a.floor() >= p { a.floor() } else { a - p };
        let hi = if b.ceil() - b >= p { b.ceil() } else { b + p };
        (lo, hi)
    } else if b > a {
        (a - p, b + p)
    } else {
        (a - 0.5, a + 0.5)
    }
}

/// Ticks of a linear axis over `[lo, hi]` with at most `max_labels` labelled ticks.
pub fn linear_axis_ticks(lo: f64, hi: f64, max_labels: usize) -> Vec<Tick> {
    let (values, step) = linear_ticks(lo, hi, max_labels);
    let max_abs = values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    values.into_iter().map(|v| Tick { pos: v, label: Some(linear_label(v, step, max_abs)) }).collect()
}

/// Ticks of a log axis over axis coordinates `[lo, hi]` drawn `length_px` long, with at most
/// `max_labels` labelled ticks.
///
/// * Two or more decades in range: every decade gets a tick, every k-th a label so that at most
///   `max_labels` are labelled; minor ticks at 2…9 × 10^d where a decade is at least 30 px long.
/// * Fewer: labels at 1, 2 and 5 × 10^d, or, if even those are fewer than two, linear 1-2-5
///   ticks in value space (a narrow log axis looks and reads like a linear one).
pub fn log_axis_ticks(lo: f64, hi: f64, length_px: f64, max_labels: usize) -> Vec<Tick> {
    let inside = |p: f64| p >= lo - 1e-9 && p <= hi + 1e-9;
    let decades = log_decades(lo, hi);
    let px_per_decade = length_px / (hi - lo);
    if decades.len() >= 2 {
        let every = decades.len().div_ceil(max_labels.max(1)) as i32;
        // Label the decades that are multiples of `every` (so 10^0 is labelled if present).
        let mut ticks: Vec<Tick> = decades
            .iter()
            .map(|&d| Tick { pos: f64::from(d), label: (d.rem_euclid(every) == 0).then(|| decade_label(d)) })
            .collect();
        if px_per_decade >= 30.0 {
            for d in (lo.floor() as i32)..=(hi.ceil() as i32) {
                for m in 2..=9 {
                    let p = f64::from(d) + f64::from(m).log10();
                    if inside(p) {
                        ticks.push(Tick { pos: p, label: None });
                    }
                }
            }
        }
        return ticks;
    }
    let mut labelled = Vec::new();
    for d in (lo.floor() as i32)..=(hi.ceil() as i32) {
        for m in [1i64, 2, 5] {
            let p = f64::from(d) + (m as f64).log10();
            if inside(p) {
                labelled.push(Tick { pos: p, label: Some(value_label(scaled(m, d))) });
            }
        }
    }
    if labelled.len() >= 2 && labelled.len() <= max_labels.max(2) {
        for d in (lo.floor() as i32)..=(hi.ceil() as i32) {
            for m in [3, 4, 6, 7, 8, 9] {
                let p = f64::from(d) + f64::from(m).log10();
                if inside(p) && px_per_decade >= 30.0 {
                    labelled.push(Tick { pos: p, label: None });
                }
            }
        }
        return labelled;
    }
    let (vlo, vhi) = (10f64.powf(lo), 10f64.powf(hi));
    let (values, step) = linear_ticks(vlo, vhi, max_labels.max(2));
    let max_abs = values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    values
        .into_iter()
        .filter(|&v| v > 0.0)
        .map(|v| Tick { pos: v.log10(), label: Some(linear_label(v, step, max_abs)) })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scaled_is_the_nearest_double() {
        assert_eq!(scaled(3, -1), 0.3);
        assert_eq!(scaled(7, -2), 0.07);
        assert_eq!(scaled(25, 3), 25000.0);
    }

    #[test]
    fn labels() {
        let s = Step { mantissa: 2, exponent: -1 };
        assert_eq!(linear_label(0.4, s, 0.8).text, "0.4");
        assert_eq!(linear_label(-0.4, s, 0.8).text, "−0.4");
        assert_eq!(linear_label(1e-17, s, 0.8).text, "0");
        let big = Step { mantissa: 5, exponent: 6 };
        assert_eq!(linear_label(1.5e7, big, 2e7), Label { text: "1.5×10".into(), sup: Some("7".into()) });
        assert_eq!(decade_label(-4), Label { text: "10".into(), sup: Some("−4".into()) });
        assert_eq!(value_label(0.0025).text, "0.0025");
        assert_eq!(value_label(10.0).text, "10");
        assert_eq!(value_label(2.5e-7), Label { text: "2.5×10".into(), sup: Some("−7".into()) });
        assert_eq!(value_label(0.1 + 0.2).text, "0.3");
    }
}
