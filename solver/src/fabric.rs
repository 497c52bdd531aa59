//! `dea-mpi fabric`: generate and relax a woven target's unit cell, build the panel the way a
//! run does (each rank only its own yarn segments plus ghosts), and report the fabric: the
//! relaxed cell (`cell.h5`, with `cell.xdmf` for ParaView; a hybrid panel's coarse cell in
//! `coarse_cell.h5` and `coarse_cell.xdmf`) and its statistics with the
//! panel's size, node counts and memory per node (`fabric.json`).

use std::path::Path;
use std::time::Instant;

use dea_core::Rank;
use dea_fabric::panel::Tiling;
use dea_fabric::panel::TransitionQuality;
use dea_fabric::relax::RelaxReport;
use dea_fabric::Fabric;
use dea_io::case::Case;
use dea_partition::Method;
use serde::Serialize;

use crate::comm::Comm;
use crate::setup::{self, SetupError};

/// Style 706's areal density (DuPont data sheet, as quoted in PHYSICS.md §6) [kg/m^2].
pub const STYLE_706_AREAL_DENSITY: f64 = 0.180;

/// The panel a woven case builds.
#[derive(Clone, Debug, Serialize)]
pub struct PanelStatistics {
    /// unit cells along each side of a layer
    pub cells_per_side: u32,
    /// [m]
    pub side_m: f64,
    /// stacked layers
    pub layers: u32,
    /// distance between the node centres of neighbouring layers [m]
    pub layer_pitch_m: f64,
    /// from the top of the first layer to the bottom of the last, fibre surfaces included [m]
    pub thickness_m: f64,
    /// yarns of the whole panel
    pub yarns: usize,
    /// digital fibres of the whole panel
    pub fibres: usize,
    /// nodes of the whole panel
    pub nodes: u64,
    /// nodes of the fine yarns (all of them unless hybrid)
    pub fine_nodes: u64,
    /// yarns of the fine kind in one layer, each way (all of them unless hybrid)
    pub fine_yarns_per_layer: usize,
    /// deepest fibre contact as built over its contact distance: the relaxed cells', and
    /// where a hybrid panel's fine and coarse yarns cross [-]
    pub largest_overlap_ratio: f64,
    /// how much farther apart the fine region's layers start than fine tiles alone would
    /// stack (a hybrid panel whose coarse yarns are thicker; docs/theory.md F8) [m]
    pub fine_layer_gap_m: f64,
    /// ties where the yarns of a fine disc end at coarse fibres (docs/theory.md F12)
    pub ties: usize,
    /// how far those transitions are from passing the force straight on
    pub transitions: TransitionQuality,
    /// one layer [kg/m^2]
    pub areal_density_kg_m2: f64,
    /// every layer [kg]
    pub mass_kg: f64,
}

/// One rank's share of the panel.
#[derive(Clone, Debug, Serialize)]
pub struct RankShare {
    /// the rank
    pub rank: u32,
    /// nodes it owns
    pub owned_nodes: u64,
    /// ghost nodes it holds
    pub ghost_nodes: u64,
    /// generating the rank's nodes, fetching its ghosts and building its contact lists [s]
    pub build_s: f64,
    /// growth of the resident set over the build, per owned node [bytes]
    pub bytes_per_node: f64,
}

/// What `dea-mpi fabric` reports.
#[derive(Clone, Debug, Serialize)]
pub struct FabricReport {
    /// the case's name
    pub case: String,
    /// the relaxation (none when the cell came from a file)
    pub relaxation: Option<RelaxReport>,
    /// relaxing the cell on each rank [s]
    pub relaxation_s: f64,
    /// the cell as the panel uses it
    pub cell: dea_fabric::weave::CellStatistics,
    /// digital fibres per yarn of that cell (a hybrid panel's fine yarns)
    pub cell_fibres_per_yarn: usize,
    /// a hybrid panel's coarse cell: its relaxation and statistics
    #[serde(skip_serializing_if = "Option::is_none")]
    pub coarse_relaxation: Option<RelaxReport>,
    #[serde(skip_serializing_if = "Option::is_none")]
    /// (its statistics)
    pub coarse_cell: Option<dea_fabric::weave::CellStatistics>,
    /// the panel as built
    pub panel: PanelStatistics,
    /// each rank's share
    pub ranks: Vec<RankShare>,
    /// (areal density of a layer / 180 g/m^2) - 1, for the style 706 preset
    pub style_706_areal_density_deviation: f64,
}

