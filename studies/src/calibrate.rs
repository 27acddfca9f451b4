//! Model updating: numeric scene keys shared by one or more scenes, fitted by least squares to
//! measured natural frequencies.
//!
//! The residual of a measured mode is its relative miss, weighted: `w (f_computed − f_measured) /
//! f_measured`, the k-th measured mode of a scene paired with its k-th computed one. The keys are
//! scaled by their start values; Levenberg–Marquardt steps are projected onto the bounds; the
//! Jacobian is taken by central differences over the modal solver (every difference a model
//! built anew, in parallel). A trial whose scene is invalid, whose pose cannot be held (a cable
//! would push) or that breaks a statement about a tension is a rejected step. From the Jacobian
//! at the fit: the standard errors (with the residuals' own variance), the correlations, and the
//! condition of the problem — a key along a direction the data do not see is named as not
//! identifiable.

use std::path::Path;

use cable::model::CableCabin;
use cable::modes::{Dropped, modes_dropping};
use feedcore::scene::{Scene, SceneError, ValidScene};
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

/// Why a calibration cannot start or go on.
#[derive(Debug, thiserror::Error)]
pub enum CalibrationError {
    #[error("{file}: {reason}")]
    Measured { file: String, reason: String },
    #[error("--fit {key}: {reason}")]
    Key { key: String, reason: String },
    #[error("the model at the start cannot be evaluated, or breaks a --tension statement: {0}")]
    Start(String),
    #[error("--tension: {0}")]
    Tension(String),
    #[error("the Jacobian at the fit cannot be evaluated: {0}")]
    Jacobian(String),
    /// A figure of the fit that is not a finite number: nothing is written.
    #[error("the fit cannot be reported: {0}")]
    NotFinite(String),
}

/// Measured natural frequencies read, Hz: 0.1 ms to 2.8 h periods.
pub const MEASURED_HZ: (f64, f64) = (1e-4, 1e4);
/// Weights of a measured mode.
pub const WEIGHTS: (f64, f64) = (1e-6, 1e6);
/// Measured damping ratios (below 1: a mode, not an overdamped motion).
pub const DAMPING_RATIOS: (f64, f64) = (1e-6, 1.0);
/// Largest magnitude of a measured shape's component, and the least its largest one must have
/// (a shape is relative: any unit, but no overflow or underflow in its products).
pub const SHAPE_MAGNITUDE: (f64, f64) = (1e-12, 1e12);
/// Largest measured file read unless raised, bytes.
pub const MAX_MEASURED_BYTES: u64 = 64 << 20;

/// One measured natural frequency.
#[derive(Clone, Debug, PartialEq)]
pub struct Measured {
    /// The scene's `name`.
    pub scene: String,
    /// From 1, lowest first.
    pub mode: usize,
    pub f_hz: f64,
    pub weight: f64,
    /// The measured damping ratio, if given: the scene's Rayleigh damping at the paired mode is
    /// fitted to it as well (a residual of its own, weighted as the frequency).
    pub zeta: Option<f64>,
    /// The cabin's part of the measured shape (dx, dy, dz, rx, ry, rz), if given: the mode is
    /// then paired with the computed one of the most similar shape, not by its number.
    pub shape: Option<[f64; 6]>,
}

/// The optional columns of a measured shape, in this order.
const SHAPE_COLUMNS: [&str; 6] = ["dx", "dy", "dz", "rx", "ry", "rz"];

/// Computed modes searched beyond the highest measured one when shapes pair them.
const SHAPE_SEARCH: usize = 4;

