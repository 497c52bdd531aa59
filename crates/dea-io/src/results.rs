//! HDF5 results: the case as run and the time histories, and their CSV twin.
//!
//! Layout (docs/output.md):
//! - attribute `case` (JSON text), attribute `format` = "dea-mpi results 1"
//! - `history/time` [s], `history/projectile_position` (n x 3) [m],
//!   `history/projectile_velocity` (n x 3) [m/s], `history/projectile_angular_velocity`
//!   (n x 3) [rad/s], `history/projectile_force` (n x 3) [N], `history/energy/<kind>` [J],
//!   `history/broken/{tension,shear,combined}` [-], `history/broken/by_layer` (n x layers),
//!   `history/back_face/{largest,at_axis}` [m]
//!
//! Field data, the final state included, are in the per-rank snapshots (`snapshot.rs`):
//! no rank ever gathers every node.

use dea_core::energy::EnergyReport;
use dea_core::Vec3;
use hdf5::types::VarLenUnicode;

/// Time histories sampled during a run.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Histories {
    /// [s]
    pub time: Vec<f64>,
    /// [m]
    pub projectile_position: Vec<Vec3>,
    /// [m/s]
    pub projectile_velocity: Vec<Vec3>,
    /// [rad/s]
    pub projectile_angular_velocity: Vec<Vec3>,
    /// contact force on the projectile [N]
    pub projectile_force: Vec<Vec3>,
    /// the energy balance's terms [J]
    pub energy: Vec<EnergyReport>,
    /// cumulative broken elements by mode
    pub broken_tension: Vec<u64>,
    /// (in shear)
    pub broken_shear: Vec<u64>,
    /// (with both terms significant)
    pub broken_combined: Vec<u64>,
    /// cumulative broken elements of each layer (one row per sample)
    pub broken_by_layer: Vec<Vec<u64>>,
    /// the last layer's largest deflection along the panel's inward normal, over its nodes
    /// still joined to both fibre neighbours; NaN if none [m]
    pub back_face_largest: Vec<f64>,
    /// the deflection of its node nearest the impact axis as built [m]
    pub back_face_at_axis: Vec<f64>,
}

/// Names of the energy datasets, in [`EnergyReport`] field order.
pub const ENERGY_KINDS: [&str; 10] = EnergyReport::KINDS;

pub(crate) fn write_vectors(group: &hdf5::Group, name: &str, values: &[Vec3], unit: &str) -> hdf5::Result<()> {
    let flat: Vec<f64> = values.iter().flat_map(|v| [v.x, v.y, v.z]).collect();
    let dataset = group.new_dataset::<f64>().shape([values.len(), 3]).create(name)?;
    dataset.write_raw(&flat)?;
    write_text_attribute(&dataset, "units", unit)
}

pub(crate) fn write_scalars<T: hdf5::H5Type + Copy>(
    group: &hdf5::Group,
    name: &str,
    values: &[T],
    unit: &str,
) -> hdf5::Result<()> {
    let dataset = group.new_dataset::<T>().shape([values.len()]).create(name)?;
    dataset.write_raw(values)?;
    write_text_attribute(&dataset, "units", unit)
}

pub(crate) fn write_text_attribute(location: &hdf5::Location, name: &str, text: &str) -> hdf5::Result<()> {
    let value: VarLenUnicode = text.parse().map_err(|e| hdf5::Error::from(format!("{e:?}").as_str()))?;
    location.new_attr::<VarLenUnicode>().create(name)?.write_scalar(&value)
}

/// Writes the `history` group of a results file or a checkpoint.
pub(crate) fn write_histories(file: &hdf5::File, histories: &Histories) -> hdf5::Result<()> {
    let history = file.create_group("history")?;
    write_scalars(&history, "time", &histories.time, "s")?;
    write_vectors(&history, "projectile_position", &histories.projectile_position, "m")?;
    write_vectors(&history, "projectile_velocity", &histories.projectile_velocity, "m/s")?;
    write_vectors(&history, "projectile_angular_velocity", &histories.projectile_angular_velocity, "rad/s")?;
    write_vectors(&history, "projectile_force", &histories.projectile_force, "N")?;
    let energy = history.create_group("energy")?;
    for (k, name) in ENERGY_KINDS.iter().enumerate() {
        let values: Vec<f64> = histories.energy.iter().map(|e| e.values()[k]).collect();
        write_scalars(&energy, name, &values, "J")?;
    }
    let total: Vec<f64> = histories.energy.iter().map(EnergyReport::total).collect();
    write_scalars(&energy, "total", &total, "J")?;
    let broken = history.create_group("broken")?;
    write_scalars(&broken, "tension", &histories.broken_tension, "elements")?;
    write_scalars(&broken, "shear", &histories.broken_shear, "elements")?;
    write_scalars(&broken, "combined", &histories.broken_combined, "elements")?;
    let layers = histories.broken_by_layer.first().map_or(0, Vec::len);
    let flat: Vec<u64> = histories.broken_by_layer.iter().flatten().copied().collect();
    let by_layer = broken.new_dataset::<u64>().shape([histories.broken_by_layer.len(), layers]).create("by_layer")?;
    by_layer.write_raw(&flat)?;
    write_text_attribute(&by_layer, "units", "elements (sample x layer)")?;
    let back_face = history.create_group("back_face")?;
    write_scalars(&back_face, "largest", &histories.back_face_largest, "m")?;
    write_scalars(&back_face, "at_axis", &histories.back_face_at_axis, "m")
}