/// What `dea-mpi fabric` reports for a 3-D weave's cell (`fabric.json`).
#[derive(Clone, Debug, Serialize)]
pub struct CellReport {
    /// the case's name
    pub case: String,
    /// how the relaxation went
    pub relaxation: RelaxReport,
    /// generating and relaxing the cell [s]
    pub relaxation_s: f64,
    /// the relaxed cell's micro-geometry
    pub cell: dea_fabric::cell::CellStatistics,
    /// relaxed thickness / initial thickness - 1 [-]
    pub thickness_change: f64,
    /// mean crimp of the filler, stuffer and binder fibres after relaxation [-]
    pub crimp_by_role: std::collections::BTreeMap<String, f64>,
    /// size of the cell along x and y [m]
    pub period_m: [f64; 2],
    /// each yarn's direction and role
    pub yarns: Vec<dea_fabric::cell::CellYarn>,
    /// digital fibres of the cell
    pub fibres: usize,
    /// nodes of the cell
    pub nodes: usize,
}

/// `dea-mpi fabric` on a `three_d_weave_cell` target: rank 0 generates and relaxes the cell
/// and writes `cell.h5`, `cell.xdmf` and `fabric.json` to `out`; the other ranks wait.
pub fn fabric_cell<C: Comm>(case: &Case, comm: C, out: &Path) -> Result<Option<CellReport>, SetupError> {
    let outcome = if comm.rank() == Rank(0) { Some(write_relaxed_cell(case, out)) } else { None };
    // every rank leaves with the same verdict
    let mut failed = [if outcome.as_ref().is_some_and(Result::is_err) { 1.0 } else { 0.0 }];
    comm.max_f64(&mut failed);
    match outcome {
        Some(result) => result.map(Some),
        None if failed[0] > 0.0 => Err(SetupError::Case("rank 0 could not build the cell (it says why)".into())),
        None => Ok(None),
    }
}

fn write_relaxed_cell(case: &Case, out: &Path) -> Result<CellReport, SetupError> {
    let resolved = case.resolve().map_err(|e| SetupError::Case(e.to_string()))?;
    let material = resolved.material.clone();
    let started = Instant::now();
    let Some((cell, relaxation)) = setup::three_d_cell(&resolved)? else {
        return Err(SetupError::Case(
            "target.kind: `dea-mpi fabric` relaxes a 3-D weave cell; this target has none".into(),
        ));
    };
    let relaxation = relaxation.ok_or_else(|| {
        SetupError::Case(
            "target.cell_file: the cell is already relaxed; `dea-mpi fabric` generates one from target.weave".into(),
        )
    })?;
    let relaxation_s = started.elapsed().as_secs_f64();
    let roles = [
        ("filler", dea_fabric::cell::YarnRole::Filler),
        ("stuffer", dea_fabric::cell::YarnRole::Stuffer),
        ("binder", dea_fabric::cell::YarnRole::Binder),
    ];
    let report = CellReport {
        case: case.name.clone(),
        thickness_change: relaxation.after.thickness_m / relaxation.before.thickness_m - 1.0,
        relaxation,
        relaxation_s,
        cell: cell.statistics(&material),
        crimp_by_role: roles
            .iter()
            .filter_map(|(name, role)| Some((name.to_string(), cell.crimp_of(*role)?)))
            .collect(),
        period_m: cell.period,
        yarns: cell.yarns.clone(),
        fibres: cell.fibres(),
        nodes: cell.positions.len(),
    };
    let failed = |e: &dyn std::fmt::Display| SetupError::Mesh(format!("{}: {e}", out.display()));
    std::fs::create_dir_all(out).map_err(|e| failed(&e))?;
    let relaxation_json = serde_json::to_string(&report.relaxation).expect("report serialises");
    let cell_json = serde_json::to_string(&report.cell).expect("statistics serialise");
    dea_io::cell::write_periodic_cell(&out.join("cell.h5"), &cell, &relaxation_json, &cell_json)
        .map_err(|e| failed(&e))?;
    dea_io::cell::write_cell_xdmf(out, "cell", &cell).map_err(|e| failed(&e))?;
    std::fs::write(out.join("fabric.json"), serde_json::to_string_pretty(&report).expect("report serialises"))
        .map_err(|e| failed(&e))?;
    Ok(report)
}