/// Reads `scene,mode,f_hz[,weight][,zeta][,dx,dy,dz,rx,ry,rz]` (a header line, then one mode per
/// line) from a regular file of at most `max_bytes`, in time linear in its rows. Every number
/// must lie in the range that keeps the fit's cost finite: frequencies in [`MEASURED_HZ`],
/// weights in [`WEIGHTS`], damping ratios in [`DAMPING_RATIOS`] (1 excluded), shapes within
/// [`SHAPE_MAGNITUDE`].
pub fn read_measured(path: &Path, max_bytes: u64) -> Result<Vec<Measured>, CalibrationError> {
    use feedcore::files::{ReadError, read_limited};
    let file = path.display().to_string();
    let err = |reason: String| CalibrationError::Measured { file: file.clone(), reason };
    let bytes = read_limited(path, max_bytes).map_err(|e| match e {
        ReadError::Io(e) => err(format!("cannot read: {e}")),
        ReadError::NotRegular => err("not a regular file (a directory, device or pipe); give a CSV file".into()),
        ReadError::TooLarge { size, limit } => err(format!(
            "the file has {} bytes, more than the limit of {limit} (--max-measured-bytes raises it)",
            ReadError::size_text(size, limit)
        )),
    })?;
    let text = String::from_utf8(bytes)
        .map_err(|e| err(format!("not UTF-8 text (invalid byte at offset {})", e.utf8_error().valid_up_to())))?;
    let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
    let header: Vec<&str> = lines.next().ok_or_else(|| err("empty".into()))?.1.split(',').map(str::trim).collect();
    let expected = "`scene,mode,f_hz`, then optionally `weight`, `zeta`, `dx,dy,dz,rx,ry,rz` in this order";
    let has_weight = header.get(3) == Some(&"weight");
    let zeta_at = if has_weight { 4 } else { 3 };
    let has_zeta = header.get(zeta_at) == Some(&"zeta");
    let shape_at = if has_zeta { zeta_at + 1 } else { zeta_at };
    let has_shape = header.len() == shape_at + 6 && header[shape_at..] == SHAPE_COLUMNS;
    if header.len() < 3
        || header[..3] != ["scene", "mode", "f_hz"]
        || header.len() != shape_at + if has_shape { 6 } else { 0 }
    {
        return Err(err(format!("the header is `{}`; expected {expected}", excerpt(&header.join(",")))));
    }
    let mut out: Vec<Measured> = Vec::new();
    let mut seen = std::collections::HashSet::new();
    let mut fields = Vec::with_capacity(header.len());
    for (i, line) in lines {
        let at = |what: &str| err(format!("line {}: {what}", i + 1));
        fields.clear();
        fields.extend(line.split(',').map(str::trim));
        if fields.len() != header.len() {
            return Err(at(&format!("{} fields, the header has {}", fields.len(), header.len())));
        }
        let mode: usize =
            fields[1].parse().ok().filter(|&m| m >= 1).ok_or_else(|| at("mode must be 1, 2, … (a whole number)"))?;
        let within = |text: &str, name: &str, (lo, hi): (f64, f64), what: &str| {
            text.parse::<f64>().ok().filter(|x| (lo..=hi).contains(x)).ok_or_else(|| {
                at(&format!("{name} = `{}` must be a number in [{lo:e}, {hi:e}] ({what})", excerpt(text)))
            })
        };
        let f_hz = within(fields[2], "f_hz", MEASURED_HZ, "a natural frequency, Hz")?;
        let weight = if has_weight { within(fields[3], "weight", WEIGHTS, "a relative weight")? } else { 1.0 };
        let zeta = if has_zeta {
            let z = within(fields[zeta_at], "zeta", DAMPING_RATIOS, "a damping ratio")?;
            if z >= DAMPING_RATIOS.1 {
                return Err(at(&format!("zeta = `{}` must lie below 1 (a damping ratio)", fields[zeta_at])));
            }
            Some(z)
        } else {
            None
        };
        let shape = if has_shape {
            let mut v = [0.0; 6];
            let (least, most) = SHAPE_MAGNITUDE;
            for (k, x) in v.iter_mut().enumerate() {
                *x = within(fields[shape_at + k], SHAPE_COLUMNS[k], (-most, most), "a shape's component, any unit")?;
            }
            if v.iter().all(|x| x.abs() < least) {
                return Err(at(&format!("the shape is zero (every component below {least:e} in magnitude)")));
            }
            Some(v)
        } else {
            None
        };
        if !seen.insert((fields[0], mode)) {
            return Err(at(&format!("mode {mode} of scene `{}` is given twice", excerpt(fields[0]))));
        }
        out.push(Measured { scene: fields[0].to_owned(), mode, f_hz, weight, zeta, shape });
    }
    if out.is_empty() {
        return Err(err("no measured mode".into()));
    }
    Ok(out)
}

/// `text` as a message quotes it: at most 40 characters, escaped.
fn excerpt(text: &str) -> String {
    let mut out: String = text.chars().take(40).collect::<String>().escape_debug().collect();
    if text.chars().nth(40).is_some() {
        out.push('…');
    }
    out
}

/// A key fitted, with its bounds.
#[derive(Clone, Debug, PartialEq)]
pub struct Key {
    /// Dotted path of a real-valued scene key, e.g. `anchors.radius_m`.
    pub path: String,
    pub lo: f64,
    pub hi: f64,
}

/// The value of the real-valued key `path` of `scene`.
pub fn get_key(scene: &ValidScene, path: &str) -> Result<f64, String> {
    let table: toml::Table = toml::from_str(&scene.to_toml()).map_err(|e| e.to_string())?;
    let mut value = toml::Value::Table(table);
    for part in path.split('.') {
        value = value
            .get(part)
            .cloned()
            .ok_or_else(|| format!("the scene has no key `{path}` (no `{part}` where it is looked for)"))?;
    }
    match value {
        toml::Value::Float(x) => Ok(x),
        toml::Value::Integer(_) => Err(format!("`{path}` is an integer; only real-valued keys can be fitted")),
        other => Err(format!("`{path}` is a {}, not a number", other.type_str())),
    }
}

/// `scene` (read from `file`) with the real-valued key `path` set to `value`, validated.
pub fn with_key(scene: &ValidScene, file: &str, path: &str, value: f64) -> Result<ValidScene, String> {
    with_keys(scene, file, &[(path, value)])
}

