//! The figures read back with an XML parser: every series present, axes labelled, the
//! decimation bounding the size while keeping the peaks, the stability categories coloured.

use roxmltree::Document;
use studies::plot::{
    CATEGORY_COLORS, Cell, History, MapPanel, PALETTE, Precision, stability_map, time_history, work_precision,
};

/// All text of the figure's `<text>` elements.
fn texts(doc: &Document) -> Vec<String> {
    doc.descendants()
        .filter(|n| n.has_tag_name("text"))
        .map(|n| {
            n.descendants().filter(|d| d.is_text()).map(|d| d.text().unwrap()).collect::<String>().trim().to_string()
        })
        .collect()
}

fn hex(c: plotters::style::RGBColor) -> String {
    format!("#{:02X}{:02X}{:02X}", c.0, c.1, c.2)
}

/// Polylines drawn in `color`, as lists of points.
fn polylines(doc: &Document, color: &str) -> Vec<Vec<(f64, f64)>> {
    doc.descendants()
        .filter(|n| n.has_tag_name("polyline") && n.attribute("stroke").is_some_and(|s| s.eq_ignore_ascii_case(color)))
        .map(|n| {
            n.attribute("points")
                .unwrap()
                .split_whitespace()
                .map(|p| {
                    let (x, y) = p.split_once(',').unwrap();
                    (x.parse().unwrap(), y.parse().unwrap())
                })
                .collect()
        })
        .collect()
}

#[test]
fn a_time_history_shows_every_run_on_three_labelled_panels_and_stays_small() {
    // 100 s at 1 ms: 10⁵ samples per run, with one spike that must survive the decimation
    let n = 100_001;
    let t: Vec<f64> = (0..n).map(|i| i as f64 * 1e-3).collect();
    let a: Vec<[f64; 3]> = t.iter().map(|&t| [(0.3 * t).sin(), (0.3 * t).cos(), 0.01 * t]).collect();
    let mut b: Vec<[f64; 3]> = a.iter().map(|d| [d[0] * 0.9, d[1] * 0.9, d[2]]).collect();
    b[54_321][0] = 5.0;
    let runs = [History { name: "monolithic", t: &t, disp_mm: &a }, History { name: "ijcsa", t: &t, disp_mm: &b }];
    let svg = time_history("lt50m_C: cabin-centre response", &runs).unwrap();
    let doc = Document::parse(&svg).unwrap();
    let text = texts(&doc);
    for label in [
        "lt50m_C: cabin-centre response",
        "X displacement (mm)",
        "Y displacement (mm)",
        "Z displacement (mm)",
        "time (s)",
    ] {
        assert!(text.iter().any(|t| t == label), "label `{label}` missing");
    }
    for name in ["monolithic", "ijcsa"] {
        assert_eq!(text.iter().filter(|t| *t == name).count(), 1, "one legend entry for {name}");
    }
    let width: f64 = doc.root_element().attribute("width").unwrap().parse().unwrap();
    for (i, _) in runs.iter().enumerate() {
        let lines = polylines(&doc, &hex(PALETTE[i]));
        let drawn: Vec<_> = lines.iter().filter(|l| l.len() > 2).collect();
        assert_eq!(drawn.len(), 3, "run {i}: one line per panel");
        for l in drawn {
            assert!(l.len() as f64 <= 4.0 * width, "run {i}: {} points for {width} px", l.len());
        }
    }
    // the spike of run 1 in the X panel is the highest point drawn there (smallest y pixel)
    let x_panel = &polylines(&doc, &hex(PALETTE[1]))[0];
    let top = x_panel.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
    let others = polylines(&doc, &hex(PALETTE[0]))[0].iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
    assert!(top < others - 50.0, "the spike is drawn: {top} against {others}");
    assert!(svg.len() < 400_000, "{} bytes for 2 × 10⁵ points", svg.len());
}

