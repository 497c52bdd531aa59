//! Checkpoints: the whole state of a run keyed by global ids, so a run restarts with the same
//! bits on the same or another number of ranks.
//!
//! A checkpoint is a directory: `manifest.h5` (the case, the step, the projectile, global
//! counters and the histories so far; written last, by rank 0) and one `part-NNNNN.h5` per
//! writing rank with the state of its owned nodes in ascending global id: kinematics, forces,
//! the positions of the last neighbour-list build, element states and strengths, dissipation
//! ledgers, and every contact history (fibre pairs by partner gid, projectile contacts).
//! The solver writes it into a temporary directory and renames it into place, so a
//! checkpoint on disk is always complete; readers check the format, the completion mark and
//! every part, and refuse anything else with a message naming the file.

use std::path::{Path, PathBuf};

use dea_core::Vec3;

use crate::results::{
    read_histories_from, write_histories, write_scalars, write_text_attribute, write_vectors, Histories,
};

const FORMAT: &str = "dea-mpi checkpoint 7";

/// Why a checkpoint cannot be used.
#[derive(Debug, thiserror::Error)]
#[error("checkpoint {}: {message}", path.display())]
pub struct CheckpointError {
    /// the checkpoint's directory or file
    pub path: PathBuf,
    /// what is wrong with it
    pub message: String,
}

fn error(path: &Path, message: impl std::fmt::Display) -> CheckpointError {
    CheckpointError { path: path.to_path_buf(), message: message.to_string() }
}

/// State of a set of owned nodes, ascending global id.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NodeState {
    /// global id of each node, ascending
    pub gid: Vec<u64>,
    /// [m]
    pub position: Vec<Vec3>,
    /// [m/s]
    pub velocity: Vec<Vec3>,
    /// force of the last step [N]
    pub force: Vec<Vec3>,
    /// position at the last neighbour-list build [m]
    pub reference_position: Vec<Vec3>,
    /// failure mode code of the node's element
    pub failure: Vec<u8>,
    /// tensile strength of the node's element [Pa]
    pub tensile_strength: Vec<f64>,
    /// dissipated and released energy so far [J]
    pub friction_dissipated: Vec<f64>,
    /// (plastic work of the contact law) [J]
    pub plastic_dissipated: Vec<f64>,
    /// (elastic energy released by failure) [J]
    pub fracture_released: Vec<f64>,
    /// projectile contact history: anchor (body frame) [m], touching, largest overlap [m]
    pub projectile_anchor: Vec<Vec3>,
    /// the projectile friction spring's tangential stretch (body frame; a rotating spring's) [m]
    pub projectile_stretch: Vec<Vec3>,
    /// stiffness of the projectile friction spring at its last evaluation [N/m]
    pub projectile_spring_stiffness: Vec<f64>,
    /// touching the projectile at the last evaluation (0 or 1)
    pub projectile_touching: Vec<u8>,
    /// largest overlap with the projectile reached [m]
    pub projectile_max_overlap: Vec<f64>,
    /// a deforming projectile's material point the friction is anchored to: triangle and
    /// barycentric weights
    pub projectile_anchor_triangle: Vec<u32>,
    /// (the barycentric weights of that point) [-]
    pub projectile_anchor_weights: Vec<Vec3>,
    /// fibre contact-list entries of each node
    pub row_length: Vec<u32>,
    /// per entry: partner gid, friction anchor [m], touching, largest overlap [m]
    pub partner_gid: Vec<u64>,
    /// (the friction anchor) [m]
    pub anchor: Vec<Vec3>,
    /// friction spring stiffness at the last evaluation [N/m]
    pub spring_stiffness: Vec<f64>,
    /// (touching: 0 or 1)
    pub touching: Vec<u8>,
    /// (largest overlap reached) [m]
    pub max_overlap: Vec<f64>,
    /// retired contacts of each node (pairs dropped after touching): partner gid and
    /// largest overlap [m]
    pub retired_length: Vec<u32>,
    /// (partner gid of each retired pair)
    pub retired_gid: Vec<u64>,
    /// (largest overlap each retired pair reached) [m]
    pub retired_max_overlap: Vec<f64>,
}

