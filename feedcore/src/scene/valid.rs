//! A scene that passed validation: immutable, cheap to share, with what validation established
//! kept in typed form so that no model has to trust an `Option` or re-parse a text.

use std::ops::Deref;
use std::sync::Arc;

use super::{Checked, Scene, SceneError};
use crate::{Quat, Vec3};

/// A validated scene. It cannot be changed: [`ValidScene::edited`] makes a new one, validated
/// again. Clones share one copy, so every model of a run reads the same scene.
#[derive(Clone, Debug)]
pub struct ValidScene(Arc<Compiled>);

#[derive(Debug)]
struct Compiled {
    scene: Scene,
    /// Where the scene came from, for the errors of edits.
    file: String,
    orientation: Quat,
    target: Option<ControlTarget>,
    damping_fit: DampingFit,
}

/// Where the Rayleigh damping is fitted to `damping.ratio`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DampingFit {
    /// At two natural modes (1-based, ascending).
    Modes([usize; 2]),
    /// At two frequencies, Hz (ascending).
    Frequencies([f64; 2]),
}

/// The compensation's target path, world frame, from the feed's start position.
#[derive(Clone, Debug, PartialEq)]
pub enum ControlTarget {
    /// Stay at the start position.
    Hold,
    /// A horizontal circle through the start position, counter-clockwise about world Z.
    Circle { center_offset: Vec3, speed: f64 },
    /// Displacements at ascending times, held before the first and after the last.
    Samples { times: Vec<f64>, displacements: Vec<Vec3> },
}

impl Scene {
    /// Validates the scene (`file` names it in errors) and freezes it.
    pub fn validated(self, file: &str) -> Result<ValidScene, SceneError> {
        let Checked { orientation, target, damping_fit } = self.check(file)?;
        let file = file.to_string();
        Ok(ValidScene(Arc::new(Compiled { scene: self, file, orientation, target, damping_fit })))
    }
}

impl ValidScene {
    /// The file (or label) the scene was read from.
    pub fn file(&self) -> &str {
        &self.0.file
    }

    /// A copy to change and validate again ([`Scene::validated`]).
    pub fn to_scene(&self) -> Scene {
        self.0.scene.clone()
    }

    /// A copy changed by `edit`, validated again (errors name this scene's file).
    pub fn edited(&self, edit: impl FnOnce(&mut Scene)) -> Result<ValidScene, SceneError> {
        let mut scene = self.0.scene.clone();
        edit(&mut scene);
        scene.validated(&self.0.file)
    }

    /// Target orientation of the cabin (body to world).
    pub fn target_orientation(&self) -> Quat {
        self.0.orientation
    }

    /// Where the Rayleigh damping is fitted.
    pub fn damping_fit(&self) -> DampingFit {
        self.0.damping_fit
    }

    /// The compensation's target path; `None` without `[control]`.
    pub fn control_target(&self) -> Option<&ControlTarget> {
        self.0.target.as_ref()
    }
}

impl Deref for ValidScene {
    type Target = Scene;
    fn deref(&self) -> &Scene {
        &self.0.scene
    }
}

impl PartialEq for ValidScene {
    fn eq(&self, other: &ValidScene) -> bool {
        self.0.scene == other.0.scene
    }
}
