//! Files a model reads through a String parameter (e.g. a scene): where they may come from and
//! how much of them may reach a log.
//!
//! A relative name resolves inside the FMU's `resources/` directory and nowhere else (no `..`
//! escape, no symbolic link out of it); an absolute name is the importer's explicit choice. A
//! name the FMU ships is also found without a resource location. A `data:` URI
//! ([`crate::uri::data_uri`]) hands the text itself over, with a name for messages. Files are read up to a size
//! limit, and an error quotes at most a short, escaped excerpt of what was read.

use std::io::Read;
use std::path::{Component, Path, PathBuf};

use crate::export::Resource;

/// Why a resource could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ResourceError {
    #[error("`{name}` leaves the FMU's resources/ directory (relative names must stay inside it)")]
    Outside { name: String },
    #[error("`{name}` is relative but the FMU was given no resource location")]
    NoLocation { name: String },
    #[error("{path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
    #[error("{path}: larger than {limit} bytes; not a file this FMU reads")]
    TooLarge { path: PathBuf, limit: u64 },
    #[error("{path}: not UTF-8 text")]
    NotText { path: PathBuf },
    #[error("{origin}: {message}")]
    Invalid { origin: String, message: String },
    #[error(
        "the state was saved with a text given inline (digest {saved:016x}) and the parameter now holds \
         {now}: set the parameter to that text before restoring the state"
    )]
    InlineChanged { saved: u64, now: String },
    #[error(
        "`{name}` is not the file the state was saved with (its contents changed, or another file took its \
         name; digest {now:016x}, saved {saved:016x}): restore the state with the file as it was"
    )]
    Changed { name: String, saved: u64, now: u64 },
}

/// Text of the resource `name`: relative names inside `resources` (or one of `shipped`, the
/// copies compiled into the binary, when there is no such file or no location), absolute names
/// as given. Returns the text and where it came from (for messages).
pub(crate) fn read_text(
    name: &str,
    resources: Option<&Path>,
    shipped: &[(&str, &str)],
    limit: u64,
) -> Result<(String, String), ResourceError> {
    if let Some(inline) = crate::uri::parse_data_uri(name) {
        let (label, text) =
            inline.map_err(|message| ResourceError::Invalid { origin: "the text given inline".into(), message })?;
        let origin = inline_label(&label);
        if text.len() as u64 > limit {
            return Err(ResourceError::TooLarge { path: PathBuf::from(origin), limit });
        }
        return Ok((text, origin));
    }
    let embedded = shipped.iter().find(|(n, _)| *n == name).map(|(_, t)| *t);
    let path = Path::new(name);
    let file = if path.is_absolute() {
        Some(path.to_owned())
    } else {
        if path.components().any(|c| !matches!(c, Component::Normal(_))) {
            return Err(ResourceError::Outside { name: name.to_owned() });
        }
        match resources {
            Some(dir) => Some(dir.join(path)).filter(|p| p.exists() || embedded.is_none()),
            None if embedded.is_some() => None,
            None => return Err(ResourceError::NoLocation { name: name.to_owned() }),
        }
    };
    let Some(file) = file else {
        return Ok((embedded.unwrap_or_default().to_owned(), format!("{name} (shipped)")));
    };
    if !path.is_absolute()
        && let Some(dir) = resources
    {
        // A symbolic link may still point out of resources/: compare the real paths.
        let io = |source| ResourceError::Io { path: file.clone(), source };
        let (real_dir, real_file) = (dir.canonicalize().map_err(io)?, file.canonicalize().map_err(io)?);
        if !real_file.starts_with(&real_dir) {
            return Err(ResourceError::Outside { name: name.to_owned() });
        }
    }
    let io = |source| ResourceError::Io { path: file.clone(), source };
    // Asked before opening: opening a FIFO blocks until someone writes to it.
    if !std::fs::metadata(&file).map_err(io)?.is_file() {
        return Err(io(std::io::Error::other("not a regular file")));
    }
    let f = std::fs::File::open(&file).map_err(io)?;
    if !f.metadata().map_err(io)?.is_file() {
        return Err(io(std::io::Error::other("not a regular file")));
    }
    let mut bytes = Vec::new();
    f.take(limit + 1).read_to_end(&mut bytes).map_err(io)?;
    if bytes.len() as u64 > limit {
        return Err(ResourceError::TooLarge { path: file, limit });
    }
    let text = String::from_utf8(bytes).map_err(|_| ResourceError::NotText { path: file.clone() })?;
    Ok((text, file.display().to_string()))
}