/// `scene` (read from `file`) with each real-valued key set to its value, validated once: one
/// pass through the scene's TOML for all of them.
pub fn with_keys(scene: &ValidScene, file: &str, keys: &[(&str, f64)]) -> Result<ValidScene, String> {
    let mut table: toml::Table = toml::from_str(&scene.to_toml()).map_err(|e| e.to_string())?;
    for &(path, value) in keys {
        let parts: Vec<&str> = path.split('.').collect();
        let (last, parents) = parts.split_last().ok_or("an empty key")?;
        let mut here = &mut table;
        for part in parents {
            here = here
                .get_mut(*part)
                .and_then(toml::Value::as_table_mut)
                .ok_or_else(|| format!("the scene has no table `{part}` on the way to `{path}`"))?;
        }
        match here.get_mut(*last) {
            Some(v @ toml::Value::Float(_)) => *v = toml::Value::Float(value),
            _ => return Err(format!("`{path}` is not a real-valued key of the scene")),
        }
    }
    let text = toml::to_string(&table).map_err(|e| e.to_string())?;
    let shown = || keys.iter().map(|(k, v)| format!("{k} = {v}")).collect::<Vec<_>>().join(", ");
    Scene::from_toml(&text, file).map_err(|e| format!("{}: {e}", shown()))
}

/// The lowest `count` natural frequencies (Hz) of `scene`, the platform as the scene has it.
pub fn frequencies(scene: &ValidScene, count: usize) -> Result<Vec<f64>, String> {
    Ok(modal_state(scene, count)?.frequencies_hz)
}

/// The modes of a scene about its static equilibrium, and the cables' tensions there.
struct ModalState {
    frequencies_hz: Vec<f64>,
    /// The cabin's part of each shape.
    cabin_shapes: Vec<[f64; 6]>,
    /// Per cable, the smaller and the larger of its two end tensions (N).
    tensions: Vec<(f64, f64)>,
}

/// The lowest `count` modes of `scene`: frequencies (Hz) and the cabin's part of each shape.
pub fn cabin_modes(scene: &ValidScene, count: usize) -> Result<(Vec<f64>, Vec<[f64; 6]>), String> {
    let m = modal_state(scene, count)?;
    Ok((m.frequencies_hz, m.cabin_shapes))
}

/// The lowest `count` modes of `scene` (frequencies in Hz, the cabin's part of each shape) and
/// the end tensions of the static equilibrium they are taken about.
fn modal_state(scene: &ValidScene, count: usize) -> Result<ModalState, String> {
    let model = modal_scene(scene).map_err(|e| e.to_string())?;
    let model = CableCabin::build(&model, 0).map_err(|e| e.to_string())?;
    let tensions =
        model.equilibrium.cables.iter().map(|c| (c.tension_anchor.min(c.tension_cabin), c.largest_tension())).collect();
    if count == 0 {
        return Ok(ModalState { frequencies_hz: Vec::new(), cabin_shapes: Vec::new(), tensions });
    }
    let sys = model.system(cable::model::Payload::Locked);
    let modes =
        modes_dropping(&sys, &model.equilibrium_config(), count, Dropped::default()).map_err(|e| e.to_string())?;
    let n = modes.frequencies_hz.len().min(count);
    let cabin_shapes = (0..n).map(|k| modes.cabin_part(k).into()).collect();
    Ok(ModalState { frequencies_hz: modes.frequencies_hz.into_iter().take(n).collect(), cabin_shapes, tensions })
}

/// What the model gives for one measured mode.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Computed {
    f_hz: f64,
    /// The computed mode it is paired with, from 1.
    mode: usize,
    /// The scene's Rayleigh damping ratio at that mode (NaN unless a damping ratio is measured).
    zeta: f64,
}

/// The damping ratio of the scene's Rayleigh damping at each frequency of `f` (its modes, lowest
/// first: the fit's modes are among them).
fn damping_ratios(scene: &ValidScene, f: &[f64]) -> Result<Vec<f64>, String> {
    let d = &scene.damping;
    let band = match (d.fit_modes, d.fit_frequencies_hz) {
        (Some([a, b]), _) => [a, b].map(|k| f.get(k - 1).copied()),
        (None, Some(hz)) => hz.map(Some),
        (None, None) => [None, None],
    };
    let [Some(f1), Some(f2)] = band else {
        return Err(format!("{}: the damping's fit frequencies are not available", scene.name));
    };
    let w = |f: f64| 2.0 * std::f64::consts::PI * f;
    let (alpha, beta) = cable::damping::rayleigh_coefficients(d.ratio, w(f1), w(f2));
    Ok(f.iter().map(|&fk| alpha / (2.0 * w(fk)) + beta * w(fk) / 2.0).collect())
}

/// The modal assurance criterion of two shapes: 1 for the same shape, 0 for orthogonal ones.
fn mac(a: &[f64; 6], b: &[f64; 6]) -> f64 {
    let dot = |x: &[f64; 6], y: &[f64; 6]| x.iter().zip(y).map(|(p, q)| p * q).sum::<f64>();
    let (ab, aa, bb) = (dot(a, b), dot(a, a), dot(b, b));
    if aa > 0.0 && bb > 0.0 { ab * ab / (aa * bb) } else { 0.0 }
}

/// A statement the fit must keep about a cable's tension in a scene's static equilibrium, e.g.
/// "cable 4 nearly slack at B": its larger end tension at most `at_most`; "all taut": each one's
/// smaller end tension at least `at_least`.
#[derive(Clone, Debug, PartialEq)]
pub struct TensionBound {
    /// The scene's `name`.
    pub scene: String,
    /// From 0, as the statics number them.
    pub cable: usize,
    pub at_most: Option<f64>,
    pub at_least: Option<f64>,
}

