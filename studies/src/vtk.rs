//! The net as VTK XML files for ParaView: one unstructured grid (`.vtu`) per sample, with the
//! series indexed by a ParaView data file (`.pvd`).
//!
//! Written by hand (the format is small): every array is appended raw binary (little endian,
//! 64-bit sizes), so that numbers keep every bit and a file costs one buffer and one write. The
//! cells and their constant arrays are encoded once per series ([`Mesh`]); a sample adds its
//! time, points, point vector and tensions.
//!
//! Points, in this order: every cable's points from its anchor to its attachment point; the
//! towers' feet (below the anchors on the ground, z = 0); the cabin centre point; with a
//! platform, the six Hooke joints on the cabin, the six spherical joints, the platform centre
//! and the feed point. Cells: each cable element (a line), each tower (a line), the cabin
//! (a polygon through the attachment points) and its centre (a vertex), each leg (a line), the
//! platform (a polygon through its joints), its centre and the feed (vertices). Cell data:
//! `part` ([`Part`]), `cable` (its number, −1 elsewhere), `tension_n` (a cable element's axial
//! force, a leg's actuator force where the method has it, NaN elsewhere). Point data: one
//! vector (a run's `displacement` from the start, a mode's `mode_shape`).
//!
//! A [`Series`] writes into a hidden folder inside the target folder and moves it into place
//! when committed: a series that failed leaves no file that looks complete.

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use feedcore::Vec3;

use crate::net::{Frame, Layout, by_azimuth};

/// What a cell is (the `part` cell array).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Part {
    CableElement = 0,
    Tower = 1,
    Cabin = 2,
    Leg = 3,
    Platform = 4,
    Feed = 5,
}

const VTK_VERTEX: u8 = 1;
const VTK_LINE: u8 = 3;
const VTK_POLYGON: u8 = 7;

/// The cells of a layout and the header of its files, fixed for a series.
pub struct Mesh {
    layout: Layout,
    points: usize,
    cells: usize,
    /// The XML up to the appended data's underscore.
    header: Vec<u8>,
    /// The constant appended blocks (connectivity, offsets, types, part, cable) and the end.
    tail: Vec<u8>,
    /// The cells' tensions, refilled per sample.
    tensions: Vec<f64>,
    /// The points, refilled per sample.
    coordinates: Vec<f64>,
}

/// Where the per-sample arrays of a file sit in its appended data, in this order.
fn block(values: usize, size: usize) -> usize {
    8 + values * size
}