/// How messages name a text given inline with this `name` parameter.
fn inline_label(name: &str) -> String {
    if name.is_empty() { "the text given inline".to_owned() } else { format!("{name} (given inline)") }
}

/// How messages name the resource `name`: itself, or for a `data:` URI its `name` parameter.
fn label_of(name: &str) -> String {
    match crate::uri::parse_data_uri(name) {
        Some(Ok((label, _))) => inline_label(&label),
        Some(Err(_)) => inline_label(""),
        None => name.to_owned(),
    }
}

/// The resource `name` (see [`read_text`]) parsed by `parse(text, origin)`; a parse error is
/// reported as a short escaped excerpt, so a log never shows more of a file than that.
pub(crate) fn load_parsed<T, E: std::fmt::Display>(
    name: &str,
    resources: Option<&Path>,
    shipped: &[(&str, &str)],
    limit: u64,
    parse: impl FnOnce(&str, &str) -> Result<T, E>,
) -> Result<(T, u64), ResourceError> {
    let (text, origin) = read_text(name, resources, shipped, limit)?;
    let digest = crate::digest::digest(text.as_bytes());
    let value =
        parse(&text, &origin).map_err(|e| ResourceError::Invalid { origin, message: excerpt(&e.to_string(), 300) })?;
    Ok((value, digest))
}

/// One kind of file a model reads through a String parameter (a scene, a configuration).
pub struct FileKind<T, E> {
    shipped: &'static [(&'static str, &'static str)],
    limit: u64,
    parse: fn(&str, &str) -> Result<T, E>,
}

impl<T, E: std::fmt::Display> FileKind<T, E> {
    /// Files of this kind: `shipped` are copies compiled into the binary as (name, text) (also
    /// found without a resource location, and written to `resources/` by [`FileKind::resources`]);
    /// at most `limit` bytes are read; `parse(text, origin)` reads one (`origin` names the file).
    pub const fn new(
        shipped: &'static [(&'static str, &'static str)],
        limit: u64,
        parse: fn(&str, &str) -> Result<T, E>,
    ) -> Self {
        FileKind { shipped, limit, parse }
    }

    /// The shipped copies, for the FMU's `resources/` directory.
    pub fn resources(&self) -> Vec<Resource> {
        Resource::texts(self.shipped)
    }

    /// The file `name`, read and parsed, as the value of a parameter; `resources`: the FMU's
    /// `resources/` directory, if the importer gave one.
    pub fn open(&'static self, resources: Option<&Path>, name: &str) -> Result<FileParameter<T, E>, ResourceError> {
        let (value, digest) = self.load(name, resources)?;
        let (name, label) = (name.to_owned(), label_of(name));
        Ok(FileParameter { kind: self, resources: resources.map(Path::to_owned), name, label, value, digest })
    }

    fn load(&self, name: &str, resources: Option<&Path>) -> Result<(T, u64), ResourceError> {
        load_parsed(name, resources, self.shipped, self.limit, self.parse)
    }
}

/// What a saved state keeps as the name of a text given inline: the text is known by its digest
/// alone (a state does not carry a copy of it), and restored where that text is set.
const INLINE_NAME: &str = "data:";

/// A file parameter in a saved state: the name, and the digest of the text read then.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SavedFile<'a> {
    pub name: &'a str,
    digest: u64,
}

/// A [`SavedFile`] that owns its name, for a state kept in memory.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct KeptFile {
    name: String,
    digest: u64,
}

impl KeptFile {
    /// Keeps `saved` (this value's storage reused).
    pub fn keep(&mut self, saved: SavedFile<'_>) {
        self.name.clear();
        self.name.push_str(saved.name);
        self.digest = saved.digest;
    }

    pub fn saved(&self) -> SavedFile<'_> {
        SavedFile { name: &self.name, digest: self.digest }
    }
}

/// A model's state kept in memory (`save_in_memory`): its file parameter and its own data `D`,
/// the storage reused from one save to the next.
pub struct KeptState<D> {
    file: KeptFile,
    data: Option<D>,
}