impl NodeState {
    /// Appends row `k` of `other`, whose contact entries are `entries` and retired
    /// contacts `retired`.
    fn push_row(
        &mut self,
        other: &NodeState,
        k: usize,
        (entries, retired): (std::ops::Range<usize>, std::ops::Range<usize>),
    ) {
        self.gid.push(other.gid[k]);
        self.position.push(other.position[k]);
        self.velocity.push(other.velocity[k]);
        self.force.push(other.force[k]);
        self.reference_position.push(other.reference_position[k]);
        self.failure.push(other.failure[k]);
        self.tensile_strength.push(other.tensile_strength[k]);
        self.friction_dissipated.push(other.friction_dissipated[k]);
        self.plastic_dissipated.push(other.plastic_dissipated[k]);
        self.fracture_released.push(other.fracture_released[k]);
        self.projectile_anchor.push(other.projectile_anchor[k]);
        self.projectile_stretch.push(other.projectile_stretch[k]);
        self.projectile_spring_stiffness.push(other.projectile_spring_stiffness[k]);
        self.projectile_touching.push(other.projectile_touching[k]);
        self.projectile_max_overlap.push(other.projectile_max_overlap[k]);
        self.projectile_anchor_triangle.push(other.projectile_anchor_triangle[k]);
        self.projectile_anchor_weights.push(other.projectile_anchor_weights[k]);
        self.row_length.push(other.row_length[k]);
        self.partner_gid.extend_from_slice(&other.partner_gid[entries.clone()]);
        self.anchor.extend_from_slice(&other.anchor[entries.clone()]);
        self.spring_stiffness.extend_from_slice(&other.spring_stiffness[entries.clone()]);
        self.touching.extend_from_slice(&other.touching[entries.clone()]);
        self.max_overlap.extend_from_slice(&other.max_overlap[entries]);
        self.retired_length.push(other.retired_length[k]);
        self.retired_gid.extend_from_slice(&other.retired_gid[retired.clone()]);
        self.retired_max_overlap.extend_from_slice(&other.retired_max_overlap[retired]);
    }

    /// Contact entries and retired contacts of each row.
    fn row_ranges(&self) -> Vec<(std::ops::Range<usize>, std::ops::Range<usize>)> {
        let ranges = |lengths: &[u32]| -> Vec<std::ops::Range<usize>> {
            lengths
                .iter()
                .scan(0usize, |next, &l| {
                    let start = *next;
                    *next += l as usize;
                    Some(start..*next)
                })
                .collect()
        };
        ranges(&self.row_length).into_iter().zip(ranges(&self.retired_length)).collect()
    }

    /// Appends the rows of `other` whose gid `keep` selects (rows stay in their order).
    pub fn append_selected(&mut self, other: &NodeState, keep: impl Fn(u64) -> bool) {
        for (k, ranges) in other.row_ranges().into_iter().enumerate() {
            if keep(other.gid[k]) {
                self.push_row(other, k, ranges);
            }
        }
    }

    /// The rows sorted by gid (parts read from several files arrive file by file).
    pub fn sorted(self) -> NodeState {
        let mut order: Vec<usize> = (0..self.gid.len()).collect();
        order.sort_unstable_by_key(|&k| self.gid[k]);
        let ranges = self.row_ranges();
        let mut sorted = NodeState::default();
        for k in order {
            sorted.push_row(&self, k, ranges[k].clone());
        }
        sorted
    }
}

/// A CRC-32 over values in a fixed order: what a part or a manifest holds, so that a file
/// damaged after it was written is refused, not loaded.
#[derive(Default)]
struct Checksum(crc32fast::Hasher);

