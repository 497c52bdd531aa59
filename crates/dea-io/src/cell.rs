//! The relaxed unit cell on disk (`dea-mpi fabric` writes it; a case reuses it through
//! `target.cell_file`): `cell.h5` holds everything the panel needs to tile it, the relaxation
//! report and the fabric's statistics; `cell.xdmf` lets ParaView draw its fibres.

use std::path::Path;

use dea_core::{FibreSection, Vec3};
use dea_fabric::weave::UnitCell;

use crate::results::{write_scalars, write_text_attribute, write_vectors};

/// Format tag of a cell file.
pub const CELL_FORMAT: &str = "dea-mpi relaxed cell 2";

/// The section's values in the `section` dataset, in order, with their units.
const SECTION_FIELDS: &str = "diameter m, area m^2, element_length m, contact_diameter m, moment_of_inertia m^4, torsional_stiffness N m/rad, filaments_per_fibre -";

/// Writes the relaxed cell with its relaxation report and statistics (JSON texts).
pub fn write_cell(path: &Path, cell: &UnitCell, report_json: &str, statistics_json: &str) -> hdf5::Result<()> {
    let file = hdf5::File::create(path)?;
    write_text_attribute(&file, "format", CELL_FORMAT)?;
    write_text_attribute(&file, "relaxation", report_json)?;
    write_text_attribute(&file, "statistics", statistics_json)?;
    let group = file.group("/")?;
    write_vectors(&group, "position", &cell.positions, "m")?;
    let section = &cell.section;
    let values = [section.diameter, section.area, section.element_length, section.contact_diameter, section.moment_of_inertia, section.torsional_stiffness, section.filaments_per_fibre];
    write_scalars(&group, "section", &values, SECTION_FIELDS)?;
    write_scalars(&group, "rest_length", &cell.rest_lengths, "m")?;
    write_scalars(&group, "rest_angle", &cell.rest_angles, "rad")?;
    let packing: Vec<f64> = cell.packing.iter().flatten().copied().collect();
    let dataset = group.new_dataset::<f64>().shape([cell.packing.len(), 2]).create("packing")?;
    dataset.write_raw(&packing)?;
    write_text_attribute(&dataset, "units", "m")?;
    write_scalars(&group, "yarn_spacing", &[cell.yarn_spacing], "m")?;
    write_scalars(&group, "fibres_per_yarn", &[cell.fibres_per_yarn as u64], "-")?;
    write_scalars(&group, "nodes_per_period", &[cell.nodes_per_period], "-")?;
    write_scalars(&group, "fibre_tension", &[cell.fibre_tension], "N")?;
    write_scalars(&group, "initial_amplitude", &[cell.initial_amplitude], "m")?;
    // for display: the segments inside the cell (the closing one crosses the periodic edge),
    // each node's fibre and direction
    let n = cell.nodes_per_period;
    let segments: Vec<u32> = (0..cell.fibres() as u32).flat_map(|f| (0..n - 1).flat_map(move |k| [f * n + k, f * n + k + 1])).collect();
    let dataset = group.new_dataset::<u32>().shape([segments.len() / 2, 2]).create("segments")?;
    dataset.write_raw(&segments)?;
    let fibre: Vec<u32> = (0..cell.positions.len() as u32).map(|i| i / n).collect();
    write_scalars(&group, "fibre", &fibre, "-")?;
    let direction: Vec<u32> = fibre.iter().map(|&f| (cell.direction(f as usize) == dea_fabric::weave::YarnDirection::Weft) as u32).collect();
    write_scalars(&group, "direction", &direction, "0 warp, 1 weft")?;
    file.flush()
}