impl<D: Clone + Send + 'static> KeptState<D> {
    /// Keeps `file` and `data` in `slot`, reusing what it holds if it holds such a state; true
    /// once kept.
    pub fn save_into(slot: &mut Option<Box<dyn std::any::Any + Send>>, file: SavedFile<'_>, data: &D) -> bool {
        if !slot.as_ref().is_some_and(|b| b.is::<KeptState<D>>()) {
            *slot = Some(Box::new(KeptState::<D> { file: KeptFile::default(), data: None }));
        }
        let Some(kept) = slot.as_mut().and_then(|b| b.downcast_mut::<KeptState<D>>()) else {
            return false;
        };
        kept.file.keep(file);
        match &mut kept.data {
            Some(held) => held.clone_from(data),
            empty => *empty = Some(data.clone()),
        }
        true
    }

    /// The file and the data `save_into` kept in `slot`; `model` names the model in the error
    /// for a slot that holds another model's state.
    pub fn kept<'a>(slot: &'a (dyn std::any::Any + Send), model: &str) -> Result<(SavedFile<'a>, &'a D), String> {
        let kept = slot.downcast_ref::<KeptState<D>>().ok_or_else(|| format!("not a state of {model}"))?;
        let data = kept.data.as_ref().ok_or_else(|| format!("an empty state of {model}"))?;
        Ok((kept.file.saved(), data))
    }
}

/// A String parameter naming a file, and the file as parsed: a model keeps one per such
/// parameter, and the name in its saved state.
pub struct FileParameter<T: 'static, E: 'static> {
    kind: &'static FileKind<T, E>,
    resources: Option<PathBuf>,
    name: String,
    /// What messages call it: the name, or a `data:` URI's `name` parameter.
    label: String,
    value: T,
    /// Of the text read: a saved state keeps it with the name, to be restored with that file only.
    digest: u64,
}

impl<T, E: std::fmt::Display> FileParameter<T, E> {
    /// The name as set.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// What messages call it: the name, or for a text given inline (a `data:` URI) its `name`
    /// parameter.
    pub fn label(&self) -> &str {
        &self.label
    }

    /// The file as parsed.
    pub fn value(&self) -> &T {
        &self.value
    }

    /// Names another file, read and parsed now (so a missing or malformed file is the setter's
    /// error, and the parameter is unchanged then). Returns whether the name changed; the same
    /// name is not read again.
    pub fn set(&mut self, name: &str) -> Result<bool, ResourceError> {
        if name == self.name {
            return Ok(false);
        }
        (self.value, self.digest) = self.kind.load(name, self.resources.as_deref())?;
        (self.name, self.label) = (name.to_owned(), label_of(name));
        Ok(true)
    }

    /// The parameter as a saved state keeps it.
    pub fn saved(&self) -> SavedFile<'_> {
        let name = if self.inline() { INLINE_NAME } else { &self.name };
        SavedFile { name, digest: self.digest }
    }

    /// Whether the text was given inline (a `data:` URI) rather than named.
    fn inline(&self) -> bool {
        crate::uri::is_data_uri(&self.name)
    }

    /// As [`FileParameter::set`], from a saved state: the file must be the one the state was
    /// saved with (same digest), else [`ResourceError::Changed`] and the parameter is unchanged.
    pub fn restore(&mut self, saved: SavedFile<'_>) -> Result<bool, ResourceError> {
        let SavedFile { name, digest } = saved;
        if name == INLINE_NAME {
            return match (self.inline(), self.digest == digest) {
                (true, true) => Ok(false),
                (true, false) => {
                    Err(ResourceError::InlineChanged { saved: digest, now: format!("another ({})", self.label) })
                }
                (false, _) => Err(ResourceError::InlineChanged { saved: digest, now: format!("`{}`", self.name) }),
            };
        }
        let changed = |now| ResourceError::Changed { name: label_of(name), saved: digest, now };
        if name == self.name {
            return if self.digest == digest { Ok(false) } else { Err(changed(self.digest)) };
        }
        let (value, now) = self.kind.load(name, self.resources.as_deref())?;
        if now != digest {
            return Err(changed(now));
        }
        (self.value, self.digest, self.name, self.label) = (value, now, name.to_owned(), label_of(name));
        Ok(true)
    }
}