impl TensionBound {
    /// Reads `SCENE:CABLE<=N` or `SCENE:CABLE>=N` (cables from 0, newtons).
    pub fn parse(text: &str) -> Result<TensionBound, String> {
        let bad = || format!("`{text}`: expected SCENE:CABLE<=NEWTONS or SCENE:CABLE>=NEWTONS (cables from 0)");
        let (scene, rest) = text.split_once(':').ok_or_else(bad)?;
        let (cable, value, at_most) = if let Some((c, v)) = rest.split_once("<=") {
            (c, v, true)
        } else if let Some((c, v)) = rest.split_once(">=") {
            (c, v, false)
        } else {
            return Err(bad());
        };
        let cable: usize = cable.trim().parse().map_err(|_| bad())?;
        let value: f64 = value.trim().parse().ok().filter(|v: &f64| v.is_finite() && *v >= 0.0).ok_or_else(bad)?;
        let scene = scene.trim().to_owned();
        let (at_most, at_least) = if at_most { (Some(value), None) } else { (None, Some(value)) };
        Ok(TensionBound { scene, cable, at_most, at_least })
    }

    /// `None` if the tensions keep the statement, else how they break it.
    fn broken(&self, tensions: &[(f64, f64)]) -> Option<String> {
        let (low, high) = tensions.get(self.cable).copied().unwrap_or((f64::NAN, f64::NAN));
        let (cable, scene) = (self.cable, &self.scene);
        match (self.at_most, self.at_least) {
            (Some(max), _) if !(high <= max) => {
                Some(format!("cable {cable} of {scene} holds {high:.1} N, above {max} N"))
            }
            (_, Some(min)) if !(low >= min) => {
                Some(format!("cable {cable} of {scene} holds {low:.1} N, below {min} N"))
            }
            _ => None,
        }
    }
}

/// The scene for a modal analysis: its damping fitted at given frequencies, so that building the
/// model does not compute modes of its own.
pub fn modal_scene(scene: &ValidScene) -> Result<ValidScene, SceneError> {
    scene.edited(|bare| {
        bare.damping.fit_modes = None;
        bare.damping.fit_frequencies_hz = Some([1.0, 2.0]);
    })
}

/// A scaled key moved to one side for a difference, and the residuals there.
type Side = (f64, DVector<f64>);

/// The scenes, the measured modes and the keys of one calibration.
pub struct Problem {
    /// Each scene with the file it was read from.
    pub scenes: Vec<(ValidScene, String)>,
    pub measured: Vec<Measured>,
    /// Where the measured modes came from (for messages).
    pub measured_file: String,
    /// Statements about tensions every trial must keep.
    pub tensions: Vec<TensionBound>,
    pub keys: Vec<Key>,
}

/// A fitted calibration.
#[derive(Clone, Debug)]
pub struct Fit {
    /// Per key: the start value and the fitted one.
    pub start: Vec<f64>,
    pub values: Vec<f64>,
    /// Keys that ended on one of their bounds (the data would move them further), or where no step
    /// either way keeps the statements about tensions.
    pub at_bound: Vec<String>,
    /// Standard errors of the keys within their bounds (none for a key at a bound; none at all
    /// with no more residuals than free keys, whose variance is then unknown, or with a key the
    /// data do not determine).
    pub std_error: Option<Vec<Option<f64>>>,
    /// Correlations of the keys within their bounds (row-major over all keys; none where a key is
    /// at a bound), with the standard errors.
    pub correlation: Option<Vec<Option<f64>>>,
    /// Singular values of the scaled Jacobian, largest first, and its condition number.
    pub singular_values: Vec<f64>,
    pub condition: f64,
    /// Keys along the directions the data do not see (singular value below 1e-6 of the largest).
    pub unidentifiable: Vec<String>,
    /// Per measured mode (in the order given): the computed frequency at the fit, and the number
    /// of the computed mode it is paired with (from 1).
    pub computed_hz: Vec<f64>,
    pub paired_mode: Vec<usize>,
    /// Per measured mode with a measured damping ratio: the scene's at the paired mode (NaN for
    /// the others).
    pub computed_zeta: Vec<f64>,
    /// Half the sum of the squared weighted relative misses, at the start and at the fit.
    pub start_cost: f64,
    pub cost: f64,
    pub iterations: usize,
    /// Each scene with the fitted keys.
    pub scenes: Vec<ValidScene>,
}

impl Fit {
    /// Every figure the fit reports is a finite number, or an error says which is not and why.
    fn check_finite(&self, keys: &[Key], measured: &[Measured]) -> Result<(), CalibrationError> {
        let not_finite = |what: String| Err(CalibrationError::NotFinite(what));
        if !self.condition.is_finite() {
            let keys = if self.unidentifiable.is_empty() { "a key".to_owned() } else { self.unidentifiable.join(", ") };
            return not_finite(format!(
                "the measured modes do not change with {keys} at all (the scaled Jacobian is singular, its \
                 condition infinite): fit without it, or measure what depends on it"
            ));
        }
        for (name, x) in [("the cost at the start", self.start_cost), ("the cost", self.cost)] {
            if !x.is_finite() {
                return not_finite(format!("{name} is {x}"));
            }
        }
        for (k, v) in keys.iter().zip(&self.values) {
            if !v.is_finite() {
                return not_finite(format!("the fitted {} is {v}", k.path));
            }
        }
        let errors = self.std_error.iter().flatten().zip(keys);
        if let Some((e, k)) = errors.filter_map(|(e, k)| Some((e.as_ref()?, k))).find(|(e, _)| !e.is_finite()) {
            return not_finite(format!("the standard error of {} is {e}", k.path));
        }
        if self.correlation.iter().flatten().flatten().any(|c| !c.is_finite()) {
            return not_finite("a correlation of the keys is not a number".into());
        }
        for (i, m) in measured.iter().enumerate() {
            let zeta = if m.zeta.is_some() { self.computed_zeta[i] } else { 0.0 };
            if !self.computed_hz[i].is_finite() || !zeta.is_finite() {
                return not_finite(format!(
                    "the computed mode paired with scene `{}` mode {} is not finite",
                    m.scene, m.mode
                ));
            }
        }
        Ok(())
    }
}