impl Checksum {
    fn floats(&mut self, values: &[f64]) -> &mut Self {
        values.iter().for_each(|v| self.0.update(&v.to_le_bytes()));
        self
    }
    fn vectors(&mut self, values: &[Vec3]) -> &mut Self {
        values.iter().for_each(|v| {
            self.floats(v.as_slice());
        });
        self
    }
    fn integers(&mut self, values: impl IntoIterator<Item = u64>) -> &mut Self {
        values.into_iter().for_each(|v| self.0.update(&v.to_le_bytes()));
        self
    }
    fn bytes(&mut self, values: &[u8]) -> &mut Self {
        self.0.update(values);
        self
    }
    fn value(&mut self) -> u32 {
        std::mem::take(&mut self.0).finalize()
    }
}

impl NodeState {
    /// Checksum of every array.
    pub fn checksum(&self) -> u32 {
        let mut c = Checksum::default();
        c.integers(self.gid.iter().copied())
            .vectors(&self.position)
            .vectors(&self.velocity)
            .vectors(&self.force)
            .vectors(&self.reference_position)
            .bytes(&self.failure)
            .floats(&self.tensile_strength)
            .floats(&self.friction_dissipated)
            .floats(&self.plastic_dissipated)
            .floats(&self.fracture_released)
            .vectors(&self.projectile_anchor)
            .vectors(&self.projectile_stretch)
            .floats(&self.projectile_spring_stiffness)
            .bytes(&self.projectile_touching)
            .floats(&self.projectile_max_overlap)
            .integers(self.projectile_anchor_triangle.iter().map(|&t| t as u64))
            .vectors(&self.projectile_anchor_weights)
            .integers(self.row_length.iter().map(|&l| l as u64))
            .integers(self.partner_gid.iter().copied())
            .vectors(&self.anchor)
            .floats(&self.spring_stiffness)
            .bytes(&self.touching)
            .floats(&self.max_overlap)
            .integers(self.retired_length.iter().map(|&l| l as u64))
            .integers(self.retired_gid.iter().copied())
            .floats(&self.retired_max_overlap)
            .value()
    }
}

/// What is the same on every rank: the case, the step, the projectile, global counters, and
/// rank 0's run state.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GlobalState {
    /// the case as run (JSON)
    pub case_json: String,
    /// ranks that wrote the parts
    pub parts: u32,
    /// nodes in all parts together
    pub nodes: u64,
    /// steps taken since the shot began
    pub step: u64,
    /// [s]
    pub time: f64,
    /// projectile: position, velocity, angular momentum, force, torque (3 each), orientation
    /// quaternion (i, j, k, w)
    pub projectile: Vec<f64>,
    /// broken elements by mode, whole problem
    pub broken: [u64; 3],
    /// ghost rebuilds and neighbour-list builds so far
    pub rebuilds: u64,
    /// (the neighbour-list builds)
    pub list_builds: u64,
    /// run-loop scalars of rank 0 (largest force, initial energy, back face, …), in the
    /// solver's order
    pub run_scalars: Vec<f64>,
    /// the run's sampled histories up to the checkpoint
    pub histories: Histories,
    /// the checksum ([`NodeState::checksum`]) of each rank's part, in rank order: binds the
    /// parts to this manifest, so a part of another checkpoint is refused
    pub part_checksums: Vec<u32>,
}

impl GlobalState {
    /// Checksum of everything but the histories' energies and counts per layer (those are
    /// checked by length).
    pub fn checksum(&self) -> u32 {
        let h = &self.histories;
        let mut c = Checksum::default();
        c.bytes(self.case_json.as_bytes())
            .integers([
                self.parts as u64,
                self.nodes,
                self.step,
                self.broken[0],
                self.broken[1],
                self.broken[2],
                self.rebuilds,
                self.list_builds,
            ])
            .floats(&[self.time])
            .floats(&self.projectile)
            .floats(&self.run_scalars)
            .floats(&h.time)
            .vectors(&h.projectile_position)
            .vectors(&h.projectile_velocity)
            .vectors(&h.projectile_angular_velocity)
            .vectors(&h.projectile_force)
            .integers(h.broken_tension.iter().chain(&h.broken_shear).chain(&h.broken_combined).copied())
            .integers(self.part_checksums.iter().map(|&c| c as u64))
            .value()
    }
}