impl Mesh {
    /// The mesh of `layout`; `vector`: the point vector's name; `fields`: the names of the
    /// file's field values (`TimeValue` first for ParaView's time).
    pub fn new(layout: &Layout, vector: &str, fields: &[&str]) -> Mesh {
        let (c, n) = (layout.cables, layout.points_per_cable());
        let cable_points = c * n;
        let feet = cable_points;
        let cabin_centre = feet + c;
        let mut connectivity: Vec<i64> = Vec::new();
        let mut offsets: Vec<i64> = Vec::new();
        let mut types: Vec<u8> = Vec::new();
        let mut part: Vec<i32> = Vec::new();
        let mut cable: Vec<i32> = Vec::new();
        let mut cell = |points: &[usize], kind: u8, p: Part, k: i32| {
            connectivity.extend(points.iter().map(|&i| i as i64));
            offsets.push(connectivity.len() as i64);
            types.push(kind);
            part.push(p as i32);
            cable.push(k);
        };
        for i in 0..c {
            for e in 0..layout.elements {
                cell(&[i * n + e, i * n + e + 1], VTK_LINE, Part::CableElement, i as i32);
            }
        }
        for i in 0..c {
            cell(&[feet + i, i * n], VTK_LINE, Part::Tower, i as i32);
        }
        let outline: Vec<usize> = layout.cabin_outline().iter().map(|&i| i * n + n - 1).collect();
        cell(&outline, VTK_POLYGON, Part::Cabin, -1);
        cell(&[cabin_centre], VTK_VERTEX, Part::Cabin, -1);
        let mut points = cabin_centre + 1;
        if let Some(p) = &layout.platform {
            let (base, joints) = (points, points + 6);
            for k in 0..6 {
                cell(&[base + k, joints + k], VTK_LINE, Part::Leg, -1);
            }
            let ring: Vec<usize> = by_azimuth(&p.platform_joints).iter().map(|&k| joints + k).collect();
            cell(&ring, VTK_POLYGON, Part::Platform, -1);
            cell(&[joints + 6], VTK_VERTEX, Part::Platform, -1);
            cell(&[joints + 7], VTK_VERTEX, Part::Feed, -1);
            points = joints + 8;
        }
        let cells = types.len();

        // appended blocks: the fields, points, vector, tensions (per sample), then the constant ones
        let mut offset = 0usize;
        let mut at = |bytes: usize| {
            let o = offset;
            offset += bytes;
            o
        };
        let field_offsets: Vec<usize> = fields.iter().map(|_| at(block(1, 8))).collect();
        let (o_points, o_vector, o_tension) = (at(block(3 * points, 8)), at(block(3 * points, 8)), at(block(cells, 8)));
        let o_conn = at(block(connectivity.len(), 8));
        let (o_offsets, o_types) = (at(block(offsets.len(), 8)), at(block(cells, 1)));
        let (o_part, o_cable) = (at(block(cells, 4)), at(block(cells, 4)));

        let mut h = String::new();
        h.push_str("<?xml version=\"1.0\"?>\n");
        h.push_str(
            "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n",
        );
        h.push_str("<UnstructuredGrid>\n<FieldData>\n");
        for (name, o) in fields.iter().zip(&field_offsets) {
            h.push_str(&format!(
                "<DataArray type=\"Float64\" Name=\"{name}\" NumberOfTuples=\"1\" format=\"appended\" offset=\"{o}\"/>\n"
            ));
        }
        h.push_str("</FieldData>\n");
        h.push_str(&format!("<Piece NumberOfPoints=\"{points}\" NumberOfCells=\"{cells}\">\n"));
        h.push_str(&format!("<PointData Vectors=\"{vector}\">\n"));
        h.push_str(&format!(
            "<DataArray type=\"Float64\" Name=\"{vector}\" NumberOfComponents=\"3\" format=\"appended\" offset=\"{o_vector}\"/>\n"
        ));
        h.push_str("</PointData>\n<CellData Scalars=\"tension_n\">\n");
        h.push_str(&format!(
            "<DataArray type=\"Float64\" Name=\"tension_n\" format=\"appended\" offset=\"{o_tension}\"/>\n"
        ));
        h.push_str(&format!("<DataArray type=\"Int32\" Name=\"part\" format=\"appended\" offset=\"{o_part}\"/>\n"));
        h.push_str(&format!("<DataArray type=\"Int32\" Name=\"cable\" format=\"appended\" offset=\"{o_cable}\"/>\n"));
        h.push_str("</CellData>\n<Points>\n");
        h.push_str(&format!(
            "<DataArray type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\" format=\"appended\" offset=\"{o_points}\"/>\n"
        ));
        h.push_str("</Points>\n<Cells>\n");
        h.push_str(&format!(
            "<DataArray type=\"Int64\" Name=\"connectivity\" format=\"appended\" offset=\"{o_conn}\"/>\n"
        ));
        h.push_str(&format!(
            "<DataArray type=\"Int64\" Name=\"offsets\" format=\"appended\" offset=\"{o_offsets}\"/>\n"
        ));
        h.push_str(&format!("<DataArray type=\"UInt8\" Name=\"types\" format=\"appended\" offset=\"{o_types}\"/>\n"));
        h.push_str("</Cells>\n</Piece>\n</UnstructuredGrid>\n<AppendedData encoding=\"raw\">\n_");

        let mut tail = Vec::new();
        put(&mut tail, &connectivity, |v, o| o.extend_from_slice(&v.to_le_bytes()));
        put(&mut tail, &offsets, |v, o| o.extend_from_slice(&v.to_le_bytes()));
        put(&mut tail, &types, |v, o| o.push(*v));
        put(&mut tail, &part, |v, o| o.extend_from_slice(&v.to_le_bytes()));
        put(&mut tail, &cable, |v, o| o.extend_from_slice(&v.to_le_bytes()));
        tail.extend_from_slice(b"\n</AppendedData>\n</VTKFile>\n");

        Mesh {
            layout: layout.clone(),
            points,
            cells,
            header: h.into_bytes(),
            tail,
            tensions: Vec::with_capacity(cells),
            coordinates: Vec::with_capacity(3 * points),
        }
    }

