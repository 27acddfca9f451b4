//! Figures read back with an XML parser: well-formed standalone SVG, data points at the pixels
//! the axis ranges put them, nice tick labels covering the data, gaps at NaN, decimation that
//! keeps every column's extremes, and clear errors for what cannot be drawn.

use master::plot::{Axis, Color, Figure, Grid, Legend, PlotError, Scale, Series};
use roxmltree::{Document, Node};

const XMLNS: &str = "http://www.w3.org/2000/svg";

fn svg_of(fig: &Figure) -> String {
    fig.to_svg_string().expect("figure renders")
}

fn by_class<'a, 'i>(doc: &'a Document<'i>, class: &str) -> Vec<Node<'a, 'i>> {
    doc.descendants().filter(|n| n.attribute("class") == Some(class)).collect()
}

fn num(n: &Node, attr: &str) -> f64 {
    n.attribute(attr).unwrap_or_else(|| panic!("no {attr} on {n:?}")).parse().unwrap()
}

/// All text under a node, tspans included.
fn text_of(n: &Node) -> String {
    n.descendants().filter(|d| d.is_text()).map(|d| d.text().unwrap()).collect()
}

/// The value a tick label stands for: `0.4`, `−0.5`, `10` + sup `−4`, `2.5×10` + sup `−7`.
fn label_value(n: &Node) -> f64 {
    let main = n.text().unwrap_or("").replace('−', "-");
    let sup = n.children().find(|c| c.has_tag_name((XMLNS, "tspan"))).map(|t| t.text().unwrap().replace('−', "-"));
    match sup {
        None => main.parse().unwrap(),
        Some(e) => {
            let e: i32 = e.parse().unwrap();
            let mantissa = main.strip_suffix("10").unwrap().trim_end_matches('×');
            let m = if mantissa.is_empty() { 1.0 } else { mantissa.parse().unwrap() };
            m * 10f64.powi(e)
        }
    }
}

/// Plot rectangle of the i-th frame: (x0, y0, x1, y1).
fn frame(doc: &Document, i: usize) -> (f64, f64, f64, f64) {
    let f = by_class(doc, "frame")[i];
    let (x, y) = (num(&f, "x"), num(&f, "y"));
    (x, y, x + num(&f, "width"), y + num(&f, "height"))
}

/// The pieces (subpaths) of a path made of `M x y L x y x y …` commands.
fn pieces(d: &str) -> Vec<Vec<(f64, f64)>> {
    let mut out: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut nums: Vec<f64> = Vec::new();
    let flush = |nums: &mut Vec<f64>, out: &mut Vec<Vec<(f64, f64)>>, new_piece: bool| {
        assert!(nums.len().is_multiple_of(2), "odd number count in {d}");
        if new_piece {
            out.push(Vec::new());
        }
        out.last_mut().unwrap().extend(nums.chunks(2).map(|c| (c[0], c[1])));
        nums.clear();
    };
    let mut token = String::new();
    let mut pending: Option<char> = None;
    for c in d.chars().chain(std::iter::once(' ')) {
        if c == 'M' || c == 'L' || c == ' ' || c == ',' {
            if !token.is_empty() {
                nums.push(token.parse().unwrap_or_else(|_| panic!("bad number {token:?} in path")));
                token.clear();
            }
            if c == 'M' || c == 'L' {
                if let Some(cmd) = pending {
                    flush(&mut nums, &mut out, cmd == 'M');
                }
                pending = Some(c);
            }
        } else {
            assert!(c.is_ascii_digit() || c == '.' || c == '-', "unexpected {c:?} in line path");
            token.push(c);
        }
    }
    if let Some(cmd) = pending {
        flush(&mut nums, &mut out, cmd == 'M');
    }
    out
}

fn line_pieces(doc: &Document, series: &str) -> Vec<Vec<(f64, f64)>> {
    let path = by_class(doc, "line")
        .into_iter()
        .find(|n| n.attribute("data-series") == Some(series))
        .unwrap_or_else(|| panic!("no line for {series:?}"));
    pieces(path.attribute("d").unwrap())
}

