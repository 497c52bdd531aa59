//! The relaxed unit cell on disk (`dea-mpi fabric` writes it; a case reuses it through
//! `target.cell_file`): `cell.h5` holds everything the panel needs to tile it, the relaxation
//! report and the fabric's statistics; `cell.xdmf` lets ParaView draw its fibres.

use std::path::Path;

use dea_core::{FibreSection, Vec3};
use dea_fabric::cell::{CellYarn, PeriodicCell, YarnDirection, YarnRole};
use dea_fabric::weave::UnitCell;

use crate::results::{write_scalars, write_text_attribute, write_vectors};

/// Format tag of a cell file.
pub const CELL_FORMAT: &str = "dea-mpi relaxed cell 3";

/// The section's values in the `section` dataset, in order, with their units.
const SECTION_FIELDS: &str = "diameter m, area m^2, element_length m, contact_diameter m, moment_of_inertia m^4, torsional_stiffness N m/rad, filaments_per_fibre -";

/// Writes a plain-weave cell (everything a panel needs to tile it) with its relaxation
/// report and statistics (JSON texts).
pub fn write_cell(path: &Path, cell: &UnitCell, report_json: &str, statistics_json: &str) -> hdf5::Result<()> {
    let file = write_periodic(path, cell, report_json, statistics_json)?;
    let group = file.group("/")?;
    let packing: Vec<f64> = cell.packing.iter().flatten().copied().collect();
    let dataset = group.new_dataset::<f64>().shape([cell.packing.len(), 2]).create("packing")?;
    dataset.write_raw(&packing)?;
    write_text_attribute(&dataset, "units", "m")?;
    write_scalars(&group, "yarn_spacing", &[cell.yarn_spacing], "m")?;
    write_scalars(&group, "initial_amplitude", &[cell.initial_amplitude], "m")?;
    file.flush()
}

/// Writes any periodic cell (a 3-D weave's) with its relaxation report and statistics.
pub fn write_periodic_cell(path: &Path, cell: &PeriodicCell, report_json: &str, statistics_json: &str) -> hdf5::Result<()> {
    write_periodic(path, cell, report_json, statistics_json)?.flush()
}

fn write_periodic(path: &Path, cell: &PeriodicCell, report_json: &str, statistics_json: &str) -> hdf5::Result<hdf5::File> {
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
    write_scalars(&group, "period", &cell.period, "m")?;
    write_scalars(&group, "fibre_tension", &[cell.fibre_tension], "N")?;
    let column = |f: fn(&CellYarn) -> u32| cell.yarns.iter().map(f).collect::<Vec<u32>>();
    write_scalars(&group, "yarn_direction", &column(|y| (y.direction == YarnDirection::Weft) as u32), "0 warp (x), 1 weft (y)")?;
    write_scalars(&group, "yarn_role", &column(|y| y.role.code()), "0 plain, 1 stuffer, 2 filler, 3 binder")?;
    write_scalars(&group, "yarn_fibres", &column(|y| y.fibres as u32), "-")?;
    write_scalars(&group, "yarn_nodes_per_period", &column(|y| y.nodes_per_period), "-")?;
    // for display: the segments inside the cell (the closing one crosses the periodic edge),
    // each node's fibre, direction and role
    let segments: Vec<u32> = (0..cell.fibres()).flat_map(|f| cell.fibre_nodes(f).skip(1).flat_map(|k| [k as u32 - 1, k as u32])).collect();
    let dataset = group.new_dataset::<u32>().shape([segments.len() / 2, 2]).create("segments")?;
    dataset.write_raw(&segments)?;
    let fibre: Vec<u32> = (0..cell.fibres()).flat_map(|f| cell.fibre_nodes(f).map(move |_| f as u32)).collect();
    write_scalars(&group, "fibre", &fibre, "-")?;
    let direction: Vec<u32> = fibre.iter().map(|&f| (cell.direction(f as usize) == YarnDirection::Weft) as u32).collect();
    write_scalars(&group, "direction", &direction, "0 warp, 1 weft")?;
    let role: Vec<u32> = fibre.iter().map(|&f| cell.yarns[cell.fibre_yarn(f as usize)].role.code()).collect();
    write_scalars(&group, "role", &role, "0 plain, 1 stuffer, 2 filler, 3 binder")?;
    Ok(file)
}