impl Problem {
    /// Checks the keys, their bounds and the measured scenes' names before anything is computed.
    pub fn check(&self) -> Result<Vec<f64>, CalibrationError> {
        for m in &self.measured {
            if let Some((s, file)) = self.scenes.iter().find(|(s, _)| s.name == m.scene) {
                let unknowns = CableCabin::unknowns(s);
                if m.mode > unknowns {
                    return Err(CalibrationError::Measured {
                        file: self.measured_file.clone(),
                        reason: format!(
                            "scene `{}` ({file}) has {unknowns} degrees of freedom, so no mode {}",
                            m.scene, m.mode
                        ),
                    });
                }
            } else {
                let names: Vec<String> = self.scenes.iter().map(|(s, _)| format!("`{}`", s.name)).collect();
                return Err(CalibrationError::Measured {
                    file: self.measured_file.clone(),
                    reason: format!(
                        "scene `{}` is not among the scenes given (their `name`s: {})",
                        m.scene,
                        names.join(", ")
                    ),
                });
            }
        }
        for t in &self.tensions {
            let Some((s, file)) = self.scenes.iter().find(|(s, _)| s.name == t.scene) else {
                return Err(CalibrationError::Tension(format!("scene `{}` is not among the scenes given", t.scene)));
            };
            if t.cable >= s.cable_count() {
                let last = s.cable_count() - 1;
                return Err(CalibrationError::Tension(format!("{file} has cables 0 to {last}, not {}", t.cable)));
            }
        }
        let mut start = Vec::new();
        for k in &self.keys {
            let key_err = |reason: String| CalibrationError::Key { key: k.path.clone(), reason };
            let mut value = None;
            for (s, file) in &self.scenes {
                let v = get_key(s, &k.path).map_err(|e| key_err(format!("{file}: {e}")))?;
                if value.is_some_and(|x| x != v) {
                    return Err(key_err(format!(
                        "the scenes differ in it ({} and {v}); a fitted key is shared by every scene",
                        value.unwrap_or_default()
                    )));
                }
                value = Some(v);
            }
            let v = value.ok_or_else(|| key_err("no scene given".into()))?;
            if !(v != 0.0) {
                return Err(key_err("its start value is 0; keys are scaled by their start values".into()));
            }
            if !(k.lo <= v && v <= k.hi) {
                return Err(key_err(format!("the start value {v} lies outside the bounds [{}, {}]", k.lo, k.hi)));
            }
            start.push(v);
        }
        Ok(start)
    }

    /// The scenes with the keys at `values`.
    fn scenes_at(&self, values: &[f64]) -> Result<Vec<ValidScene>, String> {
        self.scenes
            .iter()
            .map(|(s, file)| {
                let keys: Vec<(&str, f64)> =
                    self.keys.iter().map(|k| k.path.as_str()).zip(values.iter().copied()).collect();
                with_keys(s, file, &keys)
            })
            .collect()
    }

    /// What the model gives for every measured mode, with the keys at `values`: the computed mode
    /// paired with it (by number, or by the most similar shape where the measured shape is given,
    /// each computed mode paired once), its frequency and, where a damping ratio is measured, the
    /// scene's Rayleigh damping ratio at it.
    fn computed(&self, values: &[f64]) -> Result<Vec<Computed>, String> {
        let scenes = self.scenes_at(values)?;
        let mut out = vec![Computed { f_hz: f64::NAN, mode: 0, zeta: f64::NAN }; self.measured.len()];
        for s in &scenes {
            let mine: Vec<usize> = (0..self.measured.len()).filter(|&i| self.measured[i].scene == s.name).collect();
            let by_shape = mine.iter().any(|&i| self.measured[i].shape.is_some());
            let highest = mine.iter().map(|&i| self.measured[i].mode).max().unwrap_or(0);
            let mut count = if by_shape { highest + SHAPE_SEARCH } else { highest };
            // measured damping: the modes the scene's Rayleigh damping is fitted at too
            let with_zeta = mine.iter().any(|&i| self.measured[i].zeta.is_some());
            if let (true, Some(fit)) = (with_zeta, s.damping.fit_modes) {
                count = count.max(fit[0]).max(fit[1]);
            }
            let ModalState { frequencies_hz: f, cabin_shapes: shapes, tensions } =
                modal_state(s, count).map_err(|e| format!("{}: {e}", s.name))?;
            if let Some(broken) = self.tensions.iter().filter(|t| t.scene == s.name).find_map(|t| t.broken(&tensions)) {
                return Err(broken);
            }
            let zeta = if with_zeta { damping_ratios(s, &f)? } else { vec![f64::NAN; f.len()] };
            let mut pair = |i: usize, k: usize| out[i] = Computed { f_hz: f[k], mode: k + 1, zeta: zeta[k] };
            if by_shape {
                // the most similar pairs first, each measured and each computed mode once
                let mut pairs: Vec<(f64, usize, usize)> = mine
                    .iter()
                    .flat_map(|&i| {
                        let shape = self.measured[i].shape.expect("every row of the file has a shape");
                        shapes.iter().enumerate().map(move |(k, c)| (mac(&shape, c), i, k))
                    })
                    .collect();
                pairs.sort_by(|a, b| b.0.total_cmp(&a.0));
                let mut taken = vec![false; shapes.len()];
                let mut done = vec![false; self.measured.len()];
                for (_, i, k) in pairs {
                    if !done[i] && !taken[k] {
                        pair(i, k);
                        (done[i], taken[k]) = (true, true);
                    }
                }
            } else {
                for &i in &mine {
                    let k = self.measured[i].mode - 1;
                    if k >= f.len() {
                        return Err(format!("{}: only {} modes found", s.name, f.len()));
                    }
                    pair(i, k);
                }
            }
            if let Some(&i) = mine.iter().find(|&&i| out[i].mode == 0) {
                return Err(format!(
                    "{}: no computed mode left to pair with measured mode {}",
                    s.name, self.measured[i].mode
                ));
            }
        }
        Ok(out)
    }

