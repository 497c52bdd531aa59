//! Field snapshots written by every rank for its own nodes, joined by one XDMF file so that
//! ParaView opens the run with no plugin.
//!
//! `OUT/fields/ranks-PPPPP-part-RRRRR.h5` holds rank R's part (of a run on P ranks), one
//! group `snapshot-SSSSSSSSSS` per snapshot step: points (the rank's nodes plus the far node
//! of each element that crosses to another rank, so that no fibre shows a gap) with
//! `position`, `velocity`, `displacement`, `gid`, `layer`, `yarn` and `rank`; polyline cells
//! (one per intact element of an owned node) with `connectivity`, `element_gid`, `strain`,
//! `stress` and `failure`, and the same for the broken elements in subgroup `broken`.
//! `OUT/fields.xdmf` lists every snapshot as a spatial collection of the rank parts (intact
//! elements: a broken element's two nodes fly apart, and a line between them would cross the
//! panel) inside a temporal collection; `OUT/broken-elements.xdmf` lists the broken ones.
//! No rank ever gathers the nodes of another.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use dea_core::Vec3;

use crate::results::{write_scalars, write_text_attribute, write_vectors};

/// Elements of one rank's snapshot (its intact ones, or its broken ones).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SnapshotCells {
    /// point indices of each element
    pub connectivity: Vec<[u32; 2]>,
    /// global id of each element (that of its first node)
    pub element_gid: Vec<u64>,
    /// engineering strain [-]
    pub strain: Vec<f64>,
    /// axial stress E_L eps, 0 once broken [Pa]
    pub stress: Vec<f64>,
    /// 0 intact, 1 tension, 2 shear, 3 combined
    pub failure: Vec<u8>,
}

impl SnapshotCells {
    /// Adds one element.
    pub fn push(&mut self, connectivity: [u32; 2], element_gid: u64, strain: f64, stress: f64, failure: u8) {
        self.connectivity.push(connectivity);
        self.element_gid.push(element_gid);
        self.strain.push(strain);
        self.stress.push(stress);
        self.failure.push(failure);
    }

    /// Elements held.
    pub fn len(&self) -> usize {
        self.element_gid.len()
    }

    /// No element is held.
    pub fn is_empty(&self) -> bool {
        self.element_gid.is_empty()
    }
}

/// One rank's snapshot.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SnapshotPart {
    /// [m]
    pub position: Vec<Vec3>,
    /// [m/s]
    pub velocity: Vec<Vec3>,
    /// position less the position as built, before any settle [m]
    pub displacement: Vec<Vec3>,
    /// global id of each node
    pub gid: Vec<u64>,
    /// its layer, 0 on top
    pub layer: Vec<u32>,
    /// its panel yarn
    pub yarn: Vec<u32>,
    /// owning rank of each point (the one field that depends on the rank count)
    pub rank: Vec<u32>,
    /// the intact elements of the rank's nodes (what `fields.xdmf` draws)
    pub intact: SnapshotCells,
    /// the broken ones (`broken-elements.xdmf`)
    pub broken: SnapshotCells,
}

/// Directory of the part files.
pub fn fields_directory(out: &Path) -> PathBuf {
    out.join("fields")
}

fn part_name(ranks: usize, rank: u32) -> String {
    format!("ranks-{ranks:05}-part-{rank:05}.h5")
}

fn group_name(step: u64) -> String {
    format!("snapshot-{step:010}")
}

/// Opens `name` in the fields directory and gives it a fresh group for `step`, holding the
/// step and time (a restart after a crash writes again what followed its checkpoint).
fn snapshot_group(out: &Path, name: &str, step: u64, time: f64) -> hdf5::Result<(hdf5::File, hdf5::Group)> {
    let directory = fields_directory(out);
    std::fs::create_dir_all(&directory)
        .map_err(|e| hdf5::Error::from(format!("{}: {e}", directory.display()).as_str()))?;
    let file = hdf5::File::append(directory.join(name))?;
    let group_name = group_name(step);
    if file.link_exists(&group_name) {
        file.unlink(&group_name)?;
    }
    let group = file.create_group(&group_name)?;
    write_scalars(&group, "step", &[step], "-")?;
    write_scalars(&group, "time", &[time], "s")?;
    Ok((file, group))
}

/// Writes index rows (segments, triangles) as an n x N dataset.
fn write_rows<const N: usize>(group: &hdf5::Group, name: &str, rows: &[[u32; N]], units: &str) -> hdf5::Result<()> {
    let flat: Vec<u32> = rows.iter().flatten().copied().collect();
    let dataset = group.new_dataset::<u32>().shape([rows.len(), N]).create(name)?;
    dataset.write_raw(&flat)?;
    write_text_attribute(&dataset, "units", units)
}