    pub fn points(&self) -> usize {
        self.points
    }

    pub fn cells(&self) -> usize {
        self.cells
    }

    /// The file of one sample into `out` (cleared): `fields` in the order given to
    /// [`Mesh::new`], the frame's points and tensions, and `vector` at every point (3 values
    /// each, [`Mesh::points`] points).
    pub fn encode(&mut self, out: &mut Vec<u8>, fields: &[f64], frame: &Frame, vector: &[f64]) {
        assert_eq!(vector.len(), 3 * self.points, "one vector per point");
        self.fill(frame);
        out.clear();
        out.extend_from_slice(&self.header);
        for f in fields {
            put(out, std::slice::from_ref(f), |v, o| o.extend_from_slice(&v.to_le_bytes()));
        }
        put(out, &self.coordinates, |v, o| o.extend_from_slice(&v.to_le_bytes()));
        put(out, vector, |v, o| o.extend_from_slice(&v.to_le_bytes()));
        put(out, &self.tensions, |v, o| o.extend_from_slice(&v.to_le_bytes()));
        out.extend_from_slice(&self.tail);
    }

    /// Every point of `frame` in the file's order, appended to `out` (x, y, z each).
    pub fn points_of(layout: &Layout, frame: &Frame, out: &mut Vec<f64>) {
        let mut push = |p: &Vec3| out.extend_from_slice(&[p.x, p.y, p.z]);
        frame.points.iter().for_each(&mut push);
        for a in &layout.anchors {
            push(&Vec3::new(a.x, a.y, 0.0));
        }
        push(&frame.cabin.0);
        if let Some(p) = &layout.platform {
            let placed = frame.place(p);
            placed.base_joints.iter().for_each(&mut push);
            placed.platform_joints.iter().for_each(&mut push);
            push(&placed.center);
            push(&placed.feed);
        }
    }

    fn fill(&mut self, frame: &Frame) {
        let l = &self.layout;
        self.coordinates.clear();
        Mesh::points_of(l, frame, &mut self.coordinates);
        assert_eq!(self.coordinates.len(), 3 * self.points, "the frame belongs to the layout");
        self.tensions.clear();
        self.tensions.extend_from_slice(&frame.tensions);
        // towers, cabin outline and centre
        self.tensions.extend(std::iter::repeat_n(f64::NAN, l.cables + 2));
        if l.platform.is_some() {
            self.tensions.extend(frame.leg_forces.unwrap_or([f64::NAN; 6]));
            self.tensions.extend([f64::NAN; 3]);
        }
    }
}

/// One appended block: its size in bytes (UInt64), then the values.
fn put<T>(out: &mut Vec<u8>, values: &[T], each: impl Fn(&T, &mut Vec<u8>)) {
    out.extend_from_slice(&(std::mem::size_of_val(values) as u64).to_le_bytes());
    for v in values {
        each(v, out);
    }
}