/// Reads a cell file; every error names the file and what is wrong.
pub fn read_cell(path: &Path) -> Result<UnitCell, String> {
    let name = path.display();
    let wrap = |what: &str, e: hdf5::Error| format!("{name}: {what}: {e}");
    let file = hdf5::File::open(path).map_err(|e| wrap("cannot open as HDF5", e))?;
    let text = |attribute: &str| -> Result<String, String> {
        let value: hdf5::types::VarLenUnicode = file.attr(attribute).and_then(|a| a.read_scalar()).map_err(|e| wrap(&format!("attribute {attribute}"), e))?;
        Ok(value.as_str().to_string())
    };
    let format = text("format")?;
    if format != CELL_FORMAT {
        return Err(format!("{name}: format {format:?} is not {CELL_FORMAT:?}"));
    }
    let values: Vec<f64> = file.dataset("section").and_then(|d| d.read_raw()).map_err(|e| wrap("section", e))?;
    let [diameter, area, element_length, contact_diameter, moment_of_inertia, torsional_stiffness, filaments_per_fibre] =
        <[f64; 7]>::try_from(values).map_err(|v| format!("{name}: section has {} values, not 7 ({SECTION_FIELDS})", v.len()))?;
    let section = FibreSection { diameter, area, element_length, contact_diameter, moment_of_inertia, torsional_stiffness, filaments_per_fibre };
    let scalar = |dataset: &str| -> Result<f64, String> {
        let values: Vec<f64> = file.dataset(dataset).and_then(|d| d.read_raw()).map_err(|e| wrap(dataset, e))?;
        values.first().copied().ok_or_else(|| format!("{name}: {dataset} is empty"))
    };
    let count = |dataset: &str| -> Result<u64, String> {
        let values: Vec<u64> = file.dataset(dataset).and_then(|d| d.read_raw()).map_err(|e| wrap(dataset, e))?;
        values.first().copied().ok_or_else(|| format!("{name}: {dataset} is empty"))
    };
    let flat: Vec<f64> = file.dataset("position").and_then(|d| d.read_raw()).map_err(|e| wrap("position", e))?;
    let positions: Vec<Vec3> = flat.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect();
    let rest_lengths: Vec<f64> = file.dataset("rest_length").and_then(|d| d.read_raw()).map_err(|e| wrap("rest_length", e))?;
    let rest_angles: Vec<f64> = file.dataset("rest_angle").and_then(|d| d.read_raw()).map_err(|e| wrap("rest_angle", e))?;
    let flat: Vec<f64> = file.dataset("packing").and_then(|d| d.read_raw()).map_err(|e| wrap("packing", e))?;
    let packing: Vec<[f64; 2]> = flat.chunks_exact(2).map(|c| [c[0], c[1]]).collect();
    let fibres_per_yarn = count("fibres_per_yarn")? as usize;
    let nodes_per_period: Vec<u32> = file.dataset("nodes_per_period").and_then(|d| d.read_raw()).map_err(|e| wrap("nodes_per_period", e))?;
    let nodes_per_period = nodes_per_period.first().copied().ok_or_else(|| format!("{name}: nodes_per_period is empty"))?;
    let cell = UnitCell {
        yarn_spacing: scalar("yarn_spacing")?,
        fibres_per_yarn,
        nodes_per_period,
        section,
        positions,
        rest_lengths,
        rest_angles,
        fibre_tension: scalar("fibre_tension")?,
        packing,
        initial_amplitude: scalar("initial_amplitude")?,
    };
    let fibres = 4 * fibres_per_yarn;
    if fibres_per_yarn == 0 || nodes_per_period < 4 || cell.positions.len() != fibres * nodes_per_period as usize || cell.rest_angles.len() != cell.positions.len() || cell.rest_lengths.len() != fibres || cell.packing.len() != fibres_per_yarn {
        return Err(format!("{name}: inconsistent sizes ({} positions, {} rest lengths, {} packing points for {fibres_per_yarn} fibres per yarn and {nodes_per_period} nodes per period)", cell.positions.len(), cell.rest_lengths.len(), cell.packing.len()));
    }
    Ok(cell)
}

/// Writes `NAME.xdmf` beside the cell file `NAME.h5` in `directory` (`name` is "cell", or
/// "coarse_cell" for a hybrid panel's coarse yarns).
pub fn write_cell_xdmf(directory: &Path, name: &str, cell: &UnitCell) -> std::io::Result<()> {
    let (nodes, segments) = (cell.positions.len(), cell.fibres() * (cell.nodes_per_period as usize - 1));
    let text = format!(
        r#"<?xml version="1.0" ?>
<!DOCTYPE Xdmf SYSTEM "Xdmf.dtd" []>
<Xdmf Version="2.0">
  <Domain>
    <Grid Name="relaxed-cell" GridType="Uniform">
      <Topology TopologyType="Polyline" NodesPerElement="2" NumberOfElements="{segments}">
        <DataItem Dimensions="{segments} 2" NumberType="UInt" Precision="4" Format="HDF">{name}.h5:/segments</DataItem>
      </Topology>
      <Geometry GeometryType="XYZ">
        <DataItem Dimensions="{nodes} 3" NumberType="Float" Precision="8" Format="HDF">{name}.h5:/position</DataItem>
      </Geometry>
      <Attribute Name="fibre" AttributeType="Scalar" Center="Node">
        <DataItem Dimensions="{nodes}" NumberType="UInt" Precision="4" Format="HDF">{name}.h5:/fibre</DataItem>
      </Attribute>
      <Attribute Name="direction" AttributeType="Scalar" Center="Node">
        <DataItem Dimensions="{nodes}" NumberType="UInt" Precision="4" Format="HDF">{name}.h5:/direction</DataItem>
      </Attribute>
    </Grid>
  </Domain>
</Xdmf>
"#
    );
    std::fs::write(directory.join(format!("{name}.xdmf")), text)
}

#[cfg(test)]
mod tests {
    use super::*;
    use dea_core::FibreMaterial;
    use dea_fabric::weave::PlainWeave;

    #[test]
    fn a_cell_reads_back_bit_for_bit() {
        let cell = PlainWeave::km2_style_706(4).unit_cell(&FibreMaterial::kevlar_km2()).unwrap();
        let directory = std::env::temp_dir().join(format!("dea-cell-{}", std::process::id()));
        std::fs::create_dir_all(&directory).unwrap();
        let path = directory.join("cell.h5");
        write_cell(&path, &cell, "{}", "{}").unwrap();
        assert!(read_cell(&path).unwrap() == cell, "the cell read back differs");
        std::fs::write(&path, b"not hdf5").unwrap();
        let error = read_cell(&path).unwrap_err();
        assert!(error.contains("cell.h5") && error.contains("cannot open"), "{error}");
        std::fs::remove_dir_all(&directory).unwrap();
    }
}