    /// The weighted relative misses: every measured frequency, then every measured damping ratio.
    fn residuals(&self, computed: &[Computed]) -> DVector<f64> {
        let frequencies = self.measured.iter().zip(computed).map(|(m, c)| m.weight * (c.f_hz - m.f_hz) / m.f_hz);
        let damping =
            self.measured.iter().zip(computed).filter_map(|(m, c)| m.zeta.map(|z| m.weight * (c.zeta - z) / z));
        let all: Vec<f64> = frequencies.chain(damping).collect();
        DVector::from_vec(all)
    }

    /// ∂r/∂x, x the keys over their start values, by central differences (one-sided at a bound
    /// or where one side cannot be evaluated), and the keys that cannot move either way (held by
    /// a bound and a statement about a tension): their columns are zero.
    fn jacobian(&self, start: &[f64], x: &[f64]) -> Result<(DMatrix<f64>, Vec<usize>), String> {
        const STEP: f64 = 1e-5;
        let n = x.len();
        let evaluate = |j: usize, sign: f64| -> Option<Side> {
            let mut xs = x.to_vec();
            xs[j] += sign * STEP;
            let (lo, hi) = (self.keys[j].lo / start[j], self.keys[j].hi / start[j]);
            if xs[j] < lo.min(hi) || xs[j] > lo.max(hi) {
                return None;
            }
            let values: Vec<f64> = xs.iter().zip(start).map(|(x, s)| x * s).collect();
            self.computed(&values).ok().map(|c| (xs[j], self.residuals(&c)))
        };
        let sides: Vec<(Option<Side>, Option<Side>)> =
            (0..n).into_par_iter().map(|j| (evaluate(j, 1.0), evaluate(j, -1.0))).collect();
        let center = || -> Result<DVector<f64>, String> {
            let values: Vec<f64> = x.iter().zip(start).map(|(x, s)| x * s).collect();
            Ok(self.residuals(&self.computed(&values)?))
        };
        let rows = self.measured.len() + self.measured.iter().filter(|m| m.zeta.is_some()).count();
        let mut jac = DMatrix::zeros(rows, n);
        let mut held = Vec::new();
        for (j, side) in sides.into_iter().enumerate() {
            let column = match side {
                (Some((a, ra)), Some((b, rb))) => (ra - rb) / (a - b),
                (Some((a, ra)), None) => (ra - center()?) / (a - x[j]),
                (None, Some((b, rb))) => (center()? - rb) / (x[j] - b),
                (None, None) => {
                    held.push(j);
                    continue;
                }
            };
            jac.set_column(j, &column);
        }
        Ok((jac, held))
    }