/// A series of VTK files with its `.pvd` index in a folder: `DIR/<name>.pvd` and the files in
/// `DIR/<name>/`. The files are written to a hidden folder beside them, which
/// [`Series::commit`] renames into place (one rename, whatever the number of files) before the
/// index. Dropped uncommitted, it removes what it wrote and the earlier series of the same name
/// (which would otherwise pass for this one's).
pub struct Series {
    dir: PathBuf,
    name: String,
    /// Every file's name starts with it and ends with a number and `.vtu`.
    prefix: String,
    temp: PathBuf,
    entries: Vec<(f64, String)>,
    /// The number of the first file.
    first: usize,
    buffer: Vec<u8>,
    committed: bool,
}

/// Whether `name` is a file of a series with `prefix`: `<prefix><digits>.vtu`.
fn in_series(name: &str, prefix: &str) -> bool {
    name.strip_prefix(prefix)
        .and_then(|rest| rest.strip_suffix(".vtu"))
        .is_some_and(|n| !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()))
}

/// Refuses a folder for VTK files before anything is written: a file, or a path through a
/// file.
pub fn check_folder(dir: &Path) -> anyhow::Result<()> {
    let shown = dir.display();
    if dir.as_os_str().is_empty() {
        bail!("an empty path; give a folder for the VTK files");
    }
    if dir.exists() && !dir.is_dir() {
        bail!("{shown} is a file, not a folder; give a folder (it is created if missing) for the VTK files");
    }
    let mut above = dir.parent();
    while let Some(p) = above {
        if !p.as_os_str().is_empty() && p.exists() && !p.is_dir() {
            bail!(
                "{shown} lies inside {}, which is a file, not a folder; give a folder for the VTK files",
                p.display()
            );
        }
        above = p.parent();
    }
    Ok(())
}

impl Series {
    /// A series `<name>.pvd` of files `<name>/<prefix><number>.vtu` in `dir` (created if
    /// missing), started at once so that a folder that cannot be written, or an earlier
    /// `<name>` that is not a series of ours, fails before any work.
    pub fn create(dir: &Path, name: &str, prefix: &str) -> anyhow::Result<Series> {
        check_folder(dir)?;
        let shown = dir.display();
        let folder = dir.join(name);
        if folder.exists() {
            let theirs = |what: &str| {
                format!("{} {what}, which this series would replace; move it or give another folder", folder.display())
            };
            if !folder.is_dir() {
                bail!(theirs("is a file"));
            }
            for entry in std::fs::read_dir(&folder).with_context(|| format!("{}: cannot read it", folder.display()))? {
                let entry = entry?;
                let file = entry.file_name();
                if !(file.to_str().is_some_and(|f| in_series(f, prefix)) && entry.file_type()?.is_file()) {
                    bail!(theirs(&format!("holds {}, not a file of a series", file.to_string_lossy())));
                }
            }
        }
        std::fs::create_dir_all(dir).with_context(|| format!("{shown}: cannot create the folder"))?;
        // what a killed run of this series left, and this process's own temporaries
        crate::tempfiles::remove_stale(&folder);
        crate::tempfiles::remove_stale(&dir.join(format!("{name}.pvd")));
        let temp = crate::tempfiles::beside(&folder);
        if temp.exists() {
            std::fs::remove_dir_all(&temp).with_context(|| format!("{}: cannot clear it", temp.display()))?;
        }
        std::fs::create_dir(&temp).with_context(|| format!("{shown}: cannot write in this folder"))?;
        Ok(Series {
            dir: dir.to_owned(),
            name: name.to_string(),
            prefix: prefix.to_string(),
            temp,
            entries: Vec::new(),
            first: 0,
            buffer: Vec::new(),
            committed: false,
        })
    }

    /// Numbers the files from `first` (0 by default).
    pub fn numbered_from(mut self, first: usize) -> Series {
        self.first = first;
        self
    }

    /// The index file's final path.
    pub fn index_path(&self) -> PathBuf {
        self.dir.join(format!("{}.pvd", self.name))
    }