/// What one rank of a large job would hold, built alone ([`fabric_share`]).
#[derive(Clone, Debug, Serialize)]
pub struct ShareReport {
    /// the case's name
    pub case: String,
    /// the rank built, of `ranks`
    pub rank: u32,
    /// (the job's rank count)
    pub ranks: usize,
    /// nodes of the whole panel, and of its fine yarns
    pub panel_nodes: u64,
    /// (of its fine yarns)
    pub fine_nodes: u64,
    /// ties where a hybrid's fine disc ends at coarse fibres
    pub ties: usize,
    /// relaxing the cells [s]
    pub relaxation_s: f64,
    /// building the segment graph and partitioning it (rank 0's work in a job) [s]
    pub partition_s: f64,
    /// of which building the segment graph [s]
    pub segment_graph_s: f64,
    /// the partition's predicted quality: every rank's owned and ghost nodes, halo bytes
    pub partition: dea_partition::QualityReport,
    /// nodes the rank generated (its own, no ghosts) and contact-list entries among them
    pub owned_nodes: u64,
    /// (the contact-list entries among them)
    pub contact_entries: u64,
    /// generating the rank's nodes and building their contact lists [s]
    pub build_s: f64,
    /// growth of the resident set over that build, per owned node [bytes]
    pub bytes_per_node: f64,
    /// peak resident set of this process [bytes]
    pub peak_resident_bytes: f64,
}

/// Builds only rank `rank`'s part of an `ranks`-rank partition of a woven case, in this one
/// process: what a rank of a job too large for this machine would generate and hold (its
/// own nodes and their contact lists; its ghosts are predicted by the partition's report).
/// Writes `out/share.json`.
pub fn fabric_share(
    case: &Case,
    method: Method,
    rank: Rank,
    ranks: usize,
    out: &Path,
) -> Result<ShareReport, SetupError> {
    woven_target(case, "`dea-mpi fabric --share`")?;
    let started = Instant::now();
    let problem = setup::problem(case)?;
    let relaxation_s = started.elapsed().as_secs_f64();
    // this process holds one rank's share
    setup::shares_fit(problem.fabric.node_count(), ranks, 1, setup::memory_limit())?;
    let Fabric::Woven(panel) = &problem.fabric else { unreachable!("a woven target builds a woven panel") };
    let started = Instant::now();
    let graph = setup::segment_graph(&problem, ranks, None);
    let segment_graph_s = started.elapsed().as_secs_f64();
    let partition =
        dea_partition::partition(&graph, ranks, method).map_err(|e| SetupError::Partition(e.to_string()))?;
    let quality = dea_partition::quality(&graph, &partition);
    let partition_s = started.elapsed().as_secs_f64();
    // this process holds this rank's share of the partition, owned and ghost nodes
    let mine = &quality.ranks[rank.0 as usize];
    setup::largest_share_fits(mine.owned_nodes + mine.ghost_nodes, ranks, 1, setup::memory_limit())?;
    drop(graph);
    // hand the graph's and METIS's freed pages back, so the resident set grows by what the
    // rank's own part takes rather than refilling them
    // SAFETY: malloc_trim only releases free heap memory; it touches no live allocation
    unsafe { libc::malloc_trim(0) };
    let (resident, started) = (resident_bytes(), Instant::now());
    let mut domain = setup::own_domain(&problem, &partition, rank, |_| {});
    domain.pairs.rebuild(&domain.nodes, &domain.sections);
    let build_s = started.elapsed().as_secs_f64();
    let owned = domain.nodes.n_owned as u64;
    let report = ShareReport {
        case: case.name.clone(),
        rank: rank.0,
        ranks,
        panel_nodes: panel.node_count(),
        fine_nodes: panel.fine_node_count(),
        ties: panel.ties().len(),
        relaxation_s,
        partition_s,
        segment_graph_s,
        partition: quality,
        owned_nodes: owned,
        contact_entries: domain.pairs.partner.len() as u64,
        build_s,
        bytes_per_node: (resident_bytes() - resident) / (owned as f64).max(1.0),
        peak_resident_bytes: peak_resident_bytes(),
    };
    let failed = |e: &dyn std::fmt::Display| SetupError::Mesh(format!("{}: {e}", out.display()));
    std::fs::create_dir_all(out).map_err(|e| failed(&e))?;
    std::fs::write(out.join("share.json"), serde_json::to_string_pretty(&report).expect("report serialises"))
        .map_err(|e| failed(&e))?;
    Ok(report)
}

/// Peak resident set size of this process [bytes] (0 where /proc is not there).
fn peak_resident_bytes() -> f64 {
    status_kilobytes("VmHWM:") * 1024.0
}

/// Resident set size of this process [bytes] (0 where /proc is not there).
fn resident_bytes() -> f64 {
    status_kilobytes("VmRSS:") * 1024.0
}

/// A field of /proc/self/status in kB (0 where /proc is not there).
fn status_kilobytes(field: &str) -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|text| {
            text.lines().find(|l| l.starts_with(field)).and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
        })
        .unwrap_or(0.0)
}

/// Refuses a case whose target is not a woven panel, which `command` needs.
fn woven_target(case: &Case, command: &str) -> Result<(), SetupError> {
    match case.target {
        dea_io::case::TargetSpec::WovenPanel { .. } => Ok(()),
        _ => Err(SetupError::Case(format!("target.kind: {command} needs a woven_panel target"))),
    }
}