/// Reads a plain-weave cell file (for a panel); every error names the file and what is wrong.
pub fn read_cell(path: &Path) -> Result<UnitCell, String> {
    let name = path.display();
    let (file, periodic) = read_periodic(path)?;
    let wrap = |what: &str, e: hdf5::Error| format!("{name}: {what}: {e}");
    let plain = periodic.yarns.len() == 4 && periodic.yarns.iter().all(|y| y.role == YarnRole::Plain && y.fibres == periodic.yarns[0].fibres && y.nodes_per_period == periodic.yarns[0].nodes_per_period);
    if !plain || !file.link_exists("packing") {
        return Err(format!("{name}: not a plain-weave cell (a woven_panel tiles plain-weave cells only; a 3-D weave is struck as a three_d_woven_panel)"));
    }
    let scalar = |dataset: &str| -> Result<f64, String> {
        let values: Vec<f64> = file.dataset(dataset).and_then(|d| d.read_raw()).map_err(|e| wrap(dataset, e))?;
        values.first().copied().ok_or_else(|| format!("{name}: {dataset} is empty"))
    };
    let flat: Vec<f64> = file.dataset("packing").and_then(|d| d.read_raw()).map_err(|e| wrap("packing", e))?;
    let packing: Vec<[f64; 2]> = flat.chunks_exact(2).map(|c| [c[0], c[1]]).collect();
    let yarn_spacing = scalar("yarn_spacing")?;
    let (fibres_per_yarn, nodes_per_period) = (periodic.yarns[0].fibres, periodic.yarns[0].nodes_per_period);
    if packing.len() != fibres_per_yarn || nodes_per_period % 4 != 0 || periodic.period != [2.0 * yarn_spacing; 2] {
        return Err(format!("{name}: inconsistent plain weave ({} packing points for {fibres_per_yarn} fibres per yarn, {nodes_per_period} nodes per period, period {:?} for spacing {yarn_spacing:e} m)", packing.len(), periodic.period));
    }
    Ok(UnitCell { periodic, yarn_spacing, fibres_per_yarn, nodes_per_period, packing, initial_amplitude: scalar("initial_amplitude")? })
}

/// Reads any cell file: the open file and its periodic cell.
pub fn read_periodic(path: &Path) -> Result<(hdf5::File, PeriodicCell), String> {
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
    let floats = |dataset: &str| -> Result<Vec<f64>, String> { file.dataset(dataset).and_then(|d| d.read_raw()).map_err(|e| wrap(dataset, e)) };
    let counts = |dataset: &str| -> Result<Vec<u32>, String> { file.dataset(dataset).and_then(|d| d.read_raw()).map_err(|e| wrap(dataset, e)) };
    let [diameter, area, element_length, contact_diameter, moment_of_inertia, torsional_stiffness, filaments_per_fibre] =
        <[f64; 7]>::try_from(floats("section")?).map_err(|v| format!("{name}: section has {} values, not 7 ({SECTION_FIELDS})", v.len()))?;
    let section = FibreSection { diameter, area, element_length, contact_diameter, moment_of_inertia, torsional_stiffness, filaments_per_fibre };
    let positions: Vec<Vec3> = floats("position")?.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect();
    let period = <[f64; 2]>::try_from(floats("period")?).map_err(|v| format!("{name}: period has {} values, not 2", v.len()))?;
    let fibre_tension = *floats("fibre_tension")?.first().ok_or_else(|| format!("{name}: fibre_tension is empty"))?;
    let (directions, roles, fibres, nodes) = (counts("yarn_direction")?, counts("yarn_role")?, counts("yarn_fibres")?, counts("yarn_nodes_per_period")?);
    if [roles.len(), fibres.len(), nodes.len()].iter().any(|&n| n != directions.len()) {
        return Err(format!("{name}: the yarn tables have different lengths"));
    }
    let mut yarns = Vec::with_capacity(directions.len());
    for y in 0..directions.len() {
        let direction = match directions[y] {
            0 => YarnDirection::Warp,
            1 => YarnDirection::Weft,
            code => return Err(format!("{name}: yarn_direction[{y}] = {code} is neither 0 (warp) nor 1 (weft)")),
        };
        let role = YarnRole::from_code(roles[y]).ok_or_else(|| format!("{name}: yarn_role[{y}] = {} is not a role code", roles[y]))?;
        yarns.push(CellYarn { direction, role, fibres: fibres[y] as usize, nodes_per_period: nodes[y] });
    }
    let cell = PeriodicCell::new(period, yarns, section, positions, floats("rest_length")?, floats("rest_angle")?, fibre_tension).map_err(|e| format!("{name}: {e}"))?;
    Ok((file, cell))
}

/// Writes `NAME.xdmf` beside the cell file `NAME.h5` in `directory` (`name` is "cell", or
/// "coarse_cell" for a hybrid panel's coarse yarns).
pub fn write_cell_xdmf(directory: &Path, name: &str, cell: &PeriodicCell) -> std::io::Result<()> {
    let (nodes, segments) = (cell.positions.len(), cell.positions.len() - cell.fibres());
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
      <Attribute Name="role" AttributeType="Scalar" Center="Node">
        <DataItem Dimensions="{nodes}" NumberType="UInt" Precision="4" Format="HDF">{name}.h5:/role</DataItem>
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
