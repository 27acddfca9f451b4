//! What `master statics`, `master modes` and `master run` report, computed in one place for the
//! command line (its text and `--json`) and the Python package (the same JSON, as dicts).

use cable::model::{CableCabin, ModelError, Payload};
use cable::net::CableNet;
use cable::statics::{CableReport, CableState, Equilibrium, StaticsError, form_find};
use feedcore::scene::ValidScene;
use nalgebra::{Matrix6, Vector6};
use serde_json::{Value, json};

use crate::limits::{Footprint, memory_needed, peak_memory};
use crate::simulate::Trace;

/// The form-finding statics of a scene's target pose.
pub struct Statics {
    pub scene: ValidScene,
    pub net: CableNet,
    pub equilibrium: Equilibrium,
}

impl Statics {
    pub fn of(scene: &ValidScene) -> Result<Statics, StaticsError> {
        let net = CableNet::from_scene(scene);
        let equilibrium = form_find(&net, scene.target_position(), scene.target_orientation())?;
        Ok(Statics { scene: scene.clone(), net, equilibrium })
    }

    /// A cable's larger end tension over its breaking load (`None` without `cables.breaking_load_n`).
    pub fn utilisation(&self, cable: &CableReport) -> Option<f64> {
        self.scene.cables.utilisation(cable.largest_tension())
    }

    /// The cables carrying more than their breaking load.
    pub fn overloaded(&self) -> Vec<usize> {
        let cables = &self.equilibrium.cables;
        (0..cables.len()).filter(|&i| self.utilisation(&cables[i]).is_some_and(|u| u > 1.0)).collect()
    }

    /// `master statics --json`.
    pub fn json(&self) -> Value {
        let (eq, scene) = (&self.equilibrium, &self.scene);
        let overloaded = self.overloaded();
        let cables: Vec<_> = eq
            .cables
            .iter()
            .enumerate()
            .map(|(i, c)| {
                json!({
                    "cable": i,
                    "anchor_azimuth_deg": scene.anchors.angle_deg[i],
                    "unstretched_length_m": c.unstretched_length,
                    "tension_anchor_n": c.tension_anchor,
                    "tension_cabin_n": c.tension_cabin,
                    "slack": c.state == CableState::Slack,
                    "nearly_slack": c.state == CableState::NearlySlack,
                    "state": c.state,
                    "lowest_point_z_m": c.lowest_point_z,
                    "utilisation": self.utilisation(c),
                    "overloaded": overloaded.contains(&i),
                    "strain": scene.cables.strain(c.largest_tension()),
                })
            })
            .collect();
        let q = eq.orientation;
        json!({
            "scene": scene.name,
            "cabin_position": eq.position.as_slice(),
            "cabin_orientation": [q.w, q.i, q.j, q.k],
            "suspended_mass_kg": self.net.suspended().mass,
            "residual_n": eq.residual,
            "cables": cables,
        })
    }
}

/// One natural mode as `master modes` lists it.
pub struct Mode {
    pub frequency_hz: f64,
    /// Share of the mode's kinetic energy carried by the cabin.
    pub cabin_share: f64,
    /// `cabin x` … `cabin rz` (its largest component), or `cables`.
    pub motion: String,
    /// The cabin's part of the mass-normalized shape [dx, dy, dz, rx, ry, rz].
    pub cabin_shape: Vector6<f64>,
}

/// The lowest natural modes of a scene (platform locked at its start), with its damping fit and
/// what the analysis cost.
pub struct Modal {
    pub scene: ValidScene,
    pub model: CableCabin,
    pub modes: Vec<Mode>,
    /// Form finding and modal analysis, s.
    pub setup_s: f64,
    pub peak_memory_bytes: Option<u64>,
    pub memory_estimate_bytes: u64,
}

impl Modal {
    /// The lowest `count` modes (the caller checks the memory against its caps first).
    pub fn of(scene: &ValidScene, count: usize) -> Result<Modal, ModelError> {
        let built = CableCabin::modes_built(scene, count);
        let (memory_estimate_bytes, _) = memory_needed(scene, Footprint::CableModel, built);
        let start = std::time::Instant::now();
        let model = CableCabin::build(scene, count)?;
        let setup_s = start.elapsed().as_secs_f64();
        let peak_memory_bytes = peak_memory();
        let found = model.modes.as_ref().ok_or_else(|| ModelError::Modes("no modes were computed".into()))?;
        let sys = model.system(Payload::Locked);
        let eq = &model.equilibrium;
        let cabin_mass = sys
            .body
            .transformed(&eq.orientation.to_rotation_matrix().into_inner(), &eq.position)
            .spatial_matrix_about(&eq.position);
        let modes = (0..count.min(found.frequencies_hz.len()))
            .map(|k| {
                let cabin_shape = found.cabin_part(k);
                let (cabin_share, motion) = describe(&cabin_mass, &cabin_shape);
                Mode { frequency_hz: found.frequencies_hz[k], cabin_share, motion, cabin_shape }
            })
            .collect();
        Ok(Modal { scene: scene.clone(), model, modes, setup_s, peak_memory_bytes, memory_estimate_bytes })
    }