/// A message about a file's contents, cut to `max` characters, every control character
/// escaped: what a log may show of a file the FMU was pointed at.
pub(crate) fn excerpt(message: &str, max: usize) -> String {
    let mut out = String::new();
    for (i, c) in message.chars().enumerate() {
        if i == max {
            out.push('…');
            break;
        }
        if c.is_control() {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plain(text: &str, _origin: &str) -> Result<String, String> {
        Ok(text.to_owned())
    }

    static NOTES: FileKind<String, String> = FileKind::new(&[], 100, plain);

    #[test]
    fn a_text_given_inline_is_read_as_a_file_would_be() {
        let uri = crate::uri::data_uri("text/plain", "note.txt", "a b\nc");
        let mut p = NOTES.open(None, &uri).unwrap();
        assert_eq!((p.value().as_str(), p.label(), p.name()), ("a b\nc", "note.txt (given inline)", uri.as_str()));
        // a saved state keeps its digest, not a copy: it restores where the same text is set
        let saved = p.saved();
        assert_eq!(saved.name, "data:");
        let (saved_name, digest) = (saved.name.to_owned(), p.digest);
        let mut same = NOTES.open(None, &uri).unwrap();
        assert!(!same.restore(SavedFile { name: &saved_name, digest }).unwrap());
        let mut other = NOTES.open(None, &crate::uri::data_uri("text/plain", "", "other")).unwrap();
        assert_eq!(other.label(), "the text given inline");
        let e = other.restore(SavedFile { name: &saved_name, digest }).unwrap_err().to_string();
        assert!(e.contains("set the parameter to that text") && e.contains("the text given inline"), "{e}");
        assert_eq!(other.value().as_str(), "other", "unchanged");
        assert!(!p.set(&uri).unwrap(), "the same text is not read again");
        let big = crate::uri::data_uri("text/plain", "big.txt", &"x".repeat(101));
        let e = NOTES.open(None, &big).err().unwrap().to_string();
        assert!(e.contains("big.txt (given inline)") && e.contains("100 bytes"), "{e}");
        let e = NOTES.open(None, "data:text/plain;base64,eA==").err().unwrap().to_string();
        assert!(e.contains("base64"), "{e}");
    }

    fn dir(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("fmi2-res-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(d.join("resources/sub")).unwrap();
        std::fs::write(d.join("secret.txt"), "root:x:0:0\n").unwrap();
        std::fs::write(d.join("resources/sub/a.txt"), "a").unwrap();
        d
    }

    #[test]
    fn relative_names_stay_inside_resources() {
        let d = dir("inside");
        let res = d.join("resources");
        assert_eq!(read_text("sub/a.txt", Some(&res), &[], 10).unwrap().0, "a");
        for bad in ["../secret.txt", "sub/../../secret.txt", "./sub/a.txt"] {
            let e = read_text(bad, Some(&res), &[], 100).unwrap_err();
            assert!(matches!(e, ResourceError::Outside { .. }), "{bad}: {e}");
            assert!(!e.to_string().contains("root:x"), "{e}");
        }
        std::os::unix::fs::symlink(d.join("secret.txt"), res.join("link.txt")).unwrap();
        let e = read_text("link.txt", Some(&res), &[], 100).unwrap_err();
        assert!(matches!(e, ResourceError::Outside { .. }), "{e}");
        // an absolute name is the importer's explicit choice
        assert_eq!(read_text(d.join("secret.txt").to_str().unwrap(), None, &[], 100).unwrap().0, "root:x:0:0\n");
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn shipped_copies_size_limit_and_missing_files() {
        let d = dir("limits");
        let res = d.join("resources");
        let shipped = [("s.toml", "x = 1")];
        assert_eq!(read_text("s.toml", None, &shipped, 100).unwrap().0, "x = 1");
        assert_eq!(read_text("s.toml", Some(&res), &shipped, 100).unwrap().1, "s.toml (shipped)");
        assert!(matches!(read_text("t.toml", None, &shipped, 100), Err(ResourceError::NoLocation { .. })));
        let e = read_text("none.toml", Some(&res), &shipped, 100).unwrap_err();
        assert!(e.to_string().contains("none.toml"), "{e}");
        std::fs::write(res.join("big.txt"), vec![b'x'; 101]).unwrap();
        assert!(matches!(read_text("big.txt", Some(&res), &[], 100), Err(ResourceError::TooLarge { .. })));
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn a_file_parameter_reads_its_file_when_set_and_keeps_it_on_error() {
        static NUMBERS: FileKind<f64, String> = FileKind::new(&[("one.txt", "1")], 100, |text, origin| {
            text.trim().parse().map_err(|e| format!("{origin}: {e}"))
        });
        let d = dir("parameter");
        let res = d.join("resources");
        std::fs::write(res.join("two.txt"), "2").unwrap();
        std::fs::write(res.join("bad.txt"), "two").unwrap();
        let mut p = NUMBERS.open(Some(&res), "one.txt").unwrap();
        assert_eq!((p.name(), *p.value()), ("one.txt", 1.0));
        assert!(p.set("two.txt").unwrap());
        assert_eq!((p.name(), *p.value()), ("two.txt", 2.0));
        assert!(!p.set("two.txt").unwrap(), "the same name is not read again");
        let e = p.set("bad.txt").unwrap_err();
        assert!(matches!(e, ResourceError::Invalid { .. }) && e.to_string().contains("bad.txt"), "{e}");
        assert!(matches!(p.set("../secret.txt"), Err(ResourceError::Outside { .. })));
        assert_eq!((p.name(), *p.value()), ("two.txt", 2.0), "unchanged by the errors");
        assert!(NUMBERS.open(None, "one.txt").is_ok(), "shipped: found without a location");
        assert_eq!(NUMBERS.resources(), [Resource { name: "one.txt".into(), bytes: b"1".to_vec() }]);
        std::fs::remove_dir_all(&d).unwrap();
    }

    /// A restored parameter must find the file it was saved with: the same name with other
    /// contents is refused, and the parameter keeps what it had.
    #[test]
    fn a_saved_file_restores_only_with_the_same_contents() {
        static NUMBERS: FileKind<f64, String> =
            FileKind::new(&[], 100, |text, origin| text.trim().parse().map_err(|e| format!("{origin}: {e}")));
        let d = dir("saved");
        let res = d.join("resources");
        std::fs::write(res.join("one.txt"), "1").unwrap();
        std::fs::write(res.join("two.txt"), "2").unwrap();
        let mut p = NUMBERS.open(Some(&res), "one.txt").unwrap();
        let mut q = NUMBERS.open(Some(&res), "two.txt").unwrap();
        assert_eq!(q.saved().name, "two.txt");
        assert!(p.restore(q.saved()).unwrap());
        assert_eq!(*p.value(), 2.0);
        assert!(!q.restore(p.saved()).unwrap(), "the same file: nothing read again");
        std::fs::write(res.join("two.txt"), "2.5").unwrap();
        let mut r = NUMBERS.open(Some(&res), "one.txt").unwrap();
        let e = r.restore(q.saved()).unwrap_err();
        assert!(
            matches!(e, ResourceError::Changed { .. }) && e.to_string().contains("`two.txt` is not the file"),
            "{e}"
        );
        assert_eq!((r.name(), *r.value()), ("one.txt", 1.0), "unchanged by the refusal");
        std::fs::remove_dir_all(&d).unwrap();
    }

    /// A FIFO (or any file that is not regular) is refused at once, by name, absolute or inside
    /// resources/: opening one would block until someone writes to it.
    #[test]
    fn a_fifo_is_refused_without_blocking() {
        let d = dir("fifo");
        let res = d.join("resources");
        let fifo = res.join("scene.toml");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status().unwrap();
        assert!(made.success());
        let (tx, rx) = std::sync::mpsc::channel();
        let (relative, absolute) = (res.clone(), fifo.clone());
        std::thread::spawn(move || {
            let inside = read_text("scene.toml", Some(&relative), &[], 100).map(|_| ());
            let named = read_text(absolute.to_str().unwrap(), None, &[], 100).map(|_| ());
            tx.send((inside, named)).unwrap();
        });
        let (inside, named) = rx.recv_timeout(std::time::Duration::from_secs(10)).expect("reading a FIFO blocked");
        for e in [inside.unwrap_err(), named.unwrap_err()] {
            assert!(e.to_string().contains("scene.toml") && e.to_string().contains("not a regular file"), "{e}");
        }
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn excerpts_are_short_and_escaped() {
        assert_eq!(excerpt("a\nb\u{1b}[31m", 100), "a\\nb\\u{1b}[31m");
        assert_eq!(excerpt(&"y".repeat(500), 10), format!("{}…", "y".repeat(10)));
    }
}