#[test]
fn output_is_well_formed_standalone_svg_with_escaped_text() {
    let name = r#"a<b & "c" 'd'>"#;
    let mut fig = Figure::new(640, 400);
    fig.title("Title & <more>");
    fig.panel(|p| p.title("Δx <mm>").x_label("t [s] & more").y_label("\"y\"").line(name, &[0.0, 1.0], &[0.0, 1.0]));
    let svg = svg_of(&fig);
    let doc = Document::parse(&svg).expect("well-formed XML");
    let root = doc.root_element();
    assert!(root.has_tag_name((XMLNS, "svg")));
    assert_eq!(root.attribute("width"), Some("640"));
    assert_eq!(root.attribute("height"), Some("400"));
    assert_eq!(root.attribute("viewBox"), Some("0 0 640 400"));
    assert_eq!(text_of(&by_class(&doc, "figure-title")[0]), "Title & <more>");
    assert_eq!(text_of(&by_class(&doc, "panel-title")[0]), "Δx <mm>");
    assert_eq!(text_of(&by_class(&doc, "xlabel")[0]), "t [s] & more");
    assert_eq!(text_of(&by_class(&doc, "ylabel")[0]), "\"y\"");
    assert_eq!(text_of(&by_class(&doc, "legend-text")[0]), name);
    assert_eq!(by_class(&doc, "line")[0].attribute("data-series"), Some(name));
    // Everything drawn lies inside the canvas.
    for t in doc.descendants().filter(|n| n.has_tag_name((XMLNS, "text"))) {
        if let (Some(x), Some(y)) = (t.attribute("x"), t.attribute("y")) {
            let (x, y): (f64, f64) = (x.parse().unwrap(), y.parse().unwrap());
            assert!((0.0..=640.0).contains(&x) && (0.0..=400.0).contains(&y), "text at ({x}, {y})");
        }
    }
}

#[test]
fn write_svg_writes_the_same_document() {
    let mut fig = Figure::new(400, 300);
    fig.panel(|p| p.line("a", &[0.0, 1.0, 2.0], &[1.0, 3.0, 2.0]));
    let path = std::env::temp_dir().join(format!("plot_svg_test_{}.svg", std::process::id()));
    fig.write_svg(&path).unwrap();
    let written = std::fs::read_to_string(&path).unwrap();
    std::fs::remove_file(&path).unwrap();
    assert_eq!(written, svg_of(&fig));
}

#[test]
fn known_points_land_on_the_expected_pixels() {
    let mut fig = Figure::new(800, 500);
    fig.panel(|p| p.x_range(0.0, 10.0).y_range(-1.0, 1.0).line("lin", &[0.0, 2.5, 7.5, 10.0], &[-1.0, 0.5, -0.5, 1.0]));
    fig.panel(|p| {
        p.x_scale(Scale::Log10).y_scale(Scale::Log10).x_range(1e-3, 1e1).y_range(1e-6, 1e-2).line(
            "log",
            &[1e-3, 1e-1, 1e1],
            &[1e-6, 1e-3, 1e-2],
        )
    });
    let svg = svg_of(&fig);
    let doc = Document::parse(&svg).unwrap();

    let (x0, y0, x1, y1) = frame(&doc, 0);
    let (w, h) = (x1 - x0, y1 - y0);
    let expected = [(x0, y1), (x0 + 0.25 * w, y0 + 0.25 * h), (x0 + 0.75 * w, y0 + 0.75 * h), (x1, y0)];
    let got = line_pieces(&doc, "lin");
    assert_eq!(got.len(), 1);
    assert_eq!(got[0].len(), 4);
    for (g, e) in got[0].iter().zip(expected) {
        // Coordinates are written with two decimals.
        assert!((g.0 - e.0).abs() <= 0.005 + 1e-9 && (g.1 - e.1).abs() <= 0.005 + 1e-9, "{g:?} vs {e:?}");
    }

    let (x0, y0, x1, y1) = frame(&doc, 1);
    let (w, h) = (x1 - x0, y1 - y0);
    // log10: x = 1e-1 is halfway through [1e-3, 1e1]; y = 1e-3 is 3/4 of the way up [1e-6, 1e-2].
    let expected = [(x0, y1), (x0 + 0.5 * w, y1 - 0.75 * h), (x1, y0)];
    let got = line_pieces(&doc, "log");
    for (g, e) in got[0].iter().zip(expected) {
        assert!((g.0 - e.0).abs() <= 0.005 + 1e-9 && (g.1 - e.1).abs() <= 0.005 + 1e-9, "{g:?} vs {e:?}");
    }
}

