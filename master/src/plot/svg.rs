//! Small helpers for writing SVG text: numbers with at most two decimals, escaped text.

use std::fmt;

/// A pixel coordinate written with at most two decimals and no trailing zeros (`12.5`, `-3`,
/// `0.07`), formatted without allocating. Values beyond ±1e9 are clamped; callers never write
/// non-finite values (they are filtered out before).
#[derive(Clone, Copy)]
pub struct Num(pub f64);

impl fmt::Display for Num {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = if self.0.is_finite() { self.0.clamp(-1e9, 1e9) } else { 0.0 };
        let hundredths = (v * 100.0).round() as i64;
        if hundredths == 0 {
            return f.write_str("0");
        }
        if hundredths < 0 {
            f.write_str("-")?;
        }
        let h = hundredths.unsigned_abs();
        write!(f, "{}", h / 100)?;
        let frac = h % 100;
        if frac != 0 {
            if frac.is_multiple_of(10) { write!(f, ".{}", frac / 10) } else { write!(f, ".{frac:02}") }
        } else {
            Ok(())
        }
    }
}

/// Text escaped for SVG character data and attribute values.
pub struct Esc<'a>(pub &'a str);

impl fmt::Display for Esc<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for c in self.0.chars() {
            match c {
                '&' => f.write_str("&amp;")?,
                '<' => f.write_str("&lt;")?,
                '>' => f.write_str("&gt;")?,
                '"' => f.write_str("&quot;")?,
                '\'' => f.write_str("&#39;")?,
                // Control characters other than tab and newline are not allowed in XML 1.0.
                c if c.is_control() && c != '\t' && c != '\n' => f.write_str("\u{FFFD}")?,
                c => fmt::Write::write_char(f, c)?,
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers() {
        let s = |v: f64| Num(v).to_string();
        assert_eq!(s(12.5), "12.5");
        assert_eq!(s(-3.0), "-3");
        assert_eq!(s(0.07), "0.07");
        assert_eq!(s(0.004), "0");
        assert_eq!(s(-0.004), "0");
        assert_eq!(s(-0.456), "-0.46");
        assert_eq!(s(99.999), "100");
        assert_eq!(s(f64::NAN), "0");
    }

    #[test]
    fn escaping() {
        assert_eq!(Esc("a<b & \"c\" 'd'>").to_string(), "a&lt;b &amp; &quot;c&quot; &#39;d&#39;&gt;");
        assert_eq!(Esc("x\u{1}y").to_string(), "x\u{FFFD}y");
        assert_eq!(Esc("Δx [mm]").to_string(), "Δx [mm]");
    }
}
