//! Polyline geometry in pixel space: min/max decimation per pixel column and clipping to the
//! plot rectangle.

/// A point in pixels (x to the right, y down).
pub type Pt = (f64, f64);

/// An axis-aligned rectangle in pixels, `x0 < x1`, `y0 < y1`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rect {
    pub x0: f64,
    pub y0: f64,
    pub x1: f64,
    pub y1: f64,
}

impl Rect {
    pub fn width(&self) -> f64 {
        self.x1 - self.x0
    }

    pub fn height(&self) -> f64 {
        self.y1 - self.y0
    }

    pub fn contains(&self, (x, y): Pt) -> bool {
        x >= self.x0 && x <= self.x1 && y >= self.y0 && y <= self.y1
    }

    pub fn grown(&self, by: f64) -> Rect {
        Rect { x0: self.x0 - by, y0: self.y0 - by, x1: self.x1 + by, y1: self.y1 + by }
    }
}

/// Min/max decimation (the "M4" rule): consecutive points that fall in the same pixel column
/// (same `floor(x)`) are replaced by the first, the lowest, the highest and the last of them, in
/// their original order. The drawn line then covers exactly the same pixels in every column, so
/// peaks survive, while at most four points per column and run remain. Points are appended to
/// `out`; non-monotone x is allowed (each visit to a column is its own group).
pub fn decimate_columns(points: &[Pt], out: &mut Vec<Pt>) {
    let mut i = 0;
    while i < points.len() {
        let column = points[i].0.floor();
        let mut j = i + 1;
        let (mut lo, mut hi) = (i, i);
        while j < points.len() && points[j].0.floor() == column {
            if points[j].1 < points[lo].1 {
                lo = j;
            }
            if points[j].1 > points[hi].1 {
                hi = j;
            }
            j += 1;
        }
        let last = j - 1;
        let mut keep = [i, lo, hi, last];
        keep.sort_unstable();
        let mut prev = usize::MAX;
        for k in keep {
            if k != prev {
                out.push(points[k]);
                prev = k;
            }
        }
        i = j;
    }
}

/// Liang–Barsky: the part of segment `a → b` inside `r` as parameters `(t0, t1)` along it,
/// `0 ≤ t0 ≤ t1 ≤ 1`, or `None` if the segment misses the rectangle.
fn clip_segment(a: Pt, b: Pt, r: &Rect) -> Option<(f64, f64)> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let mut t0: f64 = 0.0;
    let mut t1: f64 = 1.0;
    for (p, q) in [(-dx, a.0 - r.x0), (dx, r.x1 - a.0), (-dy, a.1 - r.y0), (dy, r.y1 - a.1)] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let t = q / p;
            if p < 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
        }
    }
    (t0 <= t1).then_some((t0, t1))
}

fn lerp(a: Pt, b: Pt, t: f64) -> Pt {
    if t == 0.0 {
        a
    } else if t == 1.0 {
        b
    } else {
        (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1))
    }
}

/// Clips the polyline `points` to `r`, appending the visible pieces (each with two or more
/// points) to `out`. A piece ends where the line leaves the rectangle and a new one starts
/// where it comes back.
pub fn clip_polyline(points: &[Pt], r: &Rect, out: &mut Vec<Vec<Pt>>) {
    let mut piece: Vec<Pt> = Vec::new();
    for w in points.windows(2) {
        let (a, b) = (w[0], w[1]);
        match clip_segment(a, b, r) {
            Some((t0, t1)) => {
                if piece.is_empty() || t0 > 0.0 {
                    flush(&mut piece, out);
                    piece.push(lerp(a, b, t0));
                }
                piece.push(lerp(a, b, t1));
                if t1 < 1.0 {
                    flush(&mut piece, out);
                }
            }
            None => flush(&mut piece, out),
        }
    }
    flush(&mut piece, out);
}

fn flush(piece: &mut Vec<Pt>, out: &mut Vec<Vec<Pt>>) {
    if piece.len() >= 2 {
        out.push(std::mem::take(piece));
    } else {
        piece.clear();
    }
}

/// Length of the polyline pieces inside `r` (used to place the legend where it hides least).
pub fn length_inside(pieces: &[Vec<Pt>], r: &Rect) -> f64 {
    let mut total = 0.0;
    for piece in pieces {
        for w in piece.windows(2) {
            let (a, b) = (w[0], w[1]);
            if let Some((t0, t1)) = clip_segment(a, b, r) {
                total += (t1 - t0) * (b.0 - a.0).hypot(b.1 - a.1);
            }
        }
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;

    const R: Rect = Rect { x0: 0.0, y0: 0.0, x1: 10.0, y1: 10.0 };

    #[test]
    fn clipping_splits_at_exits_and_entries() {
        let line = [(-5.0, 5.0), (5.0, 5.0), (15.0, 5.0), (15.0, 6.0), (5.0, 6.0)];
        let mut out = Vec::new();
        clip_polyline(&line, &R, &mut out);
        assert_eq!(out, vec![vec![(0.0, 5.0), (5.0, 5.0), (10.0, 5.0)], vec![(10.0, 6.0), (5.0, 6.0)]]);
    }

    #[test]
    fn segment_crossing_a_corner_region_is_cut_both_ends() {
        let mut out = Vec::new();
        clip_polyline(&[(-10.0, -5.0), (20.0, 10.0)], &R, &mut out);
        assert_eq!(out.len(), 1);
        let p = &out[0];
        assert!((p[0].0 - 0.0).abs() < 1e-12 && (p[0].1 - 0.0).abs() < 1e-12);
        assert!((p[1].0 - 10.0).abs() < 1e-12 && (p[1].1 - 5.0).abs() < 1e-12);
    }

    #[test]
    fn missing_segments_vanish() {
        let mut out = Vec::new();
        clip_polyline(&[(-1.0, -1.0), (11.0, -1.0), (11.0, 11.0)], &R, &mut out);
        assert!(out.is_empty());
    }

    #[test]
    fn length_inside_counts_only_the_covered_part() {
        let pieces = vec![vec![(-5.0, 5.0), (15.0, 5.0)]];
        assert!((length_inside(&pieces, &R) - 10.0).abs() < 1e-12);
    }

    #[test]
    fn decimation_keeps_order_first_last_and_extremes() {
        let pts = [(0.1, 5.0), (0.2, 9.0), (0.3, 1.0), (0.4, 4.0), (1.5, 2.0)];
        let mut out = Vec::new();
        decimate_columns(&pts, &mut out);
        assert_eq!(out, vec![(0.1, 5.0), (0.2, 9.0), (0.3, 1.0), (0.4, 4.0), (1.5, 2.0)]);
        let pts: Vec<Pt> = (0..100).map(|i| (0.5 + 0.001 * i as f64, ((i * 37) % 101) as f64)).collect();
        out.clear();
        decimate_columns(&pts, &mut out);
        // First and minimum coincide here (y = 0 at i = 0): three points.
        assert_eq!(out.len(), 3);
        assert_eq!(out[0], pts[0]);
        assert_eq!(out[2], pts[99]);
        let min = pts.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
        let max = pts.iter().map(|p| p.1).fold(f64::NEG_INFINITY, f64::max);
        assert!(out.iter().any(|p| p.1 == min) && out.iter().any(|p| p.1 == max));
    }
}