    /// Fits the keys (Levenberg–Marquardt on the scaled keys, steps projected onto the bounds).
    pub fn fit(&self) -> Result<Fit, CalibrationError> {
        let start = self.check()?;
        let n = start.len();
        let bounds: Vec<(f64, f64)> = self
            .keys
            .iter()
            .zip(&start)
            .map(|(k, s)| {
                let (a, b) = (k.lo / s, k.hi / s);
                (a.min(b), a.max(b))
            })
            .collect();
        // the keys' values, within their bounds exactly (x · start may round past one)
        let at = |x: &[f64]| -> Vec<f64> {
            x.iter().zip(&start).zip(&self.keys).map(|((x, s), k)| (x * s).clamp(k.lo, k.hi)).collect()
        };
        let mut x = vec![1.0; n];
        let computed = self.computed(&start).map_err(CalibrationError::Start)?;
        let mut r = self.residuals(&computed);
        let start_cost = 0.5 * r.norm_squared();
        let mut cost = start_cost;
        let mut lambda = 1e-3;
        let mut iterations = 0;
        let mut converged = false;
        while !converged && iterations < 100 {
            iterations += 1;
            let (jac, _) = self.jacobian(&start, &x).map_err(CalibrationError::Jacobian)?;
            let jtj = jac.transpose() * &jac;
            let g = jac.transpose() * &r;
            // a step that lowers the cost, the damping raised until one does
            let mut step_taken = false;
            while !step_taken && lambda < 1e12 {
                let mut a = jtj.clone();
                for i in 0..n {
                    a[(i, i)] += lambda * jtj[(i, i)].max(1e-12);
                }
                let Some(step) = a.cholesky().map(|c| c.solve(&(-&g))) else {
                    lambda *= 4.0;
                    continue;
                };
                let trial: Vec<f64> = (0..n).map(|i| (x[i] + step[i]).clamp(bounds[i].0, bounds[i].1)).collect();
                // an invalid scene or a pose the cables cannot hold is a step too far
                let lower = self
                    .computed(&at(&trial))
                    .ok()
                    .map(|c| self.residuals(&c))
                    .filter(|rt| 0.5 * rt.norm_squared() < cost);
                match lower {
                    Some(rt) => {
                        let moved = trial.iter().zip(&x).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
                        let ct = 0.5 * rt.norm_squared();
                        converged = moved < 1e-10 || cost - ct < 1e-14 * (1.0 + ct);
                        (x, r, cost) = (trial, rt, ct);
                        lambda = (lambda / 3.0).max(1e-12);
                        step_taken = true;
                    }
                    None => lambda *= 4.0,
                }
            }
            // no step lowers the cost: a minimum (within the bounds)
            converged |= !step_taken;
        }
        let values = at(&x);
        let (full, held) = self.jacobian(&start, &x).map_err(CalibrationError::Jacobian)?;
        // the keys held by a bound and a statement are out of the problem at the fit
        let movable: Vec<usize> = (0..n).filter(|j| !held.contains(j)).collect();
        let jac = DMatrix::from_fn(full.nrows(), movable.len(), |i, j| full[(i, movable[j])]);
        let svd = jac.clone().svd(false, true);
        let mut singular_values: Vec<f64> = svd.singular_values.iter().copied().collect();
        singular_values.sort_by(|a, b| b.total_cmp(a));
        let largest = singular_values.first().copied().unwrap_or(0.0);
        let smallest = singular_values.last().copied().unwrap_or(0.0);
        let condition = if smallest > 0.0 { largest / smallest } else { f64::INFINITY };
        let v_t = svd.v_t.expect("asked for");
        let mut unidentifiable = Vec::new();
        for (i, s) in svd.singular_values.iter().enumerate() {
            if *s <= 1e-6 * largest {
                // the keys that make up this unseen direction
                for (j, &key) in movable.iter().enumerate() {
                    if v_t[(i, j)].abs() > 0.1 && !unidentifiable.contains(&self.keys[key].path) {
                        unidentifiable.push(self.keys[key].path.clone());
                    }
                }
            }
        }
        // keys on a bound are held there; the errors are those of the free keys
        let at_bound: Vec<String> = self
            .keys
            .iter()
            .zip(&values)
            .enumerate()
            .filter(|(j, (k, v))| **v == k.lo || **v == k.hi || held.contains(j))
            .map(|(_, (k, _))| k.path.clone())
            .collect();
        let free: Vec<usize> = (0..n).filter(|&j| !at_bound.contains(&self.keys[j].path)).collect();
        let m = r.len();
        let sub = DMatrix::from_fn(m, free.len(), |i, j| full[(i, free[j])]);
        let (std_error, correlation) = match (sub.transpose() * &sub).try_inverse() {
            Some(inv) if m > free.len() && unidentifiable.is_empty() => {
                let s2 = r.norm_squared() / (m - free.len()) as f64;
                let position = |j: usize| free.iter().position(|&f| f == j);
                let sd = (0..n).map(|j| position(j).map(|p| (s2 * inv[(p, p)]).sqrt() * start[j].abs())).collect();
                let corr = (0..n * n)
                    .map(|ij| {
                        let (p, q) = (position(ij / n)?, position(ij % n)?);
                        Some(inv[(p, q)] / (inv[(p, p)] * inv[(q, q)]).sqrt())
                    })
                    .collect();
                (Some(sd), Some(corr))
            }
            _ => (None, None),
        };
        let computed = self.computed(&values).map_err(CalibrationError::Jacobian)?;
        let computed_hz = computed.iter().map(|c| c.f_hz).collect();
        let paired_mode = computed.iter().map(|c| c.mode).collect();
        let computed_zeta = computed.iter().map(|c| c.zeta).collect();
        let scenes = self.scenes_at(&values).map_err(CalibrationError::Jacobian)?;
        let fit = Fit {
            start,
            values,
            at_bound,
            std_error,
            correlation,
            singular_values,
            condition,
            unidentifiable,
            computed_hz,
            paired_mode,
            computed_zeta,
            start_cost,
            cost,
            iterations,
            scenes,
        };
        fit.check_finite(&self.keys, &self.measured)?;
        Ok(fit)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str, text: &[u8]) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("master-measured-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        path
    }

    fn read(name: &str, text: &str) -> Result<Vec<Measured>, String> {
        read_measured(&scratch(name, text.as_bytes()), MAX_MEASURED_BYTES).map_err(|e| e.to_string())
    }