    /// `master modes --json`.
    pub fn json(&self) -> Value {
        let (d, found) = (&self.model.damping, self.model.modes.as_ref());
        let list: Vec<_> = self
            .modes
            .iter()
            .map(|m| {
                json!({"frequency_hz": m.frequency_hz, "cabin_share": m.cabin_share, "motion": m.motion,
                       "cabin_shape": m.cabin_shape.as_slice()})
            })
            .collect();
        json!({
            "scene": self.scene.name,
            "frequencies_hz": self.modes.iter().map(|m| m.frequency_hz).collect::<Vec<_>>(),
            "modes": list,
            "damping": {"ratio": d.ratio, "fit_frequencies_hz": d.frequencies_hz,
                        "alpha_per_s": d.alpha, "beta_s": d.beta},
            "eigen_solver": {"method": "shift-invert Lanczos (M inner product) with a Sturm count",
                             "relative_residual": found.map(|m| m.residual),
                             "stiffness_asymmetry": found.map(|m| m.stiffness_asymmetry),
                             "solves": found.map(|m| m.stats.solves), "passes": found.map(|m| m.stats.passes)},
            "setup_s": self.setup_s,
            "peak_memory_bytes": self.peak_memory_bytes,
            "memory_estimate_bytes": self.memory_estimate_bytes,
        })
    }
}

/// Share of the modal kinetic energy carried by the cabin, and a name for its main motion.
fn describe(cabin_mass: &Matrix6<f64>, shape: &Vector6<f64>) -> (f64, String) {
    let share = shape.dot(&(cabin_mass * shape));
    let names = ["x", "y", "z", "rx", "ry", "rz"];
    // compare translations (m) with rotations times the cabin radius (1 m)
    let k = (0..6).max_by(|a, b| shape[*a].abs().total_cmp(&shape[*b].abs())).unwrap_or(0);
    let what = if share < 0.2 { "cables".to_string() } else { format!("cabin {}", names[k]) };
    (share, what)
}

/// Each cable's larger end tension over its breaking load at the static equilibrium of the
/// target pose, if the scene gives a breaking load.
pub fn static_utilisation(scene: &ValidScene) -> Result<Option<Vec<f64>>, StaticsError> {
    if scene.cables.breaking_load_n.is_none() {
        return Ok(None);
    }
    let statics = Statics::of(scene)?;
    Ok(Some(statics.equilibrium.cables.iter().filter_map(|c| statics.utilisation(c)).collect()))
}

/// `master run --json`: every figure from every step (`dt` and `sample_interval_s` null for an
/// adaptive run), and the static utilisation of [`static_utilisation`] where there is one.
pub fn run_summary(scene: &ValidScene, t: &Trace, utilisation: Option<&[f64]>) -> Value {
    let fixed = |x: f64| if t.is_adaptive() { None } else { Some(x) };
    let mut v = json!({
        "scene": scene.name,
        "scheme": t.method,
        "adaptive": t.is_adaptive(),
        "dt": fixed(t.dt),
        "t_end": t.t_end,
        "steps": t.steps,
        "rejected_steps": t.summary.rejected_steps,
        "h_min_used": t.summary.h_min_used,
        "h_max_used": t.summary.h_max_used,
        "sample_interval_s": fixed(t.sample_interval_s),
        "wall_time_s": t.wall_time_s,
        "max_abs_disp_mm": t.max_abs_disp_mm(),
        "peak_disp_mm": t.peak_mm(),
        "peak_time_s": t.summary.peak_time_s,
        "mean_iterations": t.mean_iterations(),
        "max_interface_residual": t.max_residual(),
        "max_constraint_residual_m": t.constraint_residual(),
    });
    // the feed (scenes with [control]): its error figures and the limits reached
    if let (Some(feed), Some(map)) = (&t.feed, v.as_object_mut()) {
        map.extend(feed.json().as_object().cloned().unwrap_or_default());
    }
    if let Some(u) = utilisation {
        v["cable_utilisation_static"] = json!(u);
    }
    v
}