#[test]
fn tick_labels_are_nice_cover_the_data_and_sit_at_their_values() {
    let x: Vec<f64> = (0..50).map(|i| i as f64 * 0.37).collect();
    let y: Vec<f64> = x.iter().map(|&x| 0.5 + 0.37 * (x * 1.3).sin()).collect(); // ≈ [0.13, 0.87]
    let (ymin, ymax) = y.iter().fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    let mut fig = Figure::new(700, 420);
    fig.panel(|p| p.x_label("t [s]").y_label("y [mm]").line("y", &x, &y));
    let svg = svg_of(&fig);
    let doc = Document::parse(&svg).unwrap();
    let (x0, y0, x1, y1) = frame(&doc, 0);

    for (class, lo, hi, vertical) in [("ytick", ymin, ymax, true), ("xtick", 0.0, 49.0 * 0.37, false)] {
        let labels = by_class(&doc, class);
        let values: Vec<f64> = labels.iter().map(label_value).collect();
        assert!(values.len() >= 3, "{class}: {values:?}");
        let step = values[1] - values[0];
        let mag = 10f64.powf(step.log10().floor());
        let mantissa = (step / mag * 1e6).round() / 1e6;
        assert!([1.0, 2.0, 5.0].contains(&mantissa), "{class}: step {step} is not 1-2-5");
        for w in values.windows(2) {
            assert!(((w[1] - w[0]) - step).abs() < 1e-9 * step.abs().max(1.0), "{class}: uneven {values:?}");
        }
        for v in &values {
            assert!(((v / step) - (v / step).round()).abs() < 1e-9, "{class}: {v} not a multiple of {step}");
        }
        // Cover the data: no gap of a whole step between the data and the outer labels.
        assert!(values[0] <= lo + step && *values.last().unwrap() >= hi - step, "{class}: {values:?} vs [{lo}, {hi}]");

        // Label positions agree with a linear map fitted through the first and last label, and
        // every label sits inside the frame's extent.
        let pos: Vec<f64> =
            labels.iter().map(|n| if vertical { num(n, "y") - 0.36 * 12.0 } else { num(n, "x") }).collect();
        let (v0, vn, p0, pn) = (values[0], values[values.len() - 1], pos[0], pos[pos.len() - 1]);
        for (v, p) in values.iter().zip(&pos) {
            let expected = p0 + (v - v0) / (vn - v0) * (pn - p0);
            assert!((p - expected).abs() < 0.02, "{class} {v} at {p}, expected {expected}");
            if vertical {
                assert!(*p >= y0 - 0.01 && *p <= y1 + 0.01);
            } else {
                assert!(*p >= x0 - 0.01 && *p <= x1 + 0.01);
            }
        }
    }
    // The data's highest point maps to where the padded auto range puts it: 4 % of the span
    // below the top of the frame.
    let line = &line_pieces(&doc, "y")[0];
    let ytop = line.iter().map(|p| p.1).fold(f64::MAX, f64::min);
    let expected_top = y0 + (y1 - y0) * 0.04 / 1.08;
    assert!((ytop - expected_top).abs() < 0.01, "{ytop} vs {expected_top}");
}

#[test]
fn log_axis_labels_are_the_enclosing_decades() {
    let x = [3e-4, 1e-2, 2e1];
    let y = [1.0, 2.0, 3.0];
    let mut fig = Figure::new(700, 420);
    fig.panel(|p| p.x_scale(Scale::Log10).line("a", &x, &y));
    let svg = svg_of(&fig);
    let doc = Document::parse(&svg).unwrap();
    let labels = by_class(&doc, "xtick");
    let values: Vec<f64> = labels.iter().map(label_value).collect();
    let decades: Vec<f64> = (-4..=2).map(|e| 10f64.powi(e)).collect();
    assert_eq!(values.len(), decades.len(), "{values:?}");
    for (v, d) in values.iter().zip(&decades) {
        assert!((v / d - 1.0).abs() < 1e-12, "{values:?}");
    }
    assert_eq!(text_of(&labels[0]), "10−4");
    // The range is exactly the decades: first label on the left edge, last on the right.
    let (x0, _, x1, _) = frame(&doc, 0);
    assert!((num(&labels[0], "x") - x0).abs() < 0.01 && (num(&labels[6], "x") - x1).abs() < 0.01);
}

