//! The reference scenes compiled into the programs. The FMUs ship them in `resources/` and fall
//! back on these copies when they were given no resource location.

use std::path::Path;

use crate::scene::{Scene, ValidScene};

/// (file name, text) of every shipped scene.
pub const SCENES: [(&str, &str); 3] = [
    ("lt50m_B.toml", include_str!("../../scenes/lt50m_B.toml")),
    ("lt50m_C.toml", include_str!("../../scenes/lt50m_C.toml")),
    ("lt50m_C_compensated.toml", include_str!("../../scenes/lt50m_C_compensated.toml")),
];

/// The text of a shipped scene.
pub fn embedded(name: &str) -> Option<&'static str> {
    SCENES.iter().find(|(n, _)| *n == name).map(|(_, text)| *text)
}

/// The scene a `scene` parameter names: an absolute path, a path relative to `resources`, or
/// one of the shipped scenes. Errors name the file and what is wrong with it.
pub fn load_scene_parameter(name: &str, resources: Option<&Path>) -> Result<ValidScene, String> {
    let p = Path::new(name);
    let path = if p.is_absolute() { Some(p.to_owned()) } else { resources.map(|r| r.join(p)) };
    match (path, embedded(name)) {
        (Some(p), _) if p.is_file() => Scene::load(&p).map_err(|e| e.to_string()),
        (_, Some(text)) => Scene::from_toml(text, name).map_err(|e| e.to_string()),
        (Some(p), None) => Err(format!("scene file {} does not exist", p.display())),
        (None, None) => Err(format!("scene `{name}` is relative but the FMU was given no resource location")),
    }
}