/// Writes the histories as CSV, units in the column names; numbers in the shortest form
/// that reads back to the same bits.
pub fn write_histories_csv(path: &std::path::Path, histories: &Histories) -> std::io::Result<()> {
    use std::fmt::Write as _;
    let layers = histories.broken_by_layer.first().map_or(0, Vec::len);
    let mut text = String::from("time_s");
    for (name, unit) in [
        ("projectile_position", "m"),
        ("projectile_velocity", "m_s"),
        ("projectile_angular_velocity", "rad_s"),
        ("projectile_force", "N"),
    ] {
        for axis in ["x", "y", "z"] {
            let _ = write!(text, ",{name}_{axis}_{unit}");
        }
    }
    for kind in ENERGY_KINDS.iter().chain(&["total"]) {
        let _ = write!(text, ",energy_{kind}_J");
    }
    text.push_str(",broken_tension,broken_shear,broken_combined");
    for layer in 0..layers {
        let _ = write!(text, ",broken_layer_{layer}");
    }
    text.push_str(",back_face_largest_m,back_face_at_axis_m\n");
    for s in 0..histories.time.len() {
        let _ = write!(text, "{:?}", histories.time[s]);
        for v in [
            histories.projectile_position[s],
            histories.projectile_velocity[s],
            histories.projectile_angular_velocity[s],
            histories.projectile_force[s],
        ] {
            let _ = write!(text, ",{:?},{:?},{:?}", v.x, v.y, v.z);
        }
        let e = &histories.energy[s];
        for value in e.values().iter().chain(&[e.total()]) {
            let _ = write!(text, ",{value:?}");
        }
        let _ = write!(
            text,
            ",{},{},{}",
            histories.broken_tension[s], histories.broken_shear[s], histories.broken_combined[s]
        );
        for count in &histories.broken_by_layer[s] {
            let _ = write!(text, ",{count}");
        }
        let _ = writeln!(text, ",{:?},{:?}", histories.back_face_largest[s], histories.back_face_at_axis[s]);
    }
    std::fs::write(path, text)
}

/// The `format` attribute of a results file.
pub const RESULTS_FORMAT: &str = "dea-mpi results 1";

/// Writes a complete results file.

pub fn write_results(path: &std::path::Path, case_json: &str, histories: &Histories) -> hdf5::Result<()> {
    let file = hdf5::File::create(path)?;
    write_text_attribute(&file, "format", RESULTS_FORMAT)?;
    write_text_attribute(&file, "case", case_json)?;
    write_histories(&file, histories)?;
    file.flush()
}

/// Reads back the histories (used by tests and post-processing checks).
pub fn read_histories(path: &std::path::Path) -> hdf5::Result<Histories> {
    read_histories_from(&hdf5::File::open(path)?)
}