#[test]
fn nan_and_infinity_make_gaps_not_garbage() {
    let x: Vec<f64> = (0..9).map(f64::from).collect();
    let y = [0.0, 1.0, 2.0, f64::NAN, 4.0, 5.0, f64::INFINITY, 7.0, 8.0];
    let mut fig = Figure::new(600, 400);
    fig.panel(|p| p.line("gappy", &x, &y).line("all-nan", &[0.0, 1.0], &[f64::NAN, f64::NAN]));
    let svg = svg_of(&fig);
    assert!(!svg.contains("NaN") && !svg.contains("inf"), "non-finite numbers written");
    let doc = Document::parse(&svg).unwrap();
    let got = line_pieces(&doc, "gappy");
    // Runs: [0, 1, 2], [4, 5], [7, 8] (each with two or more points is drawn).
    assert_eq!(got.iter().map(Vec::len).collect::<Vec<_>>(), vec![3, 2, 2]);
    let (x0, y0, x1, y1) = frame(&doc, 0);
    for p in got.iter().flatten() {
        assert!(p.0 >= x0 - 0.01 && p.0 <= x1 + 0.01 && p.1 >= y0 - 0.01 && p.1 <= y1 + 0.01);
    }
    // The auto range ignores the non-finite points: y = 8 is near the top.
    let top = got.iter().flatten().map(|p| p.1).fold(f64::MAX, f64::min);
    let expected = y0 + (y1 - y0) * 0.04 / 1.08;
    assert!((top - expected).abs() < 0.01, "{top} vs {expected}");
    assert!(by_class(&doc, "line").iter().all(|n| n.attribute("data-series") != Some("all-nan")));
}

#[test]
fn decimation_keeps_every_columns_extremes_and_the_file_small() {
    // 100 s at 0.01 s: a slow wave with a fast small vibration and a few isolated spikes.
    let n = 10_001;
    let t: Vec<f64> = (0..n).map(|i| i as f64 * 0.01).collect();
    let y: Vec<f64> = t
        .iter()
        .enumerate()
        .map(|(i, &t)| {
            let spike = if i % 1777 == 0 { 0.4 } else { 0.0 };
            0.7 * (t * 0.3).sin() + 0.05 * (t * 9.0).sin() + spike
        })
        .collect();
    let mut fig = Figure::new(900, 300);
    fig.panel(|p| p.x_range(0.0, 100.0).y_range(-1.0, 1.2).line("run", &t, &y));
    let svg = svg_of(&fig);
    assert!(svg.len() < 120_000, "{} bytes for {n} points", svg.len());
    let doc = Document::parse(&svg).unwrap();
    let (x0, y0, x1, y1) = frame(&doc, 0);
    let got = line_pieces(&doc, "run");
    assert_eq!(got.len(), 1);
    let drawn = &got[0];
    let columns = (x1 - x0).ceil() as usize + 1;
    assert!(drawn.len() <= 4 * columns && drawn.len() < n / 2, "{} points drawn", drawn.len());

    // Per pixel column, the lowest and highest drawn y equal those of the full data.
    let px = |t: f64| x0 + t / 100.0 * (x1 - x0);
    let py = |v: f64| y1 - (v + 1.0) / 2.2 * (y1 - y0);
    let mut full: std::collections::BTreeMap<i64, (f64, f64)> = Default::default();
    for (&t, &v) in t.iter().zip(&y) {
        let e = full.entry(px(t).floor() as i64).or_insert((f64::MAX, f64::MIN));
        *e = (e.0.min(py(v)), e.1.max(py(v)));
    }
    // Every drawn point is a data point (up to the 0.01 px rounding of the output) ...
    let data_px: Vec<(f64, f64)> = t.iter().zip(&y).map(|(&t, &v)| (px(t), py(v))).collect();
    for &(x, v) in drawn {
        let i = data_px.partition_point(|p| p.0 < x - 0.006);
        assert!(
            data_px[i..].iter().take_while(|p| p.0 <= x + 0.006).any(|p| (p.1 - v).abs() <= 0.006),
            "drawn point ({x}, {v}) is not a data point"
        );
    }
    // ... and in every pixel column the data's lowest and highest points are among them.
    for (col, (lo, hi)) in &full {
        let c = *col as f64;
        let in_col: Vec<f64> = drawn.iter().filter(|p| p.0 >= c - 0.006 && p.0 <= c + 1.006).map(|p| p.1).collect();
        assert!(in_col.iter().any(|v| (v - lo).abs() <= 0.006), "column {col}: min {lo} missing");
        assert!(in_col.iter().any(|v| (v - hi).abs() <= 0.006), "column {col}: max {hi} missing");
    }
    // The spikes survive: the highest drawn point is the spike at t = 17.77 s (0.4 above).
    let top = drawn.iter().map(|p| p.1).fold(f64::MAX, f64::min);
    let spike_top = (0..n).step_by(1777).map(|i| py(y[i])).fold(f64::MAX, f64::min);
    assert!((top - spike_top).abs() <= 0.006);
}

