//! The result files of one command, written whole or not at all.
//!
//! Every output is declared before the run starts ([`Outputs::declare`]): its extension checked,
//! refused if it names an input of the run or another output. [`Outputs::open`] then creates the
//! directories and a temporary file beside each output, so that an unwritable place fails at
//! once, naming the path. Results go to the temporary files; [`Outputs::commit`] renames them
//! all into place at the end. A command that fails after opening its outputs removes the
//! temporary files and also the files an earlier run left under the same names: no file that
//! looks current outlives a failed run. (A refused declaration touches nothing.)

use std::fs::File;
use std::io::Write;
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};

struct Planned {
    flag: String,
    path: PathBuf,
    temp: PathBuf,
}

/// The declared outputs of one command.
pub(crate) struct Outputs {
    files: Vec<Planned>,
    inputs: Vec<PathBuf>,
    opened: bool,
    committed: bool,
}

/// An output declared in an [`Outputs`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct OutputId(usize);

/// `path` made absolute with its directory resolved (symbolic links followed) when it exists.
fn resolved(path: &Path) -> PathBuf {
    if let Ok(p) = std::fs::canonicalize(path) {
        return p;
    }
    let absolute = std::path::absolute(path).unwrap_or_else(|_| path.to_owned());
    match (absolute.parent(), absolute.file_name()) {
        (Some(dir), Some(name)) => std::fs::canonicalize(dir).map_or(absolute.clone(), |d| d.join(name)),
        _ => absolute,
    }
}

/// Whether two paths name the same file (the same inode if both exist).
fn same_file(a: &Path, b: &Path) -> bool {
    match (std::fs::metadata(a), std::fs::metadata(b)) {
        (Ok(x), Ok(y)) => x.dev() == y.dev() && x.ino() == y.ino(),
        _ => resolved(a) == resolved(b),
    }
}

impl Outputs {
    /// Outputs of a run that reads `inputs` (scene file, FMU archives, …), which no output may
    /// name.
    pub(crate) fn new(inputs: impl IntoIterator<Item = PathBuf>) -> Outputs {
        Outputs { files: Vec::new(), inputs: inputs.into_iter().collect(), opened: false, committed: false }
    }

    /// Declares the output `path` given by `flag`; `extension`: the one it must have.
    pub(crate) fn declare(&mut self, flag: &str, path: &Path, extension: Option<&str>) -> anyhow::Result<OutputId> {
        let shown = path.display();
        if let Some(ext) = extension
            && path.extension().and_then(|e| e.to_str()) != Some(ext)
        {
            bail!("{flag} {shown}: only {} is written here; name the file *.{ext}", ext.to_uppercase());
        }
        if let Some(input) = self.inputs.iter().find(|i| same_file(i, path)) {
            bail!("{flag} {shown}: this is an input of the run ({}); choose another output file", input.display());
        }
        if let Some(other) = self.files.iter().find(|f| same_file(&f.path, path)) {
            bail!(
                "{flag} {shown}: the same file as {} {}; give each output its own file",
                other.flag,
                other.path.display()
            );
        }
        if path.is_dir() {
            bail!("{flag} {shown}: is a directory; give a file name");
        }
        path.file_name().with_context(|| format!("{flag} {shown}: no file name"))?;
        let temp = studies::tempfiles::beside(path);
        self.files.push(Planned { flag: flag.to_string(), path: path.to_owned(), temp });
        Ok(OutputId(self.files.len() - 1))
    }

    /// Creates the directories and the temporary files of every declared output (and removes
    /// those a killed run of any command left for the same outputs).
    pub(crate) fn open(&mut self) -> anyhow::Result<()> {
        for f in &self.files {
            let dir = f.temp.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
            let shown = f.path.display();
            std::fs::create_dir_all(dir)
                .with_context(|| format!("{} {shown}: cannot create the directory {}", f.flag, dir.display()))?;
            studies::tempfiles::remove_stale(&f.path);
            File::create(&f.temp).with_context(|| format!("{} {shown}: cannot write in {}", f.flag, dir.display()))?;
        }
        self.opened = true;
        Ok(())
    }

    /// Writes the content of output `id` (to its temporary file).
    pub(crate) fn write(
        &self,
        id: OutputId,
        content: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
    ) -> anyhow::Result<()> {
        let f = &self.files[id.0];
        let context = || format!("{} {}: writing failed", f.flag, f.path.display());
        let mut file = std::io::BufWriter::new(File::create(&f.temp).with_context(context)?);
        content(&mut file).with_context(context)?;
        file.into_inner().map_err(|e| e.into_error()).and_then(|f| f.sync_all()).with_context(context)
    }

    /// A writer to output `id` (its temporary file) for content written as it comes; hand it
    /// back to [`Outputs::finish`].
    pub(crate) fn stream(&self, id: OutputId) -> anyhow::Result<std::io::BufWriter<File>> {
        let f = &self.files[id.0];
        let file = File::create(&f.temp).with_context(|| format!("{} {}: writing failed", f.flag, f.path.display()))?;
        Ok(std::io::BufWriter::new(file))
    }

    /// Flushes a writer from [`Outputs::stream`] to disk.
    pub(crate) fn finish(&self, id: OutputId, w: std::io::BufWriter<File>) -> anyhow::Result<()> {
        let f = &self.files[id.0];
        w.into_inner()
            .map_err(|e| e.into_error())
            .and_then(|file| file.sync_all())
            .with_context(|| format!("{} {}: writing failed", f.flag, f.path.display()))
    }

    /// The final path of output `id`.
    pub(crate) fn path(&self, id: OutputId) -> &Path {
        &self.files[id.0].path
    }

    /// Moves every output into place.
    pub(crate) fn commit(mut self) -> anyhow::Result<()> {
        for f in &self.files {
            std::fs::rename(&f.temp, &f.path)
                .with_context(|| format!("{} {}: cannot move the result into place", f.flag, f.path.display()))?;
        }
        self.committed = true;
        Ok(())
    }
}

impl Drop for Outputs {
    fn drop(&mut self) {
        if self.committed {
            return;
        }
        for f in &self.files {
            let _ = std::fs::remove_file(&f.temp);
            if self.opened && f.path.is_file() && std::fs::remove_file(&f.path).is_ok() {
                eprintln!(
                    "note: removed {} from an earlier run so that it is not taken for this one's",
                    f.path.display()
                );
            }
        }
    }
}

/// The files a run of `scene_file` reads: the scene and the FMU archives of its [system].
pub(crate) fn run_inputs(scene_file: &Path, scene: &feedcore::scene::Scene) -> Vec<PathBuf> {
    let base = scene_file.parent().unwrap_or(Path::new(""));
    let fmus = scene.system.iter().flat_map(|s| s.fmus.iter()).map(|f| base.join(&f.path));
    std::iter::once(scene_file.to_owned()).chain(fmus).collect()
}