/// Runs the command on the ranks of `comm`; rank 0 writes `out` and returns the report.
pub fn fabric<C: Comm>(case: &Case, comm: C, method: Method, out: &Path) -> Result<Option<FabricReport>, SetupError> {
    woven_target(case, "`dea-mpi fabric`")?;
    let started = Instant::now();
    let problem = setup::shared_problem(&comm, case)?;
    let relaxation_s = started.elapsed().as_secs_f64();
    let Fabric::Woven(panel) = problem.fabric.clone() else { unreachable!("a woven target builds a woven panel") };
    let (material, relaxation, coarse_relaxation) =
        (problem.material.clone(), problem.relaxation.clone(), problem.coarse_relaxation.clone());
    let (resident, started) = (resident_bytes(), Instant::now());
    let run = setup::assemble(problem, comm, method, None, |_| {})?;
    let build_s = started.elapsed().as_secs_f64();
    let grown = resident_bytes() - resident;
    let (owned, ghosts) = (run.domain.nodes.n_owned as u64, run.ghosts() as u64);
    let comm = &run.comm;
    let ranks = comm.size();
    let mut counts = vec![0i64; 2 * ranks];
    let me = comm.rank().0 as usize;
    counts[2 * me] = owned as i64;
    counts[2 * me + 1] = ghosts as i64;
    comm.sum_i64(&mut counts);
    let timings = comm.gather_f64(&[build_s, grown]);
    if comm.rank() != Rank(0) {
        return Ok(None);
    }
    let timings = timings.expect("rank 0 gathers");
    let shares = (0..ranks)
        .map(|r| RankShare {
            rank: r as u32,
            owned_nodes: counts[2 * r] as u64,
            ghost_nodes: counts[2 * r + 1] as u64,
            build_s: timings[r][0],
            bytes_per_node: timings[r][1] / (counts[2 * r] as f64).max(1.0),
        })
        .collect();
    let cell = &panel.cell;
    let areal_density = panel.areal_density(&material);
    let statistics = PanelStatistics {
        cells_per_side: panel.cells,
        side_m: panel.side(),
        layers: panel.layers,
        layer_pitch_m: panel.layer_pitch,
        thickness_m: panel.top() - panel.bottom() + panel.sections().iter().map(|s| s.diameter).fold(0.0, f64::max),
        yarns: panel.yarn_count(),
        fibres: *panel.first_fibres().last().expect("a total") as usize,
        nodes: panel.node_count(),
        fine_nodes: panel.fine_node_count(),
        fine_yarns_per_layer: panel.fine_yarns_per_layer(),
        ties: panel.ties().len(),
        transitions: panel.transition_quality(),
        largest_overlap_ratio: panel.largest_overlap_ratio(),
        fine_layer_gap_m: panel.fine_layer_gap(),
        areal_density_kg_m2: areal_density,
        mass_kg: areal_density * panel.side() * panel.side() * panel.layers as f64,
    };
    let report = FabricReport {
        case: case.name.clone(),
        relaxation,
        relaxation_s,
        cell: cell.statistics(&material),
        cell_fibres_per_yarn: cell.fibres_per_yarn,
        coarse_relaxation,
        coarse_cell: panel.coarse.as_ref().map(|c| c.cell.statistics(&material)),
        panel: statistics,
        ranks: shares,
        style_706_areal_density_deviation: areal_density / STYLE_706_AREAL_DENSITY - 1.0,
    };
    let failed = |e: &dyn std::fmt::Display| SetupError::Mesh(format!("{}: {e}", out.display()));
    std::fs::create_dir_all(out).map_err(|e| failed(&e))?;
    let report_json = serde_json::to_string_pretty(&report).expect("report serialises");
    // the cell file holds nothing that depends on the ranks or the clock
    let cells = [("cell", cell, &report.relaxation, Some(report.cell))]
        .into_iter()
        .chain(panel.coarse.as_ref().map(|c| ("coarse_cell", &c.cell, &report.coarse_relaxation, report.coarse_cell)));
    for (name, cell, relaxation, statistics) in cells {
        let relaxation_json = serde_json::to_string(relaxation).expect("report serialises");
        let cell_json = serde_json::to_string(&statistics).expect("statistics serialise");
        dea_io::cell::write_cell(&out.join(format!("{name}.h5")), cell, &relaxation_json, &cell_json)
            .map_err(|e| failed(&e))?;
        dea_io::cell::write_cell_xdmf(out, name, cell).map_err(|e| failed(&e))?;
    }
    std::fs::write(out.join("fabric.json"), &report_json).map_err(|e| failed(&e))?;
    Ok(Some(report))
}