/// The `history` group of an open results file or checkpoint.
pub(crate) fn read_histories_from(file: &hdf5::File) -> hdf5::Result<Histories> {
    let vectors = |name: &str| -> hdf5::Result<Vec<Vec3>> {
        let flat: Vec<f64> = file.dataset(name)?.read_raw()?;
        Ok(flat.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect())
    };
    let energies: Vec<Vec<f64>> = ENERGY_KINDS
        .iter()
        .map(|k| file.dataset(&format!("history/energy/{k}"))?.read_raw())
        .collect::<hdf5::Result<_>>()?;
    let time: Vec<f64> = file.dataset("history/time")?.read_raw()?;
    let energy = (0..time.len())
        .map(|s| {
            let e = |k: usize| energies[k][s];
            EnergyReport {
                fibre_kinetic: e(0),
                projectile_kinetic: e(1),
                projectile_strain: e(2),
                axial: e(3),
                bending: e(4),
                contact: e(5),
                friction_stored: e(6),
                friction_dissipated: e(7),
                plastic_dissipated: e(8),
                fracture_released: e(9),
            }
        })
        .collect();
    Ok(Histories {
        projectile_position: vectors("history/projectile_position")?,
        projectile_velocity: vectors("history/projectile_velocity")?,
        projectile_angular_velocity: vectors("history/projectile_angular_velocity")?,
        projectile_force: vectors("history/projectile_force")?,
        broken_by_layer: {
            let dataset = file.dataset("history/broken/by_layer")?;
            let layers = dataset.shape().get(1).copied().unwrap_or(0);
            let flat: Vec<u64> = dataset.read_raw()?;
            if layers == 0 {
                vec![Vec::new(); dataset.shape()[0]]
            } else {
                flat.chunks_exact(layers).map(<[u64]>::to_vec).collect()
            }
        },
        broken_tension: file.dataset("history/broken/tension")?.read_raw()?,
        broken_shear: file.dataset("history/broken/shear")?.read_raw()?,
        broken_combined: file.dataset("history/broken/combined")?.read_raw()?,
        back_face_largest: file.dataset("history/back_face/largest")?.read_raw()?,
        back_face_at_axis: file.dataset("history/back_face/at_axis")?.read_raw()?,
        time,
        energy,
    })
}

/// Every dataset below `group`, as paths from the file's root, sorted.
fn dataset_paths(group: &hdf5::Group, prefix: &str, paths: &mut Vec<String>) -> hdf5::Result<()> {
    for name in group.member_names()? {
        let path = format!("{prefix}{name}");
        match group.loc_type_by_name(&name)? {
            hdf5::LocationType::Group => dataset_paths(&group.group(&name)?, &format!("{path}/"), paths)?,
            hdf5::LocationType::Dataset => paths.push(path),
            _ => {}
        }
    }
    paths.sort();
    Ok(())
}

/// The raw bits of a dataset of any type the results use.
fn dataset_bits(dataset: &hdf5::Dataset) -> hdf5::Result<Vec<u64>> {
    use hdf5::types::{FloatSize, IntSize, TypeDescriptor};
    Ok(match dataset.dtype()?.to_descriptor()? {
        TypeDescriptor::Float(FloatSize::U8) => dataset.read_raw::<f64>()?.into_iter().map(f64::to_bits).collect(),
        TypeDescriptor::Unsigned(IntSize::U8) => dataset.read_raw::<u64>()?,
        TypeDescriptor::Unsigned(IntSize::U4) => dataset.read_raw::<u32>()?.into_iter().map(u64::from).collect(),
        TypeDescriptor::Unsigned(IntSize::U1) => dataset.read_raw::<u8>()?.into_iter().map(u64::from).collect(),
        other => return Err(format!("{}: unsupported type {other:?}", dataset.name()).as_str().into()),
    })
}

