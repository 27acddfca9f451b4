//! SSP 1.0 system structure descriptions: read ([`read`]: `.ssp` archives, `.ssd` files with
//! `.ssv` parameter files) and written ([`write`](mod@write): `.ssp` archives with their FMUs).

pub mod read;
pub mod write;

/// The type of this master's SSP annotation (opt-in; SSP 1.0 lets a tool ignore annotations it
/// does not know): `<ssc:Annotation type="org.feedsim.adaptive">` in the `<ssd:System>`'s
/// `<ssd:Annotations>`, holding one `<Adaptive>` element with `<Watch name="component.variable"/>`
/// elements — the quantities an adaptive step should judge its error by (names or prefixes, as
/// `--watch` takes them).
pub const ADAPTIVE_ANNOTATION: &str = "org.feedsim.adaptive";

/// The type of this master's SSP annotation that says the system's motion starts with a kink
/// (e.g. at full speed), which the FMUs' initialization cannot see: `<Start kink="true"/>`; a
/// master may then take the first macro step in substeps ([`crate::Coupled::step_from_start`]).
pub const START_ANNOTATION: &str = "org.feedsim.start";

/// The type of this master's SSP annotation that says which interface of an FMU offering both
/// a component should run as, in the `<ssd:Component>`'s `<ssd:Annotations>`: `<Interface
/// implementation="ModelExchange"/>` (or `CoSimulation`). Unlike SSP's own `implementation`
/// attribute, which every importer must obey (and one without Model Exchange must refuse), it
/// is a preference: a tool that does not know it skips it and runs the system as it would.
pub const INTERFACE_ANNOTATION: &str = "org.feedsim.interface";

/// The annotation type of a component's communication step, as libcosim (the Open Simulation
/// Platform's engine) reads it from an SSP system: `<ssc:Annotation
/// type="com.opensimulationplatform"><osp:StepSizeHint value="0.01"/></ssc:Annotation>` in the
/// `<ssd:Component>`'s `<ssd:Annotations>`, the step in seconds. This master steps the component at
/// that period, which must be a whole multiple of the run's macro step; tools that do not know the
/// annotation step it at their own.
pub const STEP_ANNOTATION: &str = "com.opensimulationplatform";

/// The namespace of the `osp:` elements of [`STEP_ANNOTATION`].
pub const OSP_NAMESPACE: &str = "http://opensimulationplatform.com/SSP/OSPAnnotations";

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// A private directory, removed with its contents on drop.
pub(crate) struct TempDir(PathBuf);

impl TempDir {
    pub(crate) fn new(stem: &str) -> std::io::Result<TempDir> {
        static COUNTER: AtomicU64 = AtomicU64::new(0);
        loop {
            let n = COUNTER.fetch_add(1, Ordering::Relaxed);
            let dir = std::env::temp_dir().join(format!("cosim-{stem}-{}-{n}", std::process::id()));
            match std::fs::create_dir(&dir) {
                Ok(()) => return Ok(TempDir(dir)),
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
                Err(e) => return Err(e),
            }
        }
    }

    pub(crate) fn path(&self) -> &Path {
        &self.0
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}