#[test]
fn a_work_precision_plot_has_log_axes_a_marked_line_per_scheme_and_the_reference() {
    let schemes = [
        Precision { name: "monolithic", points: vec![(0.5, 4e-3), (0.9, 1e-3), (1.7, 2.5e-4)], adaptive: vec![] },
        Precision {
            name: "ijcsa",
            points: vec![(0.6, 4e-3), (1.1, 1e-3), (2.0, 2.6e-4)],
            adaptive: vec![(0.7, 5e-4), (0.4, 3e-3)],
        },
        Precision { name: "jacobi", points: vec![], adaptive: vec![] },
    ];
    let svg =
        work_precision("work–precision", "wall time (s)", "max error (mm)", &schemes, Some((0.15, "1 % of the peak")))
            .unwrap();
    let doc = Document::parse(&svg).unwrap();
    let text = texts(&doc);
    for label in [
        "work–precision",
        "wall time (s)",
        "max error (mm)",
        "monolithic",
        "ijcsa",
        "jacobi (no result)",
        "adaptive step (its scheme's colour)",
        "1 % of the peak",
    ] {
        assert!(text.iter().any(|t| t == label), "`{label}` missing: {text:?}");
    }
    // decade ticks on both axes: 1e-4 … 1e0 for the errors, 1e-1 … 1e1 for the times
    for tick in ["1e-4", "1e-3", "1e-2", "1e-1", "1e0", "1e1"] {
        assert!(text.iter().any(|t| t == tick), "tick {tick} missing: {text:?}");
    }
    // each scheme's line has its three points, and the second scheme triangles (polygons)
    for i in 0..2 {
        assert!(polylines(&doc, &hex(PALETTE[i])).iter().any(|l| l.len() == 3), "scheme {i}");
    }
    assert!(doc.descendants().any(|n| n.has_tag_name("polygon")), "triangle markers");
    // the adaptive runs: rings in their scheme's colour, apart from its line (and one in the legend)
    let rings = doc
        .descendants()
        .filter(|n| n.has_tag_name("circle") && n.attribute("r") == Some("8") && n.attribute("fill") == Some("none"))
        .map(|n| n.attribute("stroke").unwrap_or_default().to_ascii_lowercase())
        .collect::<Vec<_>>();
    assert_eq!(rings.iter().filter(|c| **c == hex(PALETTE[1]).to_ascii_lowercase()).count(), 2, "{rings:?}");
    assert_eq!(rings.len(), 3, "two runs and the legend's ring: {rings:?}");
    // a non-positive value cannot go on a log axis: an error, not a silent drop
    for bad in [
        Precision { name: "x", points: vec![(1.0, 0.0)], adaptive: vec![] },
        Precision { name: "x", points: vec![(1.0, 1.0)], adaptive: vec![(-1.0, 1.0)] },
    ] {
        let e = work_precision("t", "x", "y", &[bad], None).unwrap_err().to_string();
        assert!(e.contains("`x`") && e.contains("positive"), "{e}");
    }
}

#[test]
fn a_stability_map_colours_every_cell_by_category_with_its_note() {
    let dts = [0.04, 0.02, 0.01];
    let ratios = [0.1, 1.0, 10.0];
    let categories = [
        ("stable", CATEGORY_COLORS[0]),
        ("unstable", CATEGORY_COLORS[1]),
        ("not converged", CATEGORY_COLORS[2]),
        ("infeasible pose", CATEGORY_COLORS[3]),
    ];
    let cells = |scheme: usize| {
        let mut v = Vec::new();
        for iy in 0..3 {
            for ix in 0..3 {
                let category = if iy == 2 {
                    3
                } else if (ix + scheme).is_multiple_of(3) {
                    1
                } else {
                    0
                };
                let text = if category == 0 { format!("{}.{}", 2 + ix, iy) } else { String::new() };
                v.push(Cell { ix, iy, category, text });
            }
        }
        v
    };
    let panels = [
        MapPanel { title: "jacobi", cells: cells(0) },
        MapPanel { title: "ijcsa", cells: cells(1) },
        MapPanel { title: "iterative", cells: cells(2) },
    ];
    let svg =
        stability_map("stability", "macro step h (s)", "platform mass factor", &dts, &ratios, &categories, &panels)
            .unwrap();
    let doc = Document::parse(&svg).unwrap();
    let text = texts(&doc);
    for label in ["stability", "jacobi", "ijcsa", "iterative", "stable", "unstable", "not converged", "infeasible pose"]
    {
        assert!(text.iter().any(|t| t == label), "`{label}` missing");
    }
    assert_eq!(text.iter().filter(|t| *t == "macro step h (s)").count(), 3);
    for tick in ["0.01", "0.02", "0.04", "0.1", "1", "10"] {
        assert!(text.iter().filter(|t| *t == tick).count() >= 3, "tick {tick} on every panel");
    }
    // filled rectangles per category: the cells plus the legend swatch
    for (k, (_, color)) in categories.iter().enumerate() {
        let want = panels.iter().flat_map(|p| &p.cells).filter(|c| c.category == k).count() + 1;
        let got = doc
            .descendants()
            .filter(|n| {
                n.has_tag_name("rect") && n.attribute("fill").is_some_and(|f| f.eq_ignore_ascii_case(&hex(*color)))
            })
            .count();
        assert_eq!(got, want, "category {k}");
    }
    for c in panels.iter().flat_map(|p| &p.cells).filter(|c| !c.text.is_empty()) {
        assert!(text.contains(&c.text), "note {} missing", c.text);
    }
    // a cell outside the grid is an error naming the panel
    let bad = [MapPanel { title: "x", cells: vec![Cell { ix: 3, iy: 0, category: 0, text: String::new() }] }];
    let e = stability_map("s", "x", "y", &dts, &ratios, &categories, &bad).unwrap_err().to_string();
    assert!(e.contains("`x`") && e.contains("outside"), "{e}");
}