/// File of part `rank` in a checkpoint directory.
pub fn part_path(directory: &Path, rank: u32) -> PathBuf {
    directory.join(format!("part-{rank:05}.h5"))
}

/// Manifest of a checkpoint directory.
pub fn manifest_path(directory: &Path) -> PathBuf {
    directory.join("manifest.h5")
}

fn write_bytes(group: &hdf5::Group, name: &str, values: &[u8], unit: &str) -> hdf5::Result<()> {
    write_scalars(group, name, values, unit)
}

/// Writes one rank's part and flushes it to disk.
pub fn write_part(path: &Path, part: &NodeState) -> hdf5::Result<()> {
    {
        let file = hdf5::File::create(path)?;
        write_text_attribute(&file, "format", FORMAT)?;
        write_scalars(&file, "gid", &part.gid, "-")?;
        write_vectors(&file, "position", &part.position, "m")?;
        write_vectors(&file, "velocity", &part.velocity, "m/s")?;
        write_vectors(&file, "force", &part.force, "N")?;
        write_vectors(&file, "reference_position", &part.reference_position, "m")?;
        write_bytes(&file, "failure", &part.failure, "failure mode code")?;
        write_scalars(&file, "tensile_strength", &part.tensile_strength, "Pa")?;
        write_scalars(&file, "friction_dissipated", &part.friction_dissipated, "J")?;
        write_scalars(&file, "plastic_dissipated", &part.plastic_dissipated, "J")?;
        write_scalars(&file, "fracture_released", &part.fracture_released, "J")?;
        write_vectors(&file, "projectile_anchor", &part.projectile_anchor, "m")?;
        write_vectors(&file, "projectile_stretch", &part.projectile_stretch, "m")?;
        write_scalars(&file, "projectile_spring_stiffness", &part.projectile_spring_stiffness, "N/m")?;
        write_bytes(&file, "projectile_touching", &part.projectile_touching, "bool")?;
        write_scalars(&file, "projectile_max_overlap", &part.projectile_max_overlap, "m")?;
        write_scalars(&file, "projectile_anchor_triangle", &part.projectile_anchor_triangle, "-")?;
        write_vectors(&file, "projectile_anchor_weights", &part.projectile_anchor_weights, "-")?;
        write_scalars(&file, "row_length", &part.row_length, "entries")?;
        write_scalars(&file, "partner_gid", &part.partner_gid, "-")?;
        write_vectors(&file, "anchor", &part.anchor, "m")?;
        write_scalars(&file, "spring_stiffness", &part.spring_stiffness, "N/m")?;
        write_bytes(&file, "touching", &part.touching, "bool")?;
        write_scalars(&file, "max_overlap", &part.max_overlap, "m")?;
        write_scalars(&file, "retired_length", &part.retired_length, "entries")?;
        write_scalars(&file, "retired_gid", &part.retired_gid, "-")?;
        write_scalars(&file, "retired_max_overlap", &part.retired_max_overlap, "m")?;
        write_scalars(&file, "checksum", &[part.checksum()], "CRC-32")?;
        file.flush()?;
    }
    sync(path)
}

/// Forces a written file to stable storage, then writes the CRC-32 of its bytes beside it
/// (`<file>.crc32`), so that a damaged file is refused before HDF5 parses it: the library
/// can crash on a flipped bit in its own metadata (a fuzzed manifest ended in a segfault).
fn sync(path: &Path) -> hdf5::Result<()> {
    let failed = |e: std::io::Error| hdf5::Error::from(format!("{}: {e}", path.display()).as_str());
    std::fs::File::open(path).and_then(|f| f.sync_all()).map_err(failed)?;
    let bytes = std::fs::read(path).map_err(failed)?;
    let sidecar = crc_path(path);
    std::fs::write(&sidecar, format!("{:08x} {}\n", crc32fast::hash(&bytes), bytes.len()))
        .and_then(|()| std::fs::File::open(&sidecar)?.sync_all())
        .map_err(failed)
}

