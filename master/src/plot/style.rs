//! Colours, markers and dash patterns.
//!
//! The default palette is Okabe & Ito's (2008) set of eight colours that stay distinct under the
//! common forms of colour blindness; yellow is left out of the line cycle because it vanishes on
//! white.

use std::fmt;

/// An opaque sRGB colour, written to SVG as `#rrggbb`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Color {
    pub r: u8,
    pub g: u8,
    pub b: u8,
}

impl Color {
    pub const fn rgb(r: u8, g: u8, b: u8) -> Self {
        Self { r, g, b }
    }

    pub const BLACK: Self = Self::rgb(0, 0, 0);
    pub const WHITE: Self = Self::rgb(255, 255, 255);
    pub const GREY: Self = Self::rgb(110, 110, 110);
    pub const LIGHT_GREY: Self = Self::rgb(215, 215, 215);
    pub const ORANGE: Self = Self::rgb(230, 159, 0);
    pub const SKY_BLUE: Self = Self::rgb(86, 180, 233);
    pub const BLUISH_GREEN: Self = Self::rgb(0, 158, 115);
    pub const YELLOW: Self = Self::rgb(240, 228, 66);
    pub const BLUE: Self = Self::rgb(0, 114, 178);
    pub const VERMILLION: Self = Self::rgb(213, 94, 0);
    pub const REDDISH_PURPLE: Self = Self::rgb(204, 121, 167);

    /// Relative luminance (WCAG 2), 0 for black to 1 for white.
    pub fn luminance(self) -> f64 {
        fn lin(c: u8) -> f64 {
            let c = f64::from(c) / 255.0;
            if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
        }
        0.2126 * lin(self.r) + 0.7152 * lin(self.g) + 0.0722 * lin(self.b)
    }

    /// Black or white, whichever reads better on top of `self`.
    pub fn contrasting_text(self) -> Self {
        // Contrast ratio against black is (L + 0.05) / 0.05, against white 1.05 / (L + 0.05);
        // they are equal at L ≈ 0.179.
        if self.luminance() > 0.179 { Self::BLACK } else { Self::WHITE }
    }
}

impl fmt::Display for Color {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "#{:02x}{:02x}{:02x}", self.r, self.g, self.b)
    }
}

/// Colours given to series in the order they are added to a panel (Okabe–Ito without yellow).
pub const PALETTE: [Color; 7] = [
    Color::BLUE,
    Color::VERMILLION,
    Color::BLUISH_GREEN,
    Color::REDDISH_PURPLE,
    Color::ORANGE,
    Color::SKY_BLUE,
    Color::BLACK,
];

/// The shape drawn at each data point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Marker {
    Circle,
    Square,
    Triangle,
    Diamond,
    Cross,
    Plus,
}

impl Marker {
    /// Shapes given to scatter series (and to line series asked for `Series::auto_marker`) in
    /// order, so that series stay apart in black-and-white print too.
    pub const CYCLE: [Marker; 6] =
        [Marker::Circle, Marker::Square, Marker::Triangle, Marker::Diamond, Marker::Cross, Marker::Plus];

    /// Cross and plus are strokes only; the others are filled.
    pub(crate) fn is_stroke_only(self) -> bool {
        matches!(self, Marker::Cross | Marker::Plus)
    }
}

/// Line dash pattern.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Dash {
    #[default]
    Solid,
    Dashed,
    Dotted,
    DashDot,
}

impl Dash {
    /// `stroke-dasharray` value scaled to the line width, or `None` for a solid line.
    pub(crate) fn dasharray(self, width: f64) -> Option<[f64; 4]> {
        let w = width.max(1.0);
        match self {
            Dash::Solid => None,
            Dash::Dashed => Some([5.0 * w, 3.0 * w, 5.0 * w, 3.0 * w]),
            Dash::Dotted => Some([1.0 * w, 2.0 * w, 1.0 * w, 2.0 * w]),
            Dash::DashDot => Some([5.0 * w, 2.5 * w, 1.0 * w, 2.5 * w]),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hex_and_contrast() {
        assert_eq!(Color::VERMILLION.to_string(), "#d55e00");
        assert_eq!(Color::WHITE.contrasting_text(), Color::BLACK);
        assert_eq!(Color::BLACK.contrasting_text(), Color::WHITE);
        assert_eq!(Color::YELLOW.contrasting_text(), Color::BLACK);
        assert_eq!(Color::BLUE.contrasting_text(), Color::WHITE);
        assert!((Color::WHITE.luminance() - 1.0).abs() < 1e-12);
    }
}
