//! Hostile and careless SSP archives and FMU states, each mutant classified. An archive is the
//! LT50m system as `master export-ssp` writes it, mutated at the zip level (entries removed,
//! truncated, renamed, doubled, zeros added) and in its description (sources outside the
//! archive, duplicate components, flipped bytes), then run for two steps by `master run
//! --system`: it runs, or it is refused naming the archive, within a time limit — never a
//! signal, a panic or a hang. A state is serialized by each FMU and mutated (bytes flipped,
//! cut short, its scene name edited with its digest made to fit): refused with the reason, and
//! the intact state restores bit for bit.

use std::io::Write;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::{MASTER, common};

/// Longest a mutant's run may take before it counts as a hang.
const TIME_LIMIT: Duration = Duration::from_secs(60);

/// How a mutant's run ended.
#[derive(Debug, PartialEq, Eq, PartialOrd, Ord, Clone, Copy)]
enum Outcome {
    Ran,
    Refused,
}

/// An archive's entries (name, bytes), in order.
type Entries = Vec<(String, Vec<u8>)>;

/// A mutant: its label, its entries, two names to make one in its bytes, the outcome expected.
type Mutant<'a> = (String, Entries, Option<(&'a str, &'a str)>, Outcome);

/// The entries of an archive, in order.
fn entries(archive: &Path) -> Entries {
    let mut zip = zip::ZipArchive::new(std::fs::File::open(archive).unwrap()).unwrap();
    (0..zip.len())
        .map(|i| {
            let mut e = zip.by_index(i).unwrap();
            let mut bytes = Vec::new();
            std::io::Read::read_to_end(&mut e, &mut bytes).unwrap();
            (e.name().unwrap().into_owned(), bytes)
        })
        .collect()
}

fn write_archive(path: &Path, entries: &[(String, Vec<u8>)]) {
    let mut zip = zip::ZipWriter::new(std::fs::File::create(path).unwrap());
    let deflated = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);
    for (name, bytes) in entries {
        zip.start_file(name.as_str(), deflated).unwrap();
        zip.write_all(bytes).unwrap();
    }
    zip.finish().unwrap();
}

/// Gives two entries one name in the archive's bytes (the zip writer refuses to).
fn rename_in_bytes(path: &Path, from: &str, to: &str) {
    assert_eq!(from.len(), to.len());
    let mut bytes = std::fs::read(path).unwrap();
    let mut k = 0;
    while let Some(at) = bytes[k..].windows(from.len()).position(|w| w == from.as_bytes()) {
        bytes[k + at..k + at + to.len()].copy_from_slice(to.as_bytes());
        k += at + to.len();
    }
    std::fs::write(path, bytes).unwrap();
}

