//! One module per subcommand. Each has an `Args` struct (clap) and `run(&Args)`; the shared
//! pieces: scheme options, output files written whole or not at all, and the caps every command
//! obeys (set once from the global flags).

use std::path::Path;
use std::sync::OnceLock;

use anyhow::Context;
use feedcore::scene::{Scene, SceneErrorKind, ValidScene};
use studies::limits::Limits;

pub(crate) mod args;
pub(crate) mod bench;
pub(crate) mod calibrate;
pub(crate) mod compare;
pub(crate) mod compensation;
pub(crate) mod design;
pub(crate) mod export_ssp;
pub(crate) mod modes;
pub(crate) mod output;
pub(crate) mod package;
pub(crate) mod replay;
pub(crate) mod reproduce;
pub(crate) mod run;
pub(crate) mod run_system;
pub(crate) mod scaling;
pub(crate) mod scheme_args;
pub(crate) mod stability;
pub(crate) mod statics;
pub(crate) mod stewart;
pub(crate) mod stress;
pub(crate) mod sweep;
pub(crate) mod tune;

/// Errors reach the user with their whole chain of causes.
pub(crate) type CmdResult = anyhow::Result<()>;

/// The result of the commands not yet moved to anyhow (package, replay).
pub(crate) type BoxResult = Result<(), Box<dyn std::error::Error>>;

/// A [`BoxResult`] as a [`CmdResult`] (the message chain kept as text).
pub(crate) fn boxed(r: BoxResult) -> CmdResult {
    r.map_err(|e| anyhow::Error::new(studies::simulate::Detached::of(&*e)))
}

/// Caps from the global flags (`--max-steps`, `--max-memory-mb`, `--max-scene-bytes`).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Caps {
    pub(crate) run: Limits,
    pub(crate) scene_bytes: u64,
}

static CAPS: OnceLock<Caps> = OnceLock::new();

/// Sets the caps once, before any command runs.
pub(crate) fn set_caps(caps: Caps) {
    let _ = CAPS.set(caps);
}

pub(crate) fn caps() -> Caps {
    *CAPS.get_or_init(|| Caps { run: Limits::default(), scene_bytes: feedcore::scene::MAX_SCENE_BYTES })
}

/// The digest of a scene as parsed: parts of one sweep, and a journal and the work it belongs
/// to, must share it.
pub(crate) fn fingerprint(scene: &ValidScene) -> String {
    format!("{:016x}", fmi::digest::digest(scene.to_toml().as_bytes()))
}

/// Reads a scene within the size cap; a file over it names the flag that raises it.
pub(crate) fn load_scene(path: &Path) -> anyhow::Result<ValidScene> {
    match Scene::load_limited(path, caps().scene_bytes) {
        Ok(s) => Ok(s),
        Err(e) if matches!(e.kind, SceneErrorKind::TooLarge { .. }) => {
            Err(e).context("a scene file this large is refused; raise the limit with --max-scene-bytes if it is meant")
        }
        Err(e) => Err(e.into()),
    }
}