    /// Every numeric column at its edges and beyond: the ends of its range are read, every value
    /// outside (zero, subnormal, huge, infinite, NaN, not a number) is refused naming the line,
    /// the column and the value.
    #[test]
    fn every_column_is_read_within_its_range_and_refused_beyond() {
        let header = "scene,mode,f_hz,weight,zeta,dx,dy,dz,rx,ry,rz";
        let good = ["C", "1", "0.47", "1", "0.005", "1", "0", "0", "0", "0", "0"];
        let line = |column: usize, value: &str| {
            let mut cells = good.map(String::from);
            cells[column] = value.to_owned();
            format!("{header}\n{}\n", cells.join(","))
        };
        assert_eq!(read("good.csv", &line(2, "0.47")).unwrap().len(), 1);
        let beyond =
            ["0", "-0", "5e-324", "1e-300", "1e300", "inf", "-inf", "NaN", "", "x", "1e", "99999999999999999999e999"];
        let cases: [(usize, &str, &[&str], &[&str]); 4] = [
            (2, "f_hz", &["1e-4", "1e4"], &["9e-5", "1.1e4", "-1"]),
            (3, "weight", &["1e-6", "1e6"], &["9e-7", "1.1e6", "-1"]),
            (4, "zeta", &["1e-6", "0.999"], &["9e-7", "1", "1.5", "-0.1"]),
            (5, "dx", &["-1e12", "1e12", "1e-12"], &["1.1e12", "-1.1e12"]),
        ];
        for (column, name, edges, outside) in cases {
            for v in edges {
                let m = read("edge.csv", &line(column, v)).unwrap_or_else(|e| panic!("{name} = {v}: {e}"));
                assert_eq!(m.len(), 1);
            }
            for v in outside.iter().chain(&beyond) {
                if column == 5 && ["0", "-0", "5e-324", "1e-300"].contains(v) {
                    // a zero component is fine in a shape; the shape below is what is refused
                    continue;
                }
                let e = read("beyond.csv", &line(column, v)).expect_err(&format!("{name} = {v}"));
                assert!(e.contains("line 2") && e.contains(name), "{name} = {v}: {e}");
            }
        }
        for column in 6..11 {
            let name = SHAPE_COLUMNS[column - 5];
            for v in beyond.iter().filter(|v| !["0", "-0", "5e-324", "1e-300"].contains(v)) {
                let e = read("beyond.csv", &line(column, v)).expect_err(&format!("{name} = {v}"));
                assert!(e.contains(name), "{name} = {v}: {e}");
            }
        }
        let tiny = format!("{header}\nC,1,0.47,1,0.005,1e-13,0,0,0,0,-1e-300\n");
        assert!(read("zero.csv", &tiny).unwrap_err().contains("the shape is zero"));
        for mode in ["0", "-1", "1.5", "x", "18446744073709551616"] {
            let e = read("mode.csv", &line(1, mode)).expect_err(mode);
            assert!(e.contains("line 2") && e.contains("mode"), "{e}");
        }
    }

    /// Only regular files within the size limit are read: a directory, a FIFO (which would
    /// block), a device that never ends or reads empty, a file over the limit, bytes that are
    /// not text are refused by name.
    #[test]
    fn only_regular_text_files_within_the_limit_are_read() {
        let dir = std::env::temp_dir().join(format!("master-measured-files-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let fifo = dir.join("fifo.csv");
        let _ = std::fs::remove_file(&fifo);
        assert!(std::process::Command::new("mkfifo").arg(&fifo).status().unwrap().success());
        for path in [dir.as_path(), fifo.as_path(), Path::new("/dev/zero"), Path::new("/dev/null")] {
            let e = read_measured(path, MAX_MEASURED_BYTES).unwrap_err().to_string();
            assert!(e.contains(&path.display().to_string()) && e.contains("not a regular file"), "{e}");
        }
        let text = "scene,mode,f_hz\nC,1,0.47\n";
        let file = scratch("limit.csv", text.as_bytes());
        let e = read_measured(&file, 10).unwrap_err().to_string();
        assert!(e.contains("limit of 10") && e.contains("--max-measured-bytes"), "{e}");
        assert_eq!(read_measured(&file, text.len() as u64).unwrap().len(), 1);
        let e = read_measured(&scratch("binary.csv", b"scene,mode,f_hz\n\xff\xfe\x00"), 1000).unwrap_err().to_string();
        assert!(e.contains("not UTF-8"), "{e}");
        let e = read("missing.csv", "").unwrap_err();
        assert!(e.contains("empty"), "{e}");
    }

    /// A million measured modes are read in one pass (duplicates found by hashing, not by
    /// comparing every pair); the one given twice is named.
    #[test]
    fn a_million_rows_are_read_in_linear_time() {
        let mut text = String::from("scene,mode,f_hz\n");
        for k in 1..=1_000_000 {
            text.push_str(&format!("C,{k},0.5\n"));
        }
        assert_eq!(read("million.csv", &text).unwrap().len(), 1_000_000);
        text.push_str("C,999999,0.5\n");
        let e = read("million.csv", &text).unwrap_err();
        assert!(e.contains("line 1000002") && e.contains("mode 999999"), "{e}");
    }
}