/// Where the CRC-32 of a checkpoint file is kept.
fn crc_path(path: &Path) -> std::path::PathBuf {
    let mut name = path.as_os_str().to_owned();
    name.push(".crc32");
    std::path::PathBuf::from(name)
}

/// Checks a checkpoint file's bytes against the CRC-32 kept beside it (a checkpoint written
/// before these were kept has none, and is not checked).
fn check_bytes(path: &Path) -> Result<(), CheckpointError> {
    let Ok(kept) = std::fs::read_to_string(crc_path(path)) else { return Ok(()) };
    let bytes = std::fs::read(path).map_err(|e| error(path, format!("cannot read: {e}")))?;
    let actual = format!("{:08x} {}", crc32fast::hash(&bytes), bytes.len());
    if kept.trim() == actual {
        Ok(())
    } else {
        Err(error(
            path,
            format!("damaged: its CRC-32 and size are {actual}, the checkpoint recorded {:?}", kept.trim()),
        ))
    }
}

fn open(path: &Path) -> Result<hdf5::File, CheckpointError> {
    if !path.exists() {
        return Err(error(path, "missing"));
    }
    check_bytes(path)?;
    let file = hdf5::File::open(path).map_err(|e| error(path, format!("cannot open (truncated or corrupt?): {e}")))?;
    let format: String = file
        .attr("format")
        .and_then(|a| a.read_scalar::<hdf5::types::VarLenUnicode>())
        .map(|s| s.to_string())
        .map_err(|e| error(path, format!("not a dea-mpi checkpoint: {e}")))?;
    if format != FORMAT {
        return Err(error(path, format!("format {format:?}, expected {FORMAT:?}")));
    }
    Ok(file)
}