/// Differences between two results files (or two relaxed cells, `dea-mpi fabric`'s
/// `cell.h5`), dataset by dataset and bit for bit. Empty when they are identical. Anything
/// else (a checkpoint's manifest, a field part, one of each kind) is refused by name.
pub fn compare_results(a: &std::path::Path, b: &std::path::Path) -> hdf5::Result<Vec<String>> {
    let comparable = [RESULTS_FORMAT, crate::cell::CELL_FORMAT];
    let open = |path: &std::path::Path| -> hdf5::Result<(hdf5::File, String)> {
        let named = |e: hdf5::Error| -> hdf5::Error { format!("{}: {e}", path.display()).as_str().into() };
        let file = hdf5::File::open(path).map_err(named)?;
        let format = file
            .attr("format")
            .and_then(|a| a.read_scalar::<hdf5::types::VarLenUnicode>())
            .map(|f| f.to_string())
            .unwrap_or_else(|_| "no format".into());
        if !comparable.contains(&format.as_str()) {
            return Err(format!(
                "{}: not a run's results ({RESULTS_FORMAT:?}) or a relaxed cell ({:?}) but {format:?}: compare two runs' OUT/results.h5",
                path.display(),
                crate::cell::CELL_FORMAT
            )
            .as_str()
            .into());
        }
        Ok((file, format))
    };
    let ((file_a, format_a), (file_b, format_b)) = (open(a)?, open(b)?);
    if format_a != format_b {
        return Err(format!(
            "{} is {format_a:?} and {} is {format_b:?}: compare two of a kind",
            a.display(),
            b.display()
        )
        .as_str()
        .into());
    }
    let (mut paths_a, mut paths_b) = (Vec::new(), Vec::new());
    dataset_paths(&file_a, "", &mut paths_a)?;
    dataset_paths(&file_b, "", &mut paths_b)?;
    let mut differences = Vec::new();
    for path in paths_a.iter().filter(|p| !paths_b.contains(p)) {
        differences.push(format!("{path}: only in {}", a.display()));
    }
    for path in paths_b.iter().filter(|p| !paths_a.contains(p)) {
        differences.push(format!("{path}: only in {}", b.display()));
    }
    for path in paths_a.iter().filter(|p| paths_b.contains(p)) {
        let (x, y) = (file_a.dataset(path)?, file_b.dataset(path)?);
        if x.shape() != y.shape() {
            differences.push(format!("{path}: shape {:?} vs {:?}", x.shape(), y.shape()));
            continue;
        }
        let (bits_x, bits_y) = (dataset_bits(&x)?, dataset_bits(&y)?);
        if let Some(k) = bits_x.iter().zip(&bits_y).position(|(p, q)| p != q) {
            let count = bits_x.iter().zip(&bits_y).filter(|(p, q)| p != q).count();
            differences.push(format!("{path}: {count} of {} values differ, first at flat index {k}", bits_x.len()));
        }
    }
    Ok(differences)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn histories_round_trip_through_hdf5() {
        let dir = std::env::temp_dir().join(format!("dea-io-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("results.h5");
        let histories = Histories {
            time: vec![0.0, 1e-9],
            projectile_position: vec![Vec3::new(1.0, 2.0, 3.0), Vec3::new(4.0, 5.0, 6.0)],
            projectile_velocity: vec![Vec3::zeros(), Vec3::x()],
            projectile_angular_velocity: vec![Vec3::x() * 2.0, Vec3::zeros()],
            projectile_force: vec![Vec3::y(), Vec3::z()],
            broken_by_layer: vec![vec![0, 0], vec![1, 5]],
            energy: vec![
                EnergyReport { axial: 1.0, ..Default::default() },
                EnergyReport { plastic_dissipated: 2.0, ..Default::default() },
            ],
            broken_tension: vec![0, 1],
            broken_shear: vec![0, 2],
            broken_combined: vec![0, 3],
            back_face_largest: vec![0.0, 2.5e-3],
            back_face_at_axis: vec![0.0, f64::NAN],
        };
        write_results(&path, "{\"name\":\"t\"}", &histories).unwrap();
        let read = read_histories(&path).unwrap();
        // NaN is not equal to itself: compare the bits of that one history
        let bits = |h: &Histories| h.back_face_at_axis.iter().map(|d| d.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&read), bits(&histories));
        assert_eq!(
            Histories { back_face_at_axis: Vec::new(), ..read },
            Histories { back_face_at_axis: Vec::new(), ..histories.clone() }
        );
        // the CSV holds the same numbers, to the bit, under named columns with units
        let csv_path = dir.join("history.csv");
        write_histories_csv(&csv_path, &histories).unwrap();
        let csv = std::fs::read_to_string(&csv_path).unwrap();
        let mut lines = csv.lines();
        let header: Vec<&str> = lines.next().unwrap().split(',').collect();
        assert_eq!(header.len(), 1 + 12 + 11 + 3 + 2 + 2);
        assert!(
            header.contains(&"projectile_velocity_x_m_s")
                && header.contains(&"energy_axial_J")
                && header.contains(&"broken_layer_1")
        );
        for (s, line) in lines.enumerate() {
            let row: Vec<f64> = line.split(',').map(|v| v.parse().unwrap()).collect();
            let column = |name: &str| row[header.iter().position(|h| *h == name).unwrap()];
            assert_eq!(column("time_s").to_bits(), histories.time[s].to_bits());
            assert_eq!(
                column("projectile_angular_velocity_x_rad_s").to_bits(),
                histories.projectile_angular_velocity[s].x.to_bits()
            );
            assert_eq!(
                column("energy_plastic_dissipated_J").to_bits(),
                histories.energy[s].plastic_dissipated.to_bits()
            );
            assert_eq!(column("broken_layer_1") as u64, histories.broken_by_layer[s][1]);
            assert_eq!(column("back_face_largest_m").to_bits(), histories.back_face_largest[s].to_bits());
            assert_eq!(column("back_face_at_axis_m").to_bits(), histories.back_face_at_axis[s].to_bits());
        }
        // a copy compares equal; one changed bit does not
        let other = dir.join("other.h5");
        write_results(&other, "{\"name\":\"t\"}", &histories).unwrap();
        assert_eq!(compare_results(&path, &other).unwrap(), Vec::<String>::new());
        let mut changed = histories.clone();
        changed.projectile_position[1].y = f64::from_bits(changed.projectile_position[1].y.to_bits() + 1);
        write_results(&other, "{\"name\":\"t\"}", &changed).unwrap();
        assert_eq!(
            compare_results(&path, &other).unwrap(),
            vec!["history/projectile_position: 1 of 6 values differ, first at flat index 4".to_string()]
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
