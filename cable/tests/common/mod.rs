//! Shared set-up of the integration tests.
#![allow(dead_code)]

use cable::net::CableNet;
use cable::statics::{Equilibrium, form_find};
use feedcore::scene::{Scene, ValidScene};

pub(crate) fn scene(name: &str) -> ValidScene {
    Scene::load(format!("{}/../scenes/{name}", env!("CARGO_MANIFEST_DIR"))).unwrap()
}

pub(crate) fn equilibrium(scene: &ValidScene) -> (CableNet, Equilibrium) {
    let net = CableNet::from_scene(scene);
    let eq = form_find(&net, scene.target_position(), scene.target_orientation()).unwrap();
    (net, eq)
}

/// A deterministic pseudo-random number in [−0.5, 0.5).
pub(crate) struct Rng(pub u64);

impl Rng {
    pub(crate) fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64 / (1u64 << 53) as f64) - 0.5
    }
}