/// Reads one rank's part, checking that its arrays agree in length.
pub fn read_part(path: &Path) -> Result<NodeState, CheckpointError> {
    let file = open(path)?;
    let fail = |e: hdf5::Error| error(path, format!("unreadable: {e}"));
    let vectors = |name: &str| -> Result<Vec<Vec3>, CheckpointError> {
        let flat: Vec<f64> = file.dataset(name).and_then(|d| d.read_raw()).map_err(fail)?;
        Ok(flat.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect())
    };
    let part = NodeState {
        gid: file.dataset("gid").and_then(|d| d.read_raw()).map_err(fail)?,
        position: vectors("position")?,
        velocity: vectors("velocity")?,
        force: vectors("force")?,
        reference_position: vectors("reference_position")?,
        failure: file.dataset("failure").and_then(|d| d.read_raw()).map_err(fail)?,
        tensile_strength: file.dataset("tensile_strength").and_then(|d| d.read_raw()).map_err(fail)?,
        friction_dissipated: file.dataset("friction_dissipated").and_then(|d| d.read_raw()).map_err(fail)?,
        plastic_dissipated: file.dataset("plastic_dissipated").and_then(|d| d.read_raw()).map_err(fail)?,
        fracture_released: file.dataset("fracture_released").and_then(|d| d.read_raw()).map_err(fail)?,
        projectile_anchor: vectors("projectile_anchor")?,
        projectile_stretch: vectors("projectile_stretch")?,
        projectile_spring_stiffness: file
            .dataset("projectile_spring_stiffness")
            .and_then(|d| d.read_raw())
            .map_err(fail)?,
        projectile_touching: file.dataset("projectile_touching").and_then(|d| d.read_raw()).map_err(fail)?,
        projectile_max_overlap: file.dataset("projectile_max_overlap").and_then(|d| d.read_raw()).map_err(fail)?,
        projectile_anchor_triangle: file
            .dataset("projectile_anchor_triangle")
            .and_then(|d| d.read_raw())
            .map_err(fail)?,
        projectile_anchor_weights: vectors("projectile_anchor_weights")?,
        row_length: file.dataset("row_length").and_then(|d| d.read_raw()).map_err(fail)?,
        partner_gid: file.dataset("partner_gid").and_then(|d| d.read_raw()).map_err(fail)?,
        anchor: vectors("anchor")?,
        spring_stiffness: file.dataset("spring_stiffness").and_then(|d| d.read_raw()).map_err(fail)?,
        touching: file.dataset("touching").and_then(|d| d.read_raw()).map_err(fail)?,
        max_overlap: file.dataset("max_overlap").and_then(|d| d.read_raw()).map_err(fail)?,
        retired_length: file.dataset("retired_length").and_then(|d| d.read_raw()).map_err(fail)?,
        retired_gid: file.dataset("retired_gid").and_then(|d| d.read_raw()).map_err(fail)?,
        retired_max_overlap: file.dataset("retired_max_overlap").and_then(|d| d.read_raw()).map_err(fail)?,
    };
    let n = part.gid.len();
    let node_lengths = [
        part.position.len(),
        part.velocity.len(),
        part.force.len(),
        part.reference_position.len(),
        part.failure.len(),
        part.tensile_strength.len(),
        part.friction_dissipated.len(),
        part.plastic_dissipated.len(),
        part.fracture_released.len(),
        part.projectile_anchor.len(),
        part.projectile_stretch.len(),
        part.projectile_spring_stiffness.len(),
        part.projectile_touching.len(),
        part.projectile_max_overlap.len(),
        part.projectile_anchor_triangle.len(),
        part.projectile_anchor_weights.len(),
        part.row_length.len(),
        part.retired_length.len(),
    ];
    let entries: usize = part.row_length.iter().map(|&l| l as usize).sum();
    let entry_lengths = [
        part.partner_gid.len(),
        part.anchor.len(),
        part.spring_stiffness.len(),
        part.touching.len(),
        part.max_overlap.len(),
    ];
    let retired: usize = part.retired_length.iter().map(|&l| l as usize).sum();
    let retired_lengths = [part.retired_gid.len(), part.retired_max_overlap.len()];
    if node_lengths.iter().any(|&l| l != n)
        || entry_lengths.iter().any(|&l| l != entries)
        || retired_lengths.iter().any(|&l| l != retired)
    {
        return Err(error(path, "arrays of different lengths: the part is damaged"));
    }
    let stored: Vec<u32> = file.dataset("checksum").and_then(|d| d.read_raw()).map_err(fail)?;
    if stored != [part.checksum()] {
        return Err(error(path, "checksum mismatch: the part is corrupt"));
    }
    Ok(part)
}

/// Writes the manifest (last, after every part) and flushes it to disk.
pub fn write_manifest(path: &Path, global: &GlobalState) -> hdf5::Result<()> {
    {
        let file = hdf5::File::create(path)?;
        write_text_attribute(&file, "format", FORMAT)?;
        write_text_attribute(&file, "case", &global.case_json)?;
        let counters = [
            global.parts as u64,
            global.nodes,
            global.step,
            global.broken[0],
            global.broken[1],
            global.broken[2],
            global.rebuilds,
            global.list_builds,
        ];
        write_scalars(
            &file,
            "counters",
            &counters,
            "parts, nodes, step, broken tension/shear/combined, rebuilds, list builds",
        )?;
        write_scalars(&file, "time", &[global.time], "s")?;
        write_scalars(&file, "projectile", &global.projectile, "SI")?;
        write_scalars(&file, "run_scalars", &global.run_scalars, "SI")?;
        write_histories(&file, &global.histories)?;
        write_scalars(&file, "part_checksums", &global.part_checksums, "CRC-32 of each part, rank order")?;
        write_scalars(&file, "checksum", &[global.checksum()], "CRC-32")?;
        // the completion mark goes last: a manifest without it is refused
        write_text_attribute(&file, "complete", "yes")?;
        file.flush()?;
    }
    sync(path)
}