/// Writes (or replaces) this rank's part of the snapshot at `step`.
pub fn write_part(out: &Path, ranks: usize, rank: u32, step: u64, time: f64, part: &SnapshotPart) -> hdf5::Result<()> {
    let (file, group) = snapshot_group(out, &part_name(ranks, rank), step, time)?;
    write_vectors(&group, "position", &part.position, "m")?;
    write_vectors(&group, "velocity", &part.velocity, "m/s")?;
    write_scalars(&group, "gid", &part.gid, "-")?;
    write_scalars(&group, "layer", &part.layer, "-")?;
    write_scalars(&group, "yarn", &part.yarn, "-")?;
    write_scalars(&group, "rank", &part.rank, "-")?;
    write_vectors(&group, "displacement", &part.displacement, "m")?;
    write_cells(&group, &part.intact)?;
    write_cells(&group.create_group(BROKEN)?, &part.broken)?;
    file.flush()
}

/// Subgroup of a snapshot that holds its broken elements.
const BROKEN: &str = "broken";

fn write_cells(group: &hdf5::Group, cells: &SnapshotCells) -> hdf5::Result<()> {
    write_rows(group, "connectivity", &cells.connectivity, "point index")?;
    write_scalars(group, "element_gid", &cells.element_gid, "-")?;
    write_scalars(group, "strain", &cells.strain, "-")?;
    write_scalars(group, "stress", &cells.stress, "Pa")?;
    write_scalars(group, "failure", &cells.failure, "0 intact, 1 tension, 2 shear, 3 combined")
}

/// File of the projectile's surface snapshots (rank 0), in the fields directory.
const PROJECTILE_FILE: &str = "projectile.h5";

/// Writes (or replaces) the projectile's surface at `step`: world positions and velocities
/// of its vertices and its triangles, for `projectile.xdmf`.
pub fn write_projectile(
    out: &Path,
    step: u64,
    time: f64,
    vertices: &[Vec3],
    velocities: &[Vec3],
    triangles: &[[u32; 3]],
) -> hdf5::Result<()> {
    let (file, group) = snapshot_group(out, PROJECTILE_FILE, step, time)?;
    write_vectors(&group, "position", vertices, "m")?;
    write_vectors(&group, "velocity", velocities, "m/s")?;
    write_rows(&group, "triangles", triangles, "vertex index")?;
    file.flush()
}