/// Runs the system for two steps; panics on a signal, a panic, a hang or an unclean refusal.
fn classify(label: &str, archive: &Path) -> Outcome {
    let mut child = Command::new(MASTER)
        .args(["run", "--system", archive.to_str().unwrap(), "--scheme", "jacobi", "--dt", "0.01", "--t-end", "0.02"])
        .arg("--quiet")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > TIME_LIMIT {
            child.kill().unwrap();
            panic!("{label}: hangs");
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let err = std::io::read_to_string(child.stderr.take().unwrap()).unwrap();
    match status.code() {
        Some(0) => Outcome::Ran,
        Some(1) => {
            assert!(err.starts_with("error: "), "{label}: {err}");
            assert!(!err.contains("panicked"), "{label}: {err}");
            let name = archive.file_name().unwrap().to_string_lossy();
            assert!(err.contains(name.as_ref()) || err.contains("component `"), "{label}: names neither: {err}");
            Outcome::Refused
        }
        other => panic!("{label}: exit {other:?} (a signal or a panic): {err}"),
    }
}

#[test]
fn mutated_ssp_archives_run_or_are_refused_cleanly() {
    let (_, scene) = common::scene("lt50m_C.toml", "archive-mutants", |_| {});
    let dir = std::env::temp_dir().join(format!("master-archive-mutants-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let base = dir.join("base.ssp");
    let exported = Command::new(MASTER)
        .args(["export-ssp", "--scene", scene.to_str().unwrap(), "--out", base.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(exported.status.success(), "{}", String::from_utf8_lossy(&exported.stderr));
    let original = entries(&base);
    let ssd = String::from_utf8(original.iter().find(|e| e.0 == "SystemStructure.ssd").unwrap().1.clone()).unwrap();
    let mut mutants: Vec<Mutant> = Vec::new();
    let with_ssd = |text: String| {
        original
            .iter()
            .map(|(n, b)| (n.clone(), if n == "SystemStructure.ssd" { text.clone().into_bytes() } else { b.clone() }))
            .collect::<Vec<_>>()
    };
    mutants.push(("intact".into(), original.clone(), None, Outcome::Ran));
    for (i, (name, _)) in original.iter().enumerate() {
        let mut removed = original.clone();
        removed.remove(i);
        mutants.push((format!("entry {name} removed"), removed, None, Outcome::Refused));
        let mut cut = original.clone();
        let half = cut[i].1.len() / 2;
        cut[i].1.truncate(half);
        mutants.push((format!("entry {name} cut to half"), cut, None, Outcome::Refused));
    }
    let zeros = vec![0u8; 32 << 20];
    let mut padded = original.clone();
    padded.push(("junk/zeros.bin".into(), zeros));
    mutants.push(("32 MiB of zeros nothing names".into(), padded, None, Outcome::Ran));
    let fmu = "resources/cable.fmu";
    assert!(ssd.contains(fmu), "{ssd}");
    let outside = common::fmu_dir().join("cable_fmu.fmu").display().to_string();
    for (what, source) in [
        ("absolute", outside.as_str()),
        ("parent", "../../cable_fmu.fmu"),
        ("parent inside a folder", "resources/../../x.fmu"),
        ("percent-encoded parent", "%2e%2e/%2e%2e/x.fmu"),
        ("file URI", "file:///etc/passwd"),
        ("empty", ""),
        ("missing", "resources/none.fmu"),
    ] {
        mutants.push((format!("source {what}"), with_ssd(ssd.replace(fmu, source)), None, Outcome::Refused));
    }
    mutants.push((
        "duplicate component".into(),
        with_ssd(ssd.replace(r#"name="stewart" "#, r#"name="cable" "#)),
        None,
        Outcome::Refused,
    ));
    mutants.push((
        "two SystemStructure.ssd".into(),
        [original.clone(), vec![("SystemStructure.ssX".into(), ssd.clone().into_bytes())]].concat(),
        Some(("SystemStructure.ssX", "SystemStructure.ssd")),
        Outcome::Refused,
    ));
    // bytes of the description flipped: the reader refuses malformed XML by file and line, or
    // the system still reads and runs (a flip inside a description text)
    let mut random = 0x9e37_79b9_7f4a_7c15u64;
    let mut flipped = Vec::new();
    for k in 0..40 {
        random ^= random << 13;
        random ^= random >> 7;
        random ^= random << 17;
        let mut text = ssd.clone().into_bytes();
        let at = (random as usize) % text.len();
        text[at] = b"<>\"&=/ x\0\xff"[k % 10];
        flipped.push((format!("description byte {at} flipped"), text));
    }

    let mut counts = std::collections::BTreeMap::new();
    for (k, (label, entries, rename, expected)) in mutants.iter().enumerate() {
        let path = dir.join(format!("m{k}.ssp"));
        write_archive(&path, entries);
        if let Some((from, to)) = rename {
            rename_in_bytes(&path, from, to);
        }
        let outcome = classify(label, &path);
        assert_eq!(outcome, *expected, "{label}");
        *counts.entry(outcome).or_insert(0) += 1;
    }
    for (k, (label, text)) in flipped.into_iter().enumerate() {
        let path = dir.join(format!("f{k}.ssp"));
        let entries: Vec<_> = original
            .iter()
            .map(|(n, b)| (n.clone(), if n == "SystemStructure.ssd" { text.clone() } else { b.clone() }))
            .collect();
        write_archive(&path, &entries);
        *counts.entry(classify(&label, &path)).or_insert(0) += 1;
    }
    // random and cut archives: refused as what they are
    let whole = std::fs::read(&base).unwrap();
    for (k, len) in [0, 1, 22, whole.len() / 3, whole.len() - 1].into_iter().enumerate() {
        let path = dir.join(format!("cut{k}.ssp"));
        std::fs::write(&path, &whole[..len]).unwrap();
        assert_eq!(classify(&format!("archive cut to {len} bytes"), &path), Outcome::Refused);
        *counts.entry(Outcome::Refused).or_insert(0) += 1;
    }
    eprintln!("SSP archive mutants: {counts:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A serialized state of `fmu` after one step of its scene C.
fn state_after_a_step(fmu: &fmi::import::Fmu, scene: &Path) -> (fmi::import::Instance, Vec<u8>, Vec<f64>) {
    let mut i = fmu.instantiate("mutants", false).unwrap();
    i.setup_experiment(None, 0.0, None).unwrap();
    let vr = fmu.value_reference("scene").unwrap();
    i.set_string(&[vr], &[scene.to_str().unwrap()]).unwrap();
    i.enter_initialization_mode().unwrap();
    i.exit_initialization_mode().unwrap();
    i.do_step(0.0, 0.01).unwrap();
    let outputs = i.value_references(fmi::Causality::Output, fmi::VarType::Real);
    let mut y = vec![0.0; outputs.len()];
    i.get_real(&outputs, &mut y).unwrap();
    let state = i.get_state().unwrap();
    let bytes = i.serialize_state(&state).unwrap();
    i.free_state(state).unwrap();
    (i, bytes, y)
}

#[test]
fn mutated_fmu_states_are_refused_with_the_reason() {
    let dir = std::env::temp_dir().join(format!("master-state-mutants-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut counts = std::collections::BTreeMap::<String, usize>::new();
    for name in ["cable_fmu", "stewart_fmu"] {
        let fmu = fmi::import::Fmu::load(&common::fmu_dir().join(format!("{name}.fmu"))).unwrap();
        // the scene by an absolute name of the same length as scene B's copy beside it
        let (c, b) = (dir.join("scene_C.toml"), dir.join("scene_B.toml"));
        std::fs::copy(common::scene_path("lt50m_C.toml"), &c).unwrap();
        std::fs::copy(common::scene_path("lt50m_B.toml"), &b).unwrap();
        let (mut inst, bytes, y) = state_after_a_step(&fmu, &c);
        let outputs = inst.value_references(fmi::Causality::Output, fmi::VarType::Real);
        let mut refused = |label: String, bad: &[u8], why: &str, at_set: bool| {
            let result = inst.deserialize_state(bad).and_then(|s| {
                let r = inst.set_state(&s);
                let _ = inst.free_state(s);
                r
            });
            let e = result.expect_err(&label).to_string();
            assert!(e.contains(why), "{name}, {label}: {e}");
            let class = format!("{name}: {}", if at_set { "refused at set" } else { "refused at deserialize" });
            *counts.entry(class).or_insert(0) += 1;
            inst.reset().unwrap();
        };
        for at in (0..bytes.len()).step_by((bytes.len() / 37).max(1)).chain([bytes.len() - 1]) {
            let mut b = bytes.clone();
            b[at] ^= 0x10;
            refused(format!("byte {at} flipped"), &b, "digest does not match", false);
        }
        for len in [0, 7, 8, 9, bytes.len() / 2, bytes.len() - 8, bytes.len() - 1] {
            refused(format!("cut to {len} bytes"), &bytes[..len], "not a state of this FMU", false);
        }
        // the scene name edited to another scene's file, the digest made to fit: the state keeps
        // the digest of the scene it was made with
        let body = &bytes[..bytes.len() - 8];
        let (from, to) = (c.to_str().unwrap().as_bytes(), b.to_str().unwrap().as_bytes());
        let at = body.windows(from.len()).position(|w| w == from).expect("the state names its scene");
        let mut forged = body.to_vec();
        forged[at..at + to.len()].copy_from_slice(to);
        let forged = [forged.as_slice(), &fmi::digest::digest(&forged).to_le_bytes()].concat();
        refused("scene name edited, digest fitted".into(), &forged, "is not the file the state was saved with", true);
        // intact: restored bit for bit (into a fresh instance, after other steps)
        let (mut other, _, _) = state_after_a_step(&fmu, &c);
        other.do_step(0.01, 0.01).unwrap();
        let s = other.deserialize_state(&bytes).unwrap();
        other.set_state(&s).unwrap();
        let mut back = vec![0.0; outputs.len()];
        other.get_real(&outputs, &mut back).unwrap();
        assert_eq!(
            back.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
            y.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
        );
        *counts.entry(format!("{name}: intact, restored")).or_insert(0) += 1;
    }
    eprintln!("FMU state mutants: {counts:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}