#[test]
fn non_positive_values_on_a_log_axis_are_an_error() {
    let mut fig = Figure::new(600, 400);
    fig.panel(|p| p.title("errors").y_scale(Scale::Log10).line("jacobi", &[1.0, 2.0, 3.0], &[1e-3, f64::NAN, 0.0]));
    let err = fig.to_svg_string().unwrap_err();
    assert_eq!(
        err,
        PlotError::NonPositiveOnLog {
            panel: "panel 0 (\"errors\")".into(),
            series: "jacobi".into(),
            axis: Axis::Y,
            index: 2,
            value: 0.0,
        }
    );
    let msg = err.to_string();
    assert!(msg.contains("\"jacobi\"") && msg.contains("y[2] = 0") && msg.contains("logarithmic"), "{msg}");
    let io = fig.write_svg(std::env::temp_dir().join("never_written.svg")).unwrap_err();
    assert_eq!(io.kind(), std::io::ErrorKind::InvalidInput);
    assert!(io.to_string().contains("jacobi"));

    // NaN alone is a gap on a log axis too, not an error.
    let mut fig = Figure::new(600, 400);
    fig.panel(|p| p.x_scale(Scale::Log10).line("ok", &[1.0, f64::NAN, 3.0], &[1.0, 2.0, 3.0]));
    assert!(fig.to_svg_string().is_ok());
    // A fixed log range must be positive.
    let mut fig = Figure::new(600, 400);
    fig.panel(|p| p.x_scale(Scale::Log10).x_range(0.0, 10.0).line("a", &[1.0, 2.0], &[1.0, 2.0]));
    assert!(matches!(fig.to_svg_string(), Err(PlotError::BadRange { axis: Axis::X, .. })));
}

#[test]
fn empty_and_constant_data_never_divide_by_zero() {
    let mut fig = Figure::new(600, 500);
    fig.panel(|p| p.line("empty", &[], &[]));
    fig.panel(|p| p.line("constant", &[0.0, 1.0, 2.0], &[3.0, 3.0, 3.0]));
    fig.panel(|p| p.scatter("one point", &[5.0], &[0.0]));
    fig.panel(|p| p.y_scale(Scale::Log10).line("log constant", &[0.0, 1.0], &[1e-3, 1e-3]));
    let svg = svg_of(&fig);
    assert!(!svg.contains("NaN") && !svg.contains("inf"));
    let doc = Document::parse(&svg).unwrap();
    assert_eq!(by_class(&doc, "frame").len(), 4);
    // The constant line is drawn across the middle of its panel.
    let (_, y0, _, y1) = frame(&doc, 1);
    let line = &line_pieces(&doc, "constant")[0];
    assert!(line.iter().all(|p| (p.1 - 0.5 * (y0 + y1)).abs() < 0.01));
    // The single scatter point sits in the middle of its panel.
    let (x0, y0, x1, y1) = frame(&doc, 2);
    let m = by_class(&doc, "markers").into_iter().find(|n| n.attribute("data-series") == Some("one point")).unwrap();
    let d = m.attribute("d").unwrap();
    let nums: Vec<f64> = d
        .trim_start_matches('M')
        .split(|c: char| c.is_ascii_alphabetic() || c == ' ')
        .take(2)
        .map(|s| s.parse().unwrap())
        .collect();
    // A circle marker path starts at its left edge, radius 3.5.
    assert!((nums[0] + 3.5 - 0.5 * (x0 + x1)).abs() < 0.01 && (nums[1] - 0.5 * (y0 + y1)).abs() < 0.01, "{d}");
    // Every panel got labelled y ticks.
    assert!(by_class(&doc, "ytick").len() >= 8);
}