    /// The final folder of the files.
    pub fn folder(&self) -> PathBuf {
        self.dir.join(&self.name)
    }

    fn temp_index(&self) -> PathBuf {
        crate::tempfiles::beside(&self.index_path())
    }

    /// Files written so far.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// The next file, at `time` (ParaView's time of the series), its content from `encode`.
    pub fn add(&mut self, time: f64, encode: impl FnOnce(&mut Vec<u8>)) -> std::io::Result<()> {
        let name = format!("{}{:06}.vtu", self.prefix, self.first + self.entries.len());
        encode(&mut self.buffer);
        File::create(self.temp.join(&name))?.write_all(&self.buffer)?;
        self.entries.push((time, name));
        Ok(())
    }

    /// Moves the files into place (replacing an earlier series of this name), then the index.
    pub fn commit(mut self) -> anyhow::Result<PathBuf> {
        let shown = self.dir.display().to_string();
        let fail = |what: &str| format!("{shown}: cannot {what}");
        let mut index = String::from(
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"1.0\" byte_order=\"LittleEndian\">\n<Collection>\n",
        );
        for (t, file) in &self.entries {
            index.push_str(&format!("<DataSet timestep=\"{t:e}\" part=\"0\" file=\"{}/{file}\"/>\n", self.name));
        }
        index.push_str("</Collection>\n</VTKFile>\n");
        let temp_index = self.temp_index();
        let mut f = File::create(&temp_index).with_context(|| fail("write the index"))?;
        // the index alone is synced: the files become a result only through it
        f.write_all(index.as_bytes()).and_then(|_| f.sync_all()).with_context(|| fail("write the index"))?;
        self.remove_earlier().with_context(|| fail("remove the earlier series"))?;
        std::fs::rename(&self.temp, self.folder()).with_context(|| fail("move the files into place"))?;
        let path = self.index_path();
        std::fs::rename(&temp_index, &path).with_context(|| fail("move the index into place"))?;
        self.committed = true;
        Ok(path)
    }

    /// Removes an earlier series of this name: its index, and its folder with its files (only
    /// those: [`Series::create`] refused a folder holding anything else).
    fn remove_earlier(&self) -> std::io::Result<()> {
        let index = self.index_path();
        if index.is_file() {
            std::fs::remove_file(index)?;
        }
        let folder = self.folder();
        if folder.is_dir() {
            for entry in std::fs::read_dir(&folder)? {
                let entry = entry?;
                if entry.file_name().to_str().is_some_and(|f| in_series(f, &self.prefix)) {
                    std::fs::remove_file(entry.path())?;
                }
            }
            std::fs::remove_dir(folder)?;
        }
        Ok(())
    }
}

impl Drop for Series {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_dir_all(&self.temp);
            let _ = std::fs::remove_file(self.temp_index());
            let _ = self.remove_earlier();
        }
    }
}

/// Writes a run's net as a series: every frame handed to it, the point vector its displacement
/// from the first frame.
pub struct RunSeries {
    pub series: Series,
    mesh: Mesh,
    start: Vec<f64>,
    now: Vec<f64>,
    displacement: Vec<f64>,
}

impl RunSeries {
    /// `<name>.pvd` and `<name>/<name>_<number>.vtu` in `dir`.
    pub fn create(dir: &Path, name: &str, layout: &Layout) -> anyhow::Result<RunSeries> {
        let series = Series::create(dir, name, &format!("{name}_"))?;
        let mesh = Mesh::new(layout, "displacement", &["TimeValue"]);
        Ok(RunSeries { series, mesh, start: Vec::new(), now: Vec::new(), displacement: Vec::new() })
    }
}