/// Writes `projectile.xdmf`: the projectile's surface at every step up to `last_step` that
/// `write_projectile` recorded (none: no file).
pub fn write_projectile_xdmf(out: &Path, last_step: u64) -> hdf5::Result<()> {
    let path = fields_directory(out).join(PROJECTILE_FILE);
    if !path.exists() {
        return Ok(());
    }
    let file = hdf5::File::open(&path)?;
    let mut x = String::from("<?xml version=\"1.0\" ?>\n<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n<Xdmf Version=\"2.0\">\n  <Domain>\n    <Grid Name=\"projectile\" GridType=\"Collection\" CollectionType=\"Temporal\">\n");
    let mut names = file.member_names()?;
    names.sort();
    for name in names {
        let group = file.group(&name)?;
        let step: u64 = group.dataset("step")?.read_raw::<u64>()?[0];
        if step > last_step {
            continue;
        }
        let time: f64 = group.dataset("time")?.read_raw::<f64>()?[0];
        let (points, triangles) = (group.dataset("position")?.shape()[0], group.dataset("triangles")?.shape()[0]);
        let _ =
            writeln!(x, "      <Grid Name=\"step {step}\" GridType=\"Uniform\">\n        <Time Value=\"{time:e}\" />");
        let _ = writeln!(x, "        <Topology TopologyType=\"Triangle\" NumberOfElements=\"{triangles}\">");
        let _ = writeln!(x, "          <DataItem Dimensions=\"{triangles} 3\" NumberType=\"UInt\" Precision=\"4\" Format=\"HDF\">fields/projectile.h5:/{name}/triangles</DataItem>");
        let _ = writeln!(x, "        </Topology>\n        <Geometry GeometryType=\"XYZ\">");
        let _ = writeln!(x, "          <DataItem Dimensions=\"{points} 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">fields/projectile.h5:/{name}/position</DataItem>");
        let _ = writeln!(x, "        </Geometry>");
        // (snapshots of an older version hold no velocity)
        if group.link_exists("velocity") {
            let _ = writeln!(x, "        <Attribute Name=\"velocity\" AttributeType=\"Vector\" Center=\"Node\">");
            let _ = writeln!(x, "          <DataItem Dimensions=\"{points} 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">fields/projectile.h5:/{name}/velocity</DataItem>");
            let _ = writeln!(x, "        </Attribute>");
        }
        let _ = writeln!(x, "      </Grid>");
    }
    x.push_str("    </Grid>\n  </Domain>\n</Xdmf>\n");
    std::fs::write(out.join("projectile.xdmf"), x)
        .map_err(|e| hdf5::Error::from(format!("{}: {e}", out.join("projectile.xdmf").display()).as_str()))
}

/// One part of one snapshot on disk.
#[derive(Clone, Debug, PartialEq)]
pub struct IndexedPart {
    /// file name inside the fields directory
    pub file: String,
    /// nodes written
    pub points: usize,
    /// intact elements
    pub cells: usize,
    /// broken elements
    pub broken_cells: usize,
}

/// One snapshot on disk.
#[derive(Clone, Debug, PartialEq)]
pub struct IndexedSnapshot {
    /// steps taken when it was written
    pub step: u64,
    /// [s]
    pub time: f64,
    /// rank count of the run that wrote it
    pub ranks: usize,
    /// one part per rank, in rank order
    pub parts: Vec<IndexedPart>,
}

/// The first value of a one-value dataset of `group` (a damaged part may hold none).
fn first_value<T: hdf5::H5Type + Copy>(group: &hdf5::Group, name: &str) -> hdf5::Result<T> {
    let values: Vec<T> = group.dataset(name)?.read_raw()?;
    values.first().copied().ok_or_else(|| format!("{}/{name}: empty", group.name()).as_str().into())
}

/// An error met reading a field part, naming the part.
fn in_part(path: &Path, error: hdf5::Error) -> hdf5::Error {
    format!("field part {}: {error}", path.display()).as_str().into()
}

/// Every snapshot in `out`'s fields directory up to `last_step`, ascending step. When two
/// runs (a crash and its restart on another rank count) wrote the same step, the parts of
/// `ranks` win.
pub fn index(out: &Path, ranks: usize, last_step: u64) -> hdf5::Result<Vec<IndexedSnapshot>> {
    let directory = fields_directory(out);
    let mut names: Vec<String> = match std::fs::read_dir(&directory) {
        Ok(entries) => entries
            .filter_map(|e| e.ok())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with("ranks-") && n.ends_with(".h5"))
            .collect(),
        Err(_) => return Ok(Vec::new()),
    };
    names.sort();
    let mut by_step: BTreeMap<u64, BTreeMap<usize, IndexedSnapshot>> = BTreeMap::new();
    for name in names {
        let Some(writer_ranks) = name.get(6..11).and_then(|r| r.parse::<usize>().ok()) else { continue };
        let path = directory.join(&name);
        let read = || -> hdf5::Result<Vec<(u64, f64, usize, usize, usize)>> {
            let file = hdf5::File::open(&path)?;
            let mut snapshots = Vec::new();
            for group_name in file.member_names()? {
                let group = file.group(&group_name)?;
                let step: u64 = first_value(&group, "step")?;
                let time: f64 = first_value(&group, "time")?;
                let broken = group.dataset(&format!("{BROKEN}/element_gid"))?.size();
                snapshots.push((
                    step,
                    time,
                    group.dataset("gid")?.size(),
                    group.dataset("element_gid")?.size(),
                    broken,
                ));
            }
            Ok(snapshots)
        };
        for (step, time, points, cells, broken_cells) in read().map_err(|e| in_part(&path, e))? {
            if step > last_step {
                continue;
            }
            let entry = by_step.entry(step).or_default().entry(writer_ranks).or_insert_with(|| IndexedSnapshot {
                step,
                time,
                ranks: writer_ranks,
                parts: Vec::new(),
            });
            entry.parts.push(IndexedPart { file: name.clone(), points, cells, broken_cells });
        }
    }
    Ok(by_step
        .into_values()
        .filter_map(|mut writers| {
            let preferred = if writers.contains_key(&ranks) { ranks } else { *writers.keys().next_back()? };
            writers.remove(&preferred)
        })
        .collect())
}

fn item(out: &mut String, file: &str, step: u64, name: &str, dimensions: &str, number_type: &str, precision: usize) {
    let _ = writeln!(
        out,
        "          <DataItem Dimensions=\"{dimensions}\" NumberType=\"{number_type}\" Precision=\"{precision}\" Format=\"HDF\">fields/{file}:/{}/{name}</DataItem>",
        group_name(step)
    );
}

/// File that draws the intact elements of every snapshot.
pub const FIELDS_XDMF: &str = "fields.xdmf";
/// File that draws the broken ones.
pub const BROKEN_XDMF: &str = "broken-elements.xdmf";

/// The XDMF text of the intact elements of `snapshots` (`broken`: of the broken ones).
fn collection(snapshots: &[IndexedSnapshot], broken: bool) -> String {
    let (grid, cells_of, prefix) = if broken {
        ("broken elements", (|p: &IndexedPart| p.broken_cells) as fn(&IndexedPart) -> usize, "broken/")
    } else {
        ("fabric", (|p: &IndexedPart| p.cells) as fn(&IndexedPart) -> usize, "")
    };
    let mut x = format!("<?xml version=\"1.0\" ?>\n<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n<Xdmf Version=\"2.0\">\n  <Domain>\n    <Grid Name=\"{grid}\" GridType=\"Collection\" CollectionType=\"Temporal\">\n");
    for snapshot in snapshots {
        let _ = writeln!(x, "      <Grid Name=\"step {}\" GridType=\"Collection\" CollectionType=\"Spatial\">\n        <Time Value=\"{:e}\" />", snapshot.step, snapshot.time);
        for part in snapshot.parts.iter().filter(|p| p.points > 0 && cells_of(p) > 0) {
            let (points, cells, step, file) = (part.points, cells_of(part), snapshot.step, part.file.as_str());
            let _ = writeln!(x, "      <Grid Name=\"{}\" GridType=\"Uniform\">", file.trim_end_matches(".h5"));
            let _ = writeln!(
                x,
                "        <Topology TopologyType=\"Polyline\" NodesPerElement=\"2\" NumberOfElements=\"{cells}\">"
            );
            item(&mut x, file, step, &format!("{prefix}connectivity"), &format!("{cells} 2"), "UInt", 4);
            let _ = writeln!(x, "        </Topology>\n        <Geometry GeometryType=\"XYZ\">");
            item(&mut x, file, step, "position", &format!("{points} 3"), "Float", 8);
            let _ = writeln!(x, "        </Geometry>");
            for (name, kind, center, number_type, precision, dims) in [
                ("velocity", "Vector", "Node", "Float", 8, format!("{points} 3")),
                ("displacement", "Vector", "Node", "Float", 8, format!("{points} 3")),
                ("gid", "Scalar", "Node", "UInt", 8, format!("{points}")),
                ("layer", "Scalar", "Node", "UInt", 4, format!("{points}")),
                ("yarn", "Scalar", "Node", "UInt", 4, format!("{points}")),
                ("rank", "Scalar", "Node", "UInt", 4, format!("{points}")),
                ("element_gid", "Scalar", "Cell", "UInt", 8, format!("{cells}")),
                ("strain", "Scalar", "Cell", "Float", 8, format!("{cells}")),
                ("stress", "Scalar", "Cell", "Float", 8, format!("{cells}")),
                ("failure", "Scalar", "Cell", "UChar", 1, format!("{cells}")),
            ] {
                let path = if center == "Cell" { format!("{prefix}{name}") } else { name.to_string() };
                let _ = writeln!(x, "        <Attribute Name=\"{name}\" AttributeType=\"{kind}\" Center=\"{center}\">");
                item(&mut x, file, step, &path, &dims, number_type, precision);
                let _ = writeln!(x, "        </Attribute>");
            }
            let _ = writeln!(x, "      </Grid>");
        }
        let _ = writeln!(x, "      </Grid>");
    }
    x.push_str("    </Grid>\n  </Domain>\n</Xdmf>\n");
    x
}

/// Writes the XDMF files joining `snapshots`, `fields.xdmf` (intact elements) and
/// `broken-elements.xdmf` (each is replaced whole, so it is always valid).
pub fn write_xdmf(out: &Path, snapshots: &[IndexedSnapshot]) -> std::io::Result<()> {
    for (name, broken) in [(FIELDS_XDMF, false), (BROKEN_XDMF, true)] {
        let temporary = out.join(format!("{name}.writing"));
        std::fs::write(&temporary, collection(snapshots, broken))?;
        std::fs::rename(&temporary, out.join(name))?;
    }
    Ok(())
}

/// A point of a merged snapshot: gid, position bits, velocity bits, displacement bits,
/// layer, yarn.
pub type MergedPoint = (u64, [u64; 3], [u64; 3], [u64; 3], u32, u32);

/// A snapshot gathered from its parts and sorted by gid: point data by node, cell data by
/// element. Used to compare runs on different rank counts (the `rank` field is left out).
#[derive(Clone, Debug, PartialEq)]
pub struct MergedSnapshot {
    /// the simulated time's bits [s]
    pub time_bits: u64,
    /// (gid, position bits, velocity bits, displacement bits, layer, yarn) by node
    pub points: Vec<MergedPoint>,
    /// (element gid, strain bits, stress bits, failure)
    pub cells: Vec<(u64, u64, u64, u8)>,
}

/// Reads every part of `snapshot` and merges it by gid (points of several parts that share a
/// gid, the far ends of crossing elements, must agree; one is kept).
pub fn merged(out: &Path, snapshot: &IndexedSnapshot) -> hdf5::Result<MergedSnapshot> {
    let bits = |v: &Vec3| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
    let mut points = Vec::new();
    let mut cells = Vec::new();
    for part in &snapshot.parts {
        let path = fields_directory(out).join(&part.file);
        let mut read = || -> hdf5::Result<()> {
            let file = hdf5::File::open(&path)?;
            let group = file.group(&group_name(snapshot.step))?;
            let vectors = |name: &str| -> hdf5::Result<Vec<Vec3>> {
                Ok(group
                    .dataset(name)?
                    .read_raw::<f64>()?
                    .chunks_exact(3)
                    .map(|c| Vec3::new(c[0], c[1], c[2]))
                    .collect())
            };
            let (position, velocity, displacement) =
                (vectors("position")?, vectors("velocity")?, vectors("displacement")?);
            let gid: Vec<u64> = group.dataset("gid")?.read_raw()?;
            let layer: Vec<u32> = group.dataset("layer")?.read_raw()?;
            let yarn: Vec<u32> = group.dataset("yarn")?.read_raw()?;
            let n = gid.len();
            // a damaged part may list fewer values of one kind than of another
            let disagree =
                || hdf5::Error::from(format!("step {}: its datasets disagree in length", snapshot.step).as_str());
            if [position.len(), velocity.len(), displacement.len(), layer.len(), yarn.len()].iter().any(|&l| l != n) {
                return Err(disagree());
            }
            for k in 0..n {
                points.push((
                    gid[k],
                    bits(&position[k]),
                    bits(&velocity[k]),
                    bits(&displacement[k]),
                    layer[k],
                    yarn[k],
                ));
            }
            for prefix in ["", "broken/"] {
                let element_gid: Vec<u64> = group.dataset(&format!("{prefix}element_gid"))?.read_raw()?;
                let strain: Vec<f64> = group.dataset(&format!("{prefix}strain"))?.read_raw()?;
                let stress: Vec<f64> = group.dataset(&format!("{prefix}stress"))?.read_raw()?;
                let failure: Vec<u8> = group.dataset(&format!("{prefix}failure"))?.read_raw()?;
                let m = element_gid.len();
                if [strain.len(), stress.len(), failure.len()].iter().any(|&l| l != m) {
                    return Err(disagree());
                }
                for k in 0..m {
                    cells.push((element_gid[k], strain[k].to_bits(), stress[k].to_bits(), failure[k]));
                }
            }
            Ok(())
        };
        read().map_err(|e| in_part(&path, e))?;
    }
    points.sort();
    points.dedup();
    cells.sort();
    Ok(MergedSnapshot { time_bits: snapshot.time.to_bits(), points, cells })
}

/// Differences between the snapshots of two runs (any rank counts), step by step, node by
/// node and element by element, the owning rank left out. Empty when identical.
pub fn compare_snapshots(a: &Path, b: &Path) -> hdf5::Result<Vec<String>> {
    let (left, right) = (index(a, usize::MAX, u64::MAX)?, index(b, usize::MAX, u64::MAX)?);
    let steps = |s: &[IndexedSnapshot]| s.iter().map(|x| x.step).collect::<Vec<_>>();
    if steps(&left) != steps(&right) {
        return Ok(vec![format!("snapshot steps differ: {:?} vs {:?}", steps(&left), steps(&right))]);
    }
    let mut differences = Vec::new();
    for (x, y) in left.iter().zip(&right) {
        let (mx, my) = (merged(a, x)?, merged(b, y)?);
        if mx != my {
            let points = mx.points.iter().zip(&my.points).filter(|(p, q)| p != q).count()
                + mx.points.len().abs_diff(my.points.len());
            let cells = mx.cells.iter().zip(&my.cells).filter(|(p, q)| p != q).count()
                + mx.cells.len().abs_diff(my.cells.len());
            differences.push(format!("snapshot at step {}: {points} points and {cells} elements differ", x.step));
        }
    }
    Ok(differences)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn part(first: u64, rank: u32) -> SnapshotPart {
        SnapshotPart {
            position: vec![Vec3::new(first as f64, 0.0, 0.0), Vec3::new(first as f64 + 1.0, 0.0, 0.0)],
            velocity: vec![Vec3::x() * first as f64, Vec3::x() * (first + 1) as f64],
            displacement: vec![Vec3::z() * first as f64 * 1e-3, Vec3::z() * (first + 1) as f64 * 1e-3],
            gid: vec![first, first + 1],
            layer: vec![0, 0],
            yarn: vec![1, 1],
            rank: vec![rank, rank],
            intact: SnapshotCells {
                connectivity: vec![[0, 1]],
                element_gid: vec![first],
                strain: vec![0.01],
                stress: vec![8.46e8],
                failure: vec![0],
            },
            broken: SnapshotCells::default(),
        }
    }

    #[test]
    fn parts_index_merge_and_join_in_xdmf() {
        let out = std::env::temp_dir().join(format!("dea-snapshot-test-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&out);
        std::fs::create_dir_all(&out).unwrap();
        // rank 1's element is broken at step 10: its cells are in the broken subgroup
        let mut broken = part(1, 1);
        broken.broken = std::mem::take(&mut broken.intact);
        broken.broken.failure[0] = 2;
        broken.broken.stress[0] = 0.0;
        for step in [10, 20] {
            write_part(&out, 2, 0, step, step as f64 * 1e-9, &part(0, 0)).unwrap();
            let rank_1 = if step == 10 { broken.clone() } else { part(1, 1) };
            write_part(&out, 2, 1, step, step as f64 * 1e-9, &rank_1).unwrap();
        }
        // a restart on 1 rank rewrote step 20 and went on to 30
        write_part(&out, 1, 0, 20, 20e-9, &part(0, 0)).unwrap();
        write_part(&out, 1, 0, 20, 20e-9, &part(0, 0)).unwrap();
        write_part(&out, 1, 0, 30, 30e-9, &part(0, 0)).unwrap();
        let snapshots = index(&out, 1, 25).unwrap();
        assert_eq!(
            snapshots.iter().map(|s| (s.step, s.ranks, s.parts.len())).collect::<Vec<_>>(),
            vec![(10, 2, 2), (20, 1, 1)]
        );
        let merged_10 = merged(&out, &snapshots[0]).unwrap();
        // node 1 is in both parts (the far end of rank 0's element): kept once
        assert_eq!(merged_10.points.iter().map(|p| p.0).collect::<Vec<_>>(), vec![0, 1, 2]);
        assert_eq!(merged_10.cells.iter().map(|c| (c.0, c.3)).collect::<Vec<_>>(), vec![(0, 0), (1, 2)]);
        assert_eq!(merged_10.points[2].3, [0, 0, 2e-3f64.to_bits()]);
        write_xdmf(&out, &snapshots).unwrap();
        let text = std::fs::read_to_string(out.join(FIELDS_XDMF)).unwrap();
        assert_eq!(text.matches("CollectionType=\"Spatial\"").count(), 2);
        // step 10 draws rank 1's part in the broken view only, step 20 in the fabric's
        assert!(!text.contains("fields/ranks-00002-part-00001.h5:/snapshot-0000000010/connectivity"));
        assert!(text.contains("fields/ranks-00002-part-00000.h5:/snapshot-0000000010/connectivity"));
        assert!(text.contains("fields/ranks-00002-part-00000.h5:/snapshot-0000000010/displacement"));
        assert!(text.contains("<Time Value=\"2e-8\" />"));
        let broken_text = std::fs::read_to_string(out.join(BROKEN_XDMF)).unwrap();
        assert_eq!(broken_text.matches("GridType=\"Uniform\"").count(), 1);
        assert!(broken_text.contains("fields/ranks-00002-part-00001.h5:/snapshot-0000000010/broken/connectivity"));
        assert!(broken_text.contains("fields/ranks-00002-part-00001.h5:/snapshot-0000000010/broken/failure"));
        std::fs::remove_dir_all(&out).unwrap();
    }
}
