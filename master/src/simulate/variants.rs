//! Scene variants written to private files so that the FMUs read them.

use std::path::Path;

use feedcore::scene::Scene;

/// Where this process writes its scene variants.
fn variants_dir() -> std::path::PathBuf {
    std::env::temp_dir().join(format!("master-variants-{}", std::process::id()))
}

/// Removes the scene variants this process wrote (when its command ends, however it ends).
pub fn remove_variants() {
    let _ = std::fs::remove_dir_all(variants_dir());
}

/// Writes `scene` (a variant of the one read from `scene_file`) to a private file, with the FMU
/// paths of its `[system]` made absolute, so that the FMUs read this variant; returns the variant
/// and its file.
pub fn write_variant(scene: &Scene, scene_file: &Path, tag: &str) -> std::io::Result<(Scene, std::path::PathBuf)> {
    let mut s = scene.clone();
    if let Some(sys) = s.system.as_mut() {
        let base = scene_file.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        for f in &mut sys.fmus {
            let p = Path::new(&f.path);
            if !p.is_absolute() {
                f.path = std::fs::canonicalize(base)?.join(p).display().to_string();
            }
        }
    }
    let dir = variants_dir();
    std::fs::create_dir_all(&dir)?;
    let file = dir.join(format!("{tag}.toml"));
    std::fs::write(&file, s.to_toml())?;
    Ok((s, file))
}