impl crate::net::NetSink for RunSeries {
    fn frame(&mut self, layout: &Layout, frame: &Frame) -> std::io::Result<()> {
        self.now.clear();
        Mesh::points_of(layout, frame, &mut self.now);
        if self.start.is_empty() {
            self.start.clone_from(&self.now);
        }
        self.displacement.clear();
        self.displacement.extend(self.now.iter().zip(&self.start).map(|(a, b)| a - b));
        let (mesh, d) = (&mut self.mesh, &self.displacement);
        self.series.add(frame.time, |out| mesh.encode(out, &[frame.time], frame, d))
    }
}

/// Writes mode shapes as a series (`<name>_modes.pvd` of `<name>_modes/<name>_mode_<number>.vtu`)
/// (the series' time is the mode's number): the equilibrium `rest` of `system` at `cfg`, its
/// tensions, and the point vector `mode_shape` — each mass-normalized shape as the solver gives
/// it at the cable points, zero at the towers' feet, the cabin's rigid motion at the bodies (the
/// platform locked). Field data: `TimeValue` (the number) and `frequency_hz`. The series is
/// started before any file is written, so an unwritable `dir` fails first.
pub fn write_modes(
    mut series: Series,
    layout: &Layout,
    system: &cable::system::System,
    cfg: &cable::system::Config,
    rest: &Frame,
    modes: &[(f64, &[f64])],
) -> anyhow::Result<PathBuf> {
    let mut mesh = Mesh::new(layout, "mode_shape", &["TimeValue", "frequency_hz"]);
    let mut points = Vec::new();
    Mesh::points_of(layout, rest, &mut points);
    let cable_points = layout.cables * layout.points_per_cable();
    let (mut motion, mut vector) = (Vec::new(), Vec::new());
    for (k, (f, shape)) in modes.iter().enumerate() {
        motion.clear();
        system.point_motion(cfg, shape, &mut motion);
        vector.clear();
        vector.extend(motion.iter().flat_map(|m| [m.x, m.y, m.z]));
        vector.extend(std::iter::repeat_n(0.0, 3 * layout.cables));
        let c0 = system.cabin_offset();
        let (dr, dth) = (
            Vec3::new(shape[c0], shape[c0 + 1], shape[c0 + 2]),
            Vec3::new(shape[c0 + 3], shape[c0 + 4], shape[c0 + 5]),
        );
        rigid_motion(&points[3 * (cable_points + layout.cables)..], &rest.cabin.0, &dr, &dth, &mut vector);
        let number = (k + 1) as f64;
        series
            .add(number, |out| mesh.encode(out, &[number, *f], rest, &vector))
            .with_context(|| format!("{}: writing mode {}", series.dir.display(), k + 1))?;
    }
    series.commit()
}

/// `master modes --vtk`: the modes of `modal` into `series` (see [`write_modes`]).
pub fn modes_series(modal: &crate::report::Modal, series: Series) -> anyhow::Result<PathBuf> {
    let model = &modal.model;
    let found = model.modes.as_ref().context("no modes were computed")?;
    let layout = Layout::of(&modal.scene);
    let system = model.system(cable::model::Payload::Locked);
    let cfg = model.equilibrium_config();
    let rest = Frame::of_equilibrium(&layout, &system, &model.equilibrium);
    let modes: Vec<(f64, &[f64])> =
        modal.modes.iter().enumerate().map(|(k, m)| (m.frequency_hz, found.shapes[k].as_slice())).collect();
    write_modes(series, &layout, &system, &cfg, &rest, &modes)
}

/// The series of a scene's modes: `<name>_modes.pvd` of `<name>_modes/<name>_mode_<number>.vtu`
/// in `dir`.
pub fn modes_series_in(dir: &Path, name: &str) -> anyhow::Result<Series> {
    Ok(Series::create(dir, &format!("{name}_modes"), &format!("{name}_mode_"))?.numbered_from(1))
}