#[test]
fn bad_input_gets_an_error_naming_it() {
    let mut fig = Figure::new(600, 400);
    fig.panel(|p| p.line("short", &[0.0, 1.0, 2.0], &[0.0, 1.0]));
    match fig.to_svg_string() {
        Err(PlotError::LengthMismatch { series, x_len: 3, y_len: 2, .. }) => assert_eq!(series, "short"),
        other => panic!("{other:?}"),
    }
    assert_eq!(Figure::new(600, 400).to_svg_string(), Err(PlotError::Empty));
    let mut fig = Figure::new(50, 40);
    fig.panel(|p| p.line("a", &[0.0, 1.0], &[0.0, 1.0]));
    assert!(matches!(fig.to_svg_string(), Err(PlotError::TooSmall { .. })));
    let mut fig = Figure::new(600, 400);
    fig.panel(|p| p.y_range(1.0, 1.0).line("a", &[0.0, 1.0], &[0.0, 1.0]));
    assert!(matches!(fig.to_svg_string(), Err(PlotError::BadRange { axis: Axis::Y, min: 1.0, max: 1.0, .. })));
    for (y, name) in
        [([-1e308, 1e308], "overflowing span"), ([0.0, 1e-300], "tiny span"), ([1e-320, 1e-320], "subnormal")]
    {
        let mut fig = Figure::new(600, 400);
        fig.panel(|p| p.line(name, &[0.0, 1.0], &y));
        match fig.to_svg_string() {
            Err(PlotError::DataRange { axis: Axis::Y, min, max, .. }) => assert_eq!((min, max), (y[0], y[1]), "{name}"),
            other => panic!("{name}: {other:?}"),
        }
    }
    let mut fig = Figure::new(600, 400);
    fig.panel(|p| p.x_range(0.0, 1e-300).line("a", &[0.0, 1.0], &[0.0, 1.0]));
    assert!(matches!(fig.to_svg_string(), Err(PlotError::BadRange { axis: Axis::X, .. })));
    let mut fig = Figure::new(600, 400);
    fig.share_x(true);
    fig.panel(|p| p.line("a", &[1.0, 2.0], &[0.0, 1.0]));
    fig.panel(|p| p.x_scale(Scale::Log10).line("b", &[1.0, 2.0], &[0.0, 1.0]));
    assert!(matches!(fig.to_svg_string(), Err(PlotError::SharedScaleMismatch { .. })));
    let mut grid = Grid::new(&[1.0, 2.0], &[1.0]).category("stable", Color::SKY_BLUE);
    grid.set(0, 0, 1, "");
    let mut fig = Figure::new(600, 400);
    fig.panel(|p| p.grid(grid));
    let err = fig.to_svg_string().unwrap_err();
    assert!(err.to_string().contains("category 1 but only 1 categories"), "{err}");
    let mut grid = Grid::new(&[1.0, 2.0], &[1.0]).category("stable", Color::SKY_BLUE);
    grid.set(2, 0, 0, "");
    let mut fig = Figure::new(600, 400);
    fig.panel(|p| p.grid(grid));
    assert!(fig.to_svg_string().unwrap_err().to_string().contains("(2, 0) is outside the 2×1 grid"));
    let mut fig = Figure::new(600, 400);
    fig.panel(|p| p.grid(Grid::new(&[1.0, 3.0, 2.0], &[1.0])));
    assert!(matches!(fig.to_svg_string(), Err(PlotError::BadGrid { .. })));
}

#[test]
fn shared_x_panels_align_and_only_the_bottom_one_is_labelled() {
    let t: Vec<f64> = (0..=100).map(|i| i as f64).collect();
    let mut fig = Figure::new(800, 600);
    fig.share_x(true);
    for k in 0..3 {
        let y: Vec<f64> = t.iter().map(|&t| (t * 0.1 + k as f64).sin() * 10f64.powi(-k)).collect();
        let tk: Vec<f64> = t.iter().map(|&t| t * (1.0 + k as f64) / 3.0).collect(); // different x extents
        fig.panel(|p| p.x_label("t [s]").y_label("Δ [mm]").line("d", &tk, &y));
    }
    let svg = svg_of(&fig);
    let doc = Document::parse(&svg).unwrap();
    let frames: Vec<_> = (0..3).map(|i| frame(&doc, i)).collect();
    for f in &frames {
        assert!((f.0 - frames[0].0).abs() < 1e-9 && (f.2 - frames[0].2).abs() < 1e-9, "{frames:?}");
        assert!(((f.3 - f.1) - (frames[0].3 - frames[0].1)).abs() < 1e-9, "equal heights: {frames:?}");
    }
    assert!(frames[0].3 < frames[1].1 && frames[1].3 < frames[2].1, "stacked top to bottom");
    let xticks = by_class(&doc, "xtick");
    assert!(!xticks.is_empty());
    assert!(xticks.iter().all(|n| num(n, "y") > frames[2].3), "x labels only under the bottom panel");
    assert_eq!(by_class(&doc, "xlabel").len(), 1);
    // One x range for all: the union [0, 100] (padded), so x = 0 maps to the same pixel in each.
    let starts: Vec<f64> = (0..3)
        .map(|i| by_class(&doc, "line")[i].attribute("d").unwrap().to_owned())
        .map(|d| pieces(&d)[0][0].0)
        .collect();
    assert!(starts.iter().all(|&s| (s - starts[0]).abs() < 0.01), "{starts:?}");
}

