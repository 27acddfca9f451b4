//! The paper's possible linearisations of the modal analysis (docs/reproduction.md, "Table 2"):
//! hypotheses that each leave out physics, the platform locked, added or absent, another E.
//! For comparisons with the paper only: the full tangent stiffness is the physics.

use cable::model::CableCabin;
use cable::modes::{Dropped, modes_dropping, straight_cable_frequencies};
use feedcore::scene::{SceneError, StewartMode, ValidScene};
use serde_json::{Value, json};

use crate::options::Named;
use crate::table::Table;

/// Linearisations the paper's Table 2 may have used; every one leaves out physics.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Hypothesis {
    /// The full tangent stiffness (the physics).
    Full,
    /// Without `Σ [pᵢ]×[dᵢ]×`, the stiffness of the cable-end forces turning with the cabin.
    NoRotationalGeometricStiffness,
    /// Without `−[m g]×[c]×`, the stiffness of the weight acting at the turning centre of mass.
    NoWeightRotationalStiffness,
    /// Without both (K stays symmetric: at equilibrium their unsymmetric parts cancel).
    NoRotationalLoadStiffness,
    /// The cabin on six massless straight cables (axial EA/L₀ and geometric T/L stiffness): six modes.
    StraightCables,
    /// As straight-cables without the cables' geometric stiffness T/L: six modes.
    StraightCablesNoGeometricStiffness,
}

impl Named for Hypothesis {
    const ALL: &'static [Hypothesis] = &[
        Hypothesis::Full,
        Hypothesis::NoRotationalGeometricStiffness,
        Hypothesis::NoWeightRotationalStiffness,
        Hypothesis::NoRotationalLoadStiffness,
        Hypothesis::StraightCables,
        Hypothesis::StraightCablesNoGeometricStiffness,
    ];

    fn name(self) -> &'static str {
        match self {
            Hypothesis::Full => "full",
            Hypothesis::NoRotationalGeometricStiffness => "no-rotational-geometric-stiffness",
            Hypothesis::NoWeightRotationalStiffness => "no-weight-rotational-stiffness",
            Hypothesis::NoRotationalLoadStiffness => "no-rotational-load-stiffness",
            Hypothesis::StraightCables => "straight-cables",
            Hypothesis::StraightCablesNoGeometricStiffness => "straight-cables-no-geometric-stiffness",
        }
    }

    fn help(self) -> &'static str {
        match self {
            Hypothesis::Full => "The full tangent stiffness (the physics)",
            Hypothesis::NoRotationalGeometricStiffness => {
                "Without Σ [pᵢ]×[dᵢ]×, the stiffness of the cable-end forces turning with the cabin"
            }
            Hypothesis::NoWeightRotationalStiffness => {
                "Without −[m g]×[c]×, the stiffness of the weight acting at the turning centre of mass"
            }
            Hypothesis::NoRotationalLoadStiffness => {
                "Without both (K stays symmetric: at equilibrium their unsymmetric parts cancel)"
            }
            Hypothesis::StraightCables => {
                "The cabin on six massless straight cables (axial EA/L₀ and geometric T/L stiffness): six modes"
            }
            Hypothesis::StraightCablesNoGeometricStiffness => {
                "As straight-cables without the cables' geometric stiffness T/L: six modes"
            }
        }
    }
}

/// How the Stewart platform enters the modal analysis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Platform {
    /// Rigidly attached at its start pose (its mass, centre of mass and inertia).
    Locked,
    /// Its mass added to the cabin's at the cabin centre point (no offset, no added inertia).
    AddedMass,
    /// Left out (neither its weight nor its inertia).
    Absent,
}

impl Named for Platform {
    const ALL: &'static [Platform] = &[Platform::Locked, Platform::AddedMass, Platform::Absent];

    fn name(self) -> &'static str {
        match self {
            Platform::Locked => "locked",
            Platform::AddedMass => "added-mass",
            Platform::Absent => "absent",
        }
    }

    fn help(self) -> &'static str {
        match self {
            Platform::Locked => "Rigidly attached at its start pose (its mass, centre of mass and inertia)",
            Platform::AddedMass => {
                "Its mass added to the cabin's at the cabin centre point (no offset, no added inertia)"
            }
            Platform::Absent => "Left out (neither its weight nor its inertia)",
        }
    }
}