/// The rigid motion `δr + δθ × (p − r)` of cabin-fixed points `p` for a cabin motion (δr, δθ)
/// about its centre point `r`: the bodies' part of a mode shape (the platform locked).
pub fn rigid_motion(points: &[f64], centre: &Vec3, dr: &Vec3, dth: &Vec3, out: &mut Vec<f64>) {
    for p in points.chunks_exact(3) {
        let v = dr + dth.cross(&(Vec3::new(p[0], p[1], p[2]) - centre));
        out.extend_from_slice(&[v.x, v.y, v.z]);
    }
}

#[cfg(test)]
pub mod tests {
    use super::*;

    /// A file of this module read back: every DataArray by name, as f64, from its appended
    /// block (checking each block's size against its type and count).
    pub fn read_back(bytes: &[u8]) -> std::collections::HashMap<String, Vec<f64>> {
        let start = bytes.windows(2).position(|w| w == b"\n_").expect("appended data") + 2;
        let end = bytes.len() - b"\n</AppendedData>\n</VTKFile>\n".len();
        let xml = format!("{}</AppendedData></VTKFile>", std::str::from_utf8(&bytes[..start - 1]).unwrap());
        let doc = roxmltree::Document::parse(&xml).unwrap();
        let data = &bytes[start..end];
        let mut arrays = std::collections::HashMap::new();
        for a in doc.descendants().filter(|n| n.has_tag_name("DataArray")) {
            let o: usize = a.attribute("offset").unwrap().parse().unwrap();
            let n = u64::from_le_bytes(data[o..o + 8].try_into().unwrap()) as usize;
            let body = &data[o + 8..o + 8 + n];
            let values: Vec<f64> = match a.attribute("type").unwrap() {
                "Float64" => body.chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().unwrap())).collect(),
                "Int64" => body.chunks_exact(8).map(|c| i64::from_le_bytes(c.try_into().unwrap()) as f64).collect(),
                "Int32" => body.chunks_exact(4).map(|c| i32::from_le_bytes(c.try_into().unwrap()) as f64).collect(),
                "UInt8" => body.iter().map(|&b| f64::from(b)).collect(),
                t => panic!("type {t}"),
            };
            arrays.insert(a.attribute("Name").unwrap().to_string(), values);
        }
        // the blocks fill the appended data exactly
        let total: usize = doc
            .descendants()
            .filter(|n| n.has_tag_name("DataArray"))
            .map(|a| {
                let o: usize = a.attribute("offset").unwrap().parse().unwrap();
                8 + u64::from_le_bytes(data[o..o + 8].try_into().unwrap()) as usize
            })
            .sum();
        assert_eq!(total, data.len(), "the appended blocks are contiguous");
        arrays
    }

    fn lt50m(name: &str) -> feedcore::scene::ValidScene {
        feedcore::scene::Scene::load(format!("{}/../scenes/{name}", env!("CARGO_MANIFEST_DIR"))).unwrap()
    }

    #[test]
    fn a_file_reads_back_bit_for_bit() {
        let scene = lt50m("lt50m_B.toml");
        let layout = Layout::of(&scene);
        let statics = crate::report::Statics::of(&scene).unwrap();
        let (_, mut frame) = crate::net::equilibrium_frame(&scene, &layout, &statics.equilibrium);
        frame.time = 1.25;
        frame.leg_forces = Some([1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        let mut mesh = Mesh::new(&layout, "displacement", &["TimeValue", "other"]);
        // cables × (elements + 1), the feet, the cabin centre, 6 + 6 joints, platform centre, feed
        assert_eq!(mesh.points(), 6 * 21 + 6 + 1 + 14);
        assert_eq!(mesh.cells(), 6 * 20 + 6 + 2 + 6 + 3);
        let vector: Vec<f64> = (0..3 * mesh.points()).map(|k| (k as f64).sqrt() - 3.0).collect();
        let mut bytes = Vec::new();
        mesh.encode(&mut bytes, &[1.25, -7.5], &frame, &vector);
        let a = read_back(&bytes);
        assert_eq!(a["TimeValue"], [1.25]);
        assert_eq!(a["other"], [-7.5]);
        assert_eq!(a["displacement"], vector);
        let mut points = Vec::new();
        Mesh::points_of(&layout, &frame, &mut points);
        assert_eq!(a["Points"], points);
        for (k, p) in frame.points.iter().enumerate() {
            assert_eq!(&a["Points"][3 * k..3 * k + 3], p.as_slice());
        }
        let t = &a["tension_n"];
        assert_eq!(&t[..120], frame.tensions.as_slice());
        assert!(t[120..128].iter().all(|x| x.is_nan()), "towers and cabin carry no tension");
        assert_eq!(&t[128..134], &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        let part = &a["part"];
        assert_eq!(part.iter().filter(|&&p| p == 0.0).count(), 120);
        assert_eq!(
            a["cable"][..120].iter().map(|&c| c as usize).collect::<Vec<_>>(),
            (0..120).map(|e| e / 20).collect::<Vec<_>>()
        );
        // element e of cable i joins its points e and e + 1; the offsets end at the connectivity's end
        let (conn, offsets) = (&a["connectivity"], &a["offsets"]);
        assert_eq!(&conn[2 * 47..2 * 47 + 2], &[(2 * 21 + 7) as f64, (2 * 21 + 8) as f64]);
        assert_eq!(*offsets.last().unwrap() as usize, conn.len());
        assert_eq!(a["types"].len(), mesh.cells());
    }

    #[test]
    fn an_uncommitted_series_leaves_nothing_and_removes_the_earlier_one() {
        let dir = std::env::temp_dir().join(format!("vtk-series-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let write = |files: usize, commit: bool| {
            let mut s = Series::create(&dir, "x", "x_").unwrap();
            for k in 0..files {
                s.add(k as f64, |out| {
                    out.clear();
                    out.extend_from_slice(b"data")
                })
                .unwrap();
            }
            if commit {
                s.commit().unwrap();
            }
        };
        let names = || {
            let mut v: Vec<String> =
                std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
            v.sort();
            v
        };
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("notes.txt"), "mine").unwrap();
        let files = || {
            let mut v: Vec<String> = std::fs::read_dir(dir.join("x"))
                .unwrap()
                .map(|e| e.unwrap().file_name().into_string().unwrap())
                .collect();
            v.sort();
            v
        };
        write(3, true);
        assert_eq!(names(), ["notes.txt", "x", "x.pvd"]);
        assert_eq!(files(), ["x_000000.vtu", "x_000001.vtu", "x_000002.vtu"]);
        let index = std::fs::read_to_string(dir.join("x.pvd")).unwrap();
        assert!(index.contains("timestep=\"2e0\" part=\"0\" file=\"x/x_000002.vtu\""), "{index}");
        // a shorter series replaces the longer one whole
        write(2, true);
        assert_eq!(files(), ["x_000000.vtu", "x_000001.vtu"]);
        // a failed one leaves nothing of either, and the others' files alone
        write(1, false);
        assert_eq!(names(), ["notes.txt"]);
        // a folder of the series' name holding something else is refused before anything is written
        std::fs::create_dir(dir.join("x")).unwrap();
        std::fs::write(dir.join("x").join("mine.txt"), "mine").unwrap();
        let refused = Series::create(&dir, "x", "x_").err().unwrap().to_string();
        assert!(refused.contains("holds mine.txt"), "{refused}");
        assert_eq!(names(), ["notes.txt", "x"]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn series_files_are_told_from_others() {
        assert!(in_series("lt50m_C_000012.vtu", "lt50m_C_"));
        assert!(!in_series("lt50m_C_.vtu", "lt50m_C_"));
        assert!(!in_series("lt50m_C_00x.vtu", "lt50m_C_"));
        assert!(!in_series("lt50m_C_000012.vtu.bak", "lt50m_C_"));
        assert!(!in_series("lt50m_C_mode_01.vtu", "lt50m_C_"));
    }
}