#[test]
fn heat_map_cells_fill_the_axes_with_category_colours_and_text() {
    let dts = [0.0025, 0.005, 0.01, 0.02, 0.04];
    let ratios = [0.1, 1.0, 10.0];
    let mut grid = Grid::new(&dts, &ratios).category("stable", Color::SKY_BLUE).category("unstable", Color::VERMILLION);
    for ix in 0..5 {
        for iy in 0..3 {
            let unstable = ix + iy >= 5;
            grid.set(ix, iy, usize::from(unstable), if unstable { "" } else { "2.5" });
        }
    }
    let mut fig = Figure::new(700, 400);
    fig.panel(|p| p.x_scale(Scale::Log10).y_scale(Scale::Log10).legend(Legend::Right).grid(grid));
    let svg = svg_of(&fig);
    let doc = Document::parse(&svg).unwrap();
    let (x0, y0, x1, y1) = frame(&doc, 0);
    let cells = by_class(&doc, "cell");
    assert_eq!(cells.len(), 15);
    for c in &cells {
        let (ix, iy): (usize, usize) =
            (c.attribute("data-ix").unwrap().parse().unwrap(), c.attribute("data-iy").unwrap().parse().unwrap());
        let expected = if ix + iy >= 5 { Color::VERMILLION } else { Color::SKY_BLUE };
        assert_eq!(c.attribute("fill"), Some(expected.to_string().as_str()));
        // Log-spaced centres a factor 2 apart: every cell equally wide, tiling [x0, x1].
        assert!((num(c, "width") - (x1 - x0) / 5.0).abs() < 0.02);
        assert!((num(c, "height") - (y1 - y0) / 3.0).abs() < 0.02);
        assert!((num(c, "x") - (x0 + ix as f64 * (x1 - x0) / 5.0)).abs() < 0.02);
        assert!((num(c, "y") - (y1 - (iy + 1) as f64 * (y1 - y0) / 3.0)).abs() < 0.02);
    }
    let texts = by_class(&doc, "cell-text");
    assert_eq!(texts.len(), 15 - 3);
    assert!(texts.iter().all(|t| text_of(t) == "2.5"));
    // Ticks at the centres, labelled with the values.
    let xt: Vec<String> = by_class(&doc, "xtick").iter().map(text_of).collect();
    assert_eq!(xt, ["0.0025", "0.005", "0.01", "0.02", "0.04"]);
    let yt: Vec<String> = by_class(&doc, "ytick").iter().map(text_of).collect();
    assert_eq!(yt, ["0.1", "1", "10"]);
    // The legend sits right of the plot, not over the cells.
    let legend = doc.descendants().find(|n| n.attribute("class") == Some("legend")).unwrap();
    let rect = legend.children().find(|c| c.is_element()).unwrap();
    assert!(num(&rect, "x") > x1);
    let names: Vec<String> = by_class(&doc, "legend-text").iter().map(text_of).collect();
    assert_eq!(names, ["stable", "unstable"]);
}