/// Reads and checks the manifest of a checkpoint directory.
pub fn read_manifest(directory: &Path) -> Result<GlobalState, CheckpointError> {
    let path = manifest_path(directory);
    let file = open(&path)?;
    let fail = |e: hdf5::Error| error(&path, format!("unreadable: {e}"));
    if file.attr("complete").is_err() {
        return Err(error(&path, "incomplete (the writer stopped before finishing it)"));
    }
    let case_json =
        file.attr("case").and_then(|a| a.read_scalar::<hdf5::types::VarLenUnicode>()).map_err(fail)?.to_string();
    let counters: Vec<u64> = file.dataset("counters").and_then(|d| d.read_raw()).map_err(fail)?;
    let reals: Vec<f64> = file.dataset("time").and_then(|d| d.read_raw()).map_err(fail)?;
    if counters.len() != 8 || reals.len() != 1 {
        return Err(error(&path, "damaged counters"));
    }
    let global = GlobalState {
        case_json,
        parts: counters[0] as u32,
        nodes: counters[1],
        step: counters[2],
        broken: [counters[3], counters[4], counters[5]],
        rebuilds: counters[6],
        list_builds: counters[7],
        time: reals[0],
        projectile: file.dataset("projectile").and_then(|d| d.read_raw()).map_err(fail)?,
        run_scalars: file.dataset("run_scalars").and_then(|d| d.read_raw()).map_err(fail)?,
        histories: read_histories_from(&file).map_err(fail)?,
        part_checksums: file
            .dataset("part_checksums")
            .and_then(|d| d.read_raw())
            .map_err(|_| error(&path, "damaged: no checksums of its parts"))?,
    };
    if global.part_checksums.len() != global.parts as usize {
        return Err(error(&path, "damaged: the checksums do not match the count of parts"));
    }
    let stored: Vec<u32> = file.dataset("checksum").and_then(|d| d.read_raw()).map_err(fail)?;
    if stored != [global.checksum()] {
        return Err(error(&path, "checksum mismatch: the manifest is corrupt"));
    }
    Ok(global)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn part(gids: &[u64]) -> NodeState {
        let mut p = NodeState::default();
        for &g in gids {
            let x = Vec3::new(g as f64, 2.0 * g as f64, 0.5);
            p.gid.push(g);
            p.position.push(x);
            p.velocity.push(x * 2.0);
            p.force.push(x * 3.0);
            p.reference_position.push(x * 4.0);
            p.failure.push((g % 4) as u8);
            p.tensile_strength.push(g as f64 * 1e9);
            p.friction_dissipated.push(1.0);
            p.plastic_dissipated.push(2.0);
            p.fracture_released.push(3.0);
            p.projectile_anchor.push(x);
            p.projectile_stretch.push(x * 0.5);
            p.projectile_spring_stiffness.push(g as f64 * 10.0);
            p.projectile_touching.push(1);
            p.projectile_max_overlap.push(1e-6);
            p.projectile_anchor_triangle.push(g as u32);
            p.projectile_anchor_weights.push(Vec3::new(0.2, 0.3, 0.5));
            p.row_length.push((g % 3) as u32);
            for e in 0..g % 3 {
                p.partner_gid.push(g * 10 + e);
                p.anchor.push(x * e as f64);
                p.spring_stiffness.push(e as f64 * 100.0);
                p.touching.push((e % 2) as u8);
                p.max_overlap.push(e as f64 * 1e-7);
            }
            p.retired_length.push((g % 2) as u32);
            for e in 0..g % 2 {
                p.retired_gid.push(g * 100 + e);
                p.retired_max_overlap.push(g as f64 * 1e-8);
            }
        }
        p
    }

    #[test]
    fn parts_round_trip_select_and_sort_and_damage_is_refused() {
        let dir = std::env::temp_dir().join(format!("dea-checkpoint-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let original = part(&[2, 5, 7, 8, 11]);
        let path = part_path(&dir, 3);
        write_part(&path, &original).unwrap();
        let read = read_part(&path).unwrap();
        assert_eq!(read, original);
        // the rows of two parts, selected and merged, come back in gid order
        let other = part(&[1, 4, 6]);
        let mut merged = NodeState::default();
        merged.append_selected(&read, |g| g != 7);
        merged.append_selected(&other, |g| g != 4);
        let merged = merged.sorted();
        assert_eq!(merged.gid, vec![1, 2, 5, 6, 8, 11]);
        let mut expected = NodeState::default();
        expected.append_selected(&part(&[1, 2, 5, 6, 8, 11]), |_| true);
        assert_eq!(merged, expected);
        // a value changed inside an intact file is caught by the checksum
        {
            let file = hdf5::File::open_rw(&path).unwrap();
            let dataset = file.dataset("velocity").unwrap();
            let mut values: Vec<f64> = dataset.read_raw().unwrap();
            values[4] += 1e-9;
            dataset.write_raw(&values).unwrap();
        }
        // ...by the CRC-32 of its bytes kept beside it, before HDF5 reads it
        let message = read_part(&path).unwrap_err().to_string();
        assert!(message.contains("part-00003.h5: damaged: its CRC-32"), "{message}");
        // ...and, without that, by the checksum of its contents
        std::fs::remove_file(crc_path(&path)).unwrap();
        let message = read_part(&path).unwrap_err().to_string();
        assert!(message.contains("checksum mismatch"), "{message}");
        write_part(&path, &original).unwrap();
        assert_eq!(read_part(&path).unwrap(), original);
        // a truncated part is refused with its name, with its CRC-32 or by HDF5
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
        let message = read_part(&path).unwrap_err().to_string();
        assert!(message.contains("part-00003.h5") && message.contains("damaged"), "{message}");
        std::fs::remove_file(crc_path(&path)).unwrap();
        let message = read_part(&path).unwrap_err().to_string();
        assert!(message.contains("part-00003.h5") && message.contains("truncated"), "{message}");
        // a manifest round-trips; one without its completion mark is refused
        let global = GlobalState {
            case_json: "{}".into(),
            parts: 2,
            nodes: 8,
            step: 40,
            time: 1e-7,
            projectile: (0..19).map(|k| k as f64).collect(),
            broken: [1, 2, 3],
            rebuilds: 4,
            list_builds: 5,
            run_scalars: vec![1.5, 2.5],
            histories: Histories {
                time: vec![0.0],
                projectile_position: vec![Vec3::x()],
                projectile_velocity: vec![Vec3::y()],
                projectile_angular_velocity: vec![Vec3::z()],
                broken_by_layer: vec![vec![1, 2, 3]],
                projectile_force: vec![Vec3::z()],
                energy: vec![Default::default()],
                broken_tension: vec![0],
                broken_shear: vec![0],
                broken_combined: vec![0],
                back_face_largest: vec![1e-3],
                back_face_at_axis: vec![2e-3],
            },
            part_checksums: vec![7, 9],
        };
        write_manifest(&manifest_path(&dir), &global).unwrap();
        assert_eq!(read_manifest(&dir).unwrap(), global);
        {
            let file = hdf5::File::create(manifest_path(&dir)).unwrap();
            write_text_attribute(&file, "format", FORMAT).unwrap();
        }
        assert!(read_manifest(&dir).unwrap_err().to_string().contains("damaged"), "the bytes changed");
        std::fs::remove_file(crc_path(&manifest_path(&dir))).unwrap();
        assert!(read_manifest(&dir).unwrap_err().to_string().contains("incomplete"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