/// The scene as a modal case sees it: the platform as `platform` says, E replaced.
pub fn case_scene(
    scene: &ValidScene,
    platform: Platform,
    youngs_modulus: Option<f64>,
) -> Result<ValidScene, SceneError> {
    let platform_mass = scene.stewart_geometry().total_mass();
    scene.edited(|s| {
        if let Some(e) = youngs_modulus {
            s.cables.youngs_modulus_pa = e;
        }
        match platform {
            Platform::Locked => {}
            Platform::AddedMass => {
                s.cabin.mass_kg += platform_mass;
                s.analyses.stewart = StewartMode::Absent;
            }
            Platform::Absent => s.analyses.stewart = StewartMode::Absent,
        }
    })
}

/// The lowest `count` frequencies (Hz) of `scene` under a hypothesis, platform and modulus
/// (the straight-cable models have six).
pub fn case_frequencies(
    scene: &ValidScene,
    hypothesis: Hypothesis,
    platform: Platform,
    youngs_modulus: Option<f64>,
    count: usize,
) -> anyhow::Result<Vec<f64>> {
    let s = case_scene(scene, platform, youngs_modulus)?;
    let model = CableCabin::build(&crate::calibrate::modal_scene(&s)?, 0)?;
    let sys = model.system(cable::model::Payload::Locked);
    let cfg = model.equilibrium_config();
    let dropped = |cable_end_rotation, weight_rotation| Dropped { cable_end_rotation, weight_rotation };
    let f = match hypothesis {
        Hypothesis::Full => modes_dropping(&sys, &cfg, count, Dropped::default())?.frequencies_hz,
        Hypothesis::NoRotationalGeometricStiffness => {
            modes_dropping(&sys, &cfg, count, dropped(true, false))?.frequencies_hz
        }
        Hypothesis::NoWeightRotationalStiffness => {
            modes_dropping(&sys, &cfg, count, dropped(false, true))?.frequencies_hz
        }
        Hypothesis::NoRotationalLoadStiffness => modes_dropping(&sys, &cfg, count, dropped(true, true))?.frequencies_hz,
        Hypothesis::StraightCables => straight_cable_frequencies(&sys, &cfg, true),
        Hypothesis::StraightCablesNoGeometricStiffness => straight_cable_frequencies(&sys, &cfg, false),
    };
    Ok(f.into_iter().take(count).collect())
}

/// The frequencies of one case: the report of `master modes` with a hypothesis, another
/// platform or another E.
pub struct Case {
    pub scene: String,
    pub hypothesis: Hypothesis,
    pub platform: Platform,
    pub youngs_modulus: f64,
    pub frequencies_hz: Vec<f64>,
}

impl Case {
    /// The lowest `count` frequencies of `scene` under the hypothesis, platform and modulus.
    pub fn of(
        scene: &ValidScene,
        hypothesis: Hypothesis,
        platform: Platform,
        youngs_modulus: Option<f64>,
        count: usize,
    ) -> anyhow::Result<Case> {
        Ok(Case {
            scene: scene.name.clone(),
            hypothesis,
            platform,
            youngs_modulus: youngs_modulus.unwrap_or(scene.cables.youngs_modulus_pa),
            frequencies_hz: case_frequencies(scene, hypothesis, platform, youngs_modulus, count)?,
        })
    }

    pub fn json(&self) -> Value {
        json!({"scene": self.scene, "hypothesis": self.hypothesis.name(), "platform": self.platform.name(),
               "youngs_modulus_pa": self.youngs_modulus, "frequencies_hz": self.frequencies_hz})
    }

    pub fn text(&self) -> String {
        let mut text = format!(
            "Natural frequencies of {} under the hypothesis {} (platform {}, E = {:e} Pa)\n",
            self.scene,
            self.hypothesis.name(),
            self.platform.name(),
            self.youngs_modulus
        );
        text.push_str("A comparison with the paper's linearisation, not the physics: docs/reproduction.md.\n\n");
        let mut t = Table::new(["mode", "f Hz"]);
        for (k, f) in self.frequencies_hz.iter().enumerate() {
            t.row([(k + 1).to_string(), format!("{f:.5}")]);
        }
        text.push_str(&t.render());
        text
    }
}