#[test]
fn auto_legend_goes_where_it_hides_least() {
    // A line from bottom-left to top-right: the top-left and bottom-right corners are empty,
    // and top-left comes first among the empty ones.
    let mut fig = Figure::new(600, 400);
    fig.panel(|p| p.line("rising", &[0.0, 1.0], &[0.0, 1.0]).line("also rising", &[0.0, 1.0], &[0.05, 1.05]));
    let svg = svg_of(&fig);
    let doc = Document::parse(&svg).unwrap();
    let (x0, y0, x1, _) = frame(&doc, 0);
    let legend = doc.descendants().find(|n| n.attribute("class") == Some("legend")).unwrap();
    let rect = legend.children().find(|c| c.is_element()).unwrap();
    assert!((num(&rect, "x") - (x0 + 8.0)).abs() < 0.01, "legend at the left");
    assert!((num(&rect, "y") - (y0 + 8.0)).abs() < 0.01, "legend at the top");
    assert!(num(&rect, "x") + num(&rect, "width") < x1);

    // A falling line leaves the top-right corner empty: the first choice.
    let mut fig = Figure::new(600, 400);
    fig.panel(|p| p.line("falling", &[0.0, 1.0], &[1.0, 0.0]));
    let svg = svg_of(&fig);
    let doc = Document::parse(&svg).unwrap();
    let (_, y0, x1, _) = frame(&doc, 0);
    let legend = doc.descendants().find(|n| n.attribute("class") == Some("legend")).unwrap();
    let rect = legend.children().find(|c| c.is_element()).unwrap();
    assert!((num(&rect, "x") + num(&rect, "width") - (x1 - 8.0)).abs() < 0.01);
    assert!((num(&rect, "y") - (y0 + 8.0)).abs() < 0.01);
}

#[test]
fn data_outside_a_fixed_range_is_clipped_to_the_frame() {
    let x: Vec<f64> = (0..200).map(|i| i as f64 * 0.05).collect();
    let y: Vec<f64> = x.iter().map(|&x| 3.0 * (x * 2.0).sin()).collect();
    let mut fig = Figure::new(600, 400);
    fig.panel(|p| p.x_range(1.0, 8.0).y_range(-1.0, 1.0).add(Series::line("wild", &x, &y).color(Color::BLACK)));
    let svg = svg_of(&fig);
    let doc = Document::parse(&svg).unwrap();
    let (x0, y0, x1, y1) = frame(&doc, 0);
    let got = line_pieces(&doc, "wild");
    assert!(got.len() > 3, "leaves and re-enters the frame: {} pieces", got.len());
    for p in got.iter().flatten() {
        // Lines are clipped 2 px outside the frame (the clip path trims the rest).
        assert!(p.0 >= x0 - 2.01 && p.0 <= x1 + 2.01 && p.1 >= y0 - 2.01 && p.1 <= y1 + 2.01, "{p:?}");
    }
    assert_eq!(by_class(&doc, "line")[0].attribute("stroke"), Some("#000000"));
}

/// A deterministic pseudo-random sequence in [0, 1).
fn lcg(state: &mut u64) -> f64 {
    *state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    (*state >> 11) as f64 / (1u64 << 53) as f64
}

#[test]
fn hostile_data_gives_a_document_or_an_error_never_a_panic() {
    let specials =
        [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 0.0, -0.0, 1e-310, 1e300, -1e300, f64::MAX, f64::MIN_POSITIVE];
    let mut s = 11;
    let (mut drawn, mut refused) = (0, 0);
    for case in 0..300 {
        let n = (lcg(&mut s) * 30.0) as usize;
        let mut value = || {
            if lcg(&mut s) < 0.3 {
                specials[(lcg(&mut s) * specials.len() as f64) as usize]
            } else {
                (lcg(&mut s) - 0.3) * 10f64.powf(lcg(&mut s) * 40.0 - 20.0)
            }
        };
        let x: Vec<f64> = (0..n).map(|_| value()).collect();
        let y: Vec<f64> = (0..n).map(|_| value()).collect();
        let (a, b) = (value(), value());
        let log = case % 3 == 0;
        let mut fig = Figure::new(500, 300);
        fig.panel(|p| {
            if log {
                p.y_scale(Scale::Log10);
            }
            if case % 4 == 1 {
                p.x_range(a.min(b), a.max(b));
            }
            p.line("l", &x, &y).scatter("s", &y, &x)
        });
        match fig.to_svg_string() {
            Ok(svg) => {
                assert!(!svg.contains("NaN") && !svg.contains("inf"), "case {case}");
                Document::parse(&svg).unwrap_or_else(|e| panic!("case {case}: {e}"));
                drawn += 1;
            }
            Err(e) => {
                assert!(!e.to_string().is_empty());
                refused += 1;
            }
        }
    }
    println!("{drawn} drawn, {refused} refused");
    // Both paths are exercised.
    assert!(drawn >= 50 && refused >= 50, "{drawn} drawn, {refused} refused");
}
