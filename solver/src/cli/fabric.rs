//! `dea-mpi fabric`: relax a woven case's cell, build its panel and report the fabric.

use std::path::PathBuf;
use std::process::ExitCode;

use dea_core::Rank;
use dea_mpi::comm::mpi::MpiComm;

use super::{fail, fail_all, load, load_shared, method_of, setup_exit, Exit, PartitionMethod};

pub const ABOUT: &str = "Relax a woven case's unit cell, build its panel and report the fabric";
pub const LONG_ABOUT: &str = "Generate and relax a woven case's unit cell, build its panel over the job's ranks (each
rank only its own part) and report the fabric: OUT/cell.h5 (reusable as target.cell_file), OUT/cell.xdmf (ParaView)
and OUT/fabric.json. With --share, build in this one process only one rank's part of a larger job.";
pub const EXAMPLES: &str = "Examples:\n  dea-mpi fabric\n  mpirun -np 4 dea-mpi fabric cases/km2_706_patch.json --out out/fabric\n  dea-mpi fabric cases/km2_706_28_layer_disc.json --share 0/64   # one rank's part of a 64-rank job";

#[derive(clap::Args)]
pub struct Args {
    /// case file with a woven_panel target; none: the built-in default case
    pub case: Option<PathBuf>,
    /// output directory
    #[arg(long, default_value = "out/fabric")]
    pub out: PathBuf,
    /// METIS algorithm for the partition over the job's ranks
    #[arg(long, value_enum, default_value_t = PartitionMethod::Kway)]
    pub method: PartitionMethod,
    /// build, in this one process, only what rank RANK of a RANKS-rank job would (its
    /// own nodes and their contact lists) and report it in OUT/share.json: a panel too
    /// large for this machine, one rank's share at a time
    #[arg(long, value_name = "RANK/RANKS", value_parser = parse_share)]
    pub share: Option<(u32, usize)>,
}

/// `RANK/RANKS` of `--share`, RANK below RANKS.
fn parse_share(text: &str) -> Result<(u32, usize), String> {
    let (rank, ranks) = text.split_once('/').ok_or_else(|| format!("expected RANK/RANKS, e.g. 0/64, got {text:?}"))?;
    let rank: u32 = rank.trim().parse().map_err(|e| format!("RANK {rank:?}: {e}"))?;
    let ranks: usize = ranks.trim().parse().map_err(|e| format!("RANKS {ranks:?}: {e}"))?;
    if ranks == 0 || rank as usize >= ranks {
        return Err(format!("RANK must be below RANKS (at least 1), got {rank}/{ranks}"));
    }
    Ok((rank, ranks))
}

/// One line on a cell's relaxation, which took `seconds` [s].
fn print_relaxation(r: &dea_fabric::relax::RelaxReport, seconds: f64) {
    println!(
        "relaxed in {} iterations ({seconds:.2} s): largest nodal force {:.3e} -> {:.3e} N, {} contacts, deepest {:.1} % of a contact diameter",
        r.iterations, r.initial_residual_n, r.final_residual_n, r.contacts, 100.0 * r.largest_overlap_ratio
    );
}

pub fn main(Args { case, out, method, share }: Args) -> ExitCode {
    match share {
        Some((rank, ranks)) => one_share(case, out, method, rank, ranks),
        None => whole(case, out, method),
    }
}

/// What rank `rank` of a `ranks`-rank job would build, in this process.
fn one_share(case: Option<PathBuf>, out: PathBuf, method: PartitionMethod, rank: u32, ranks: usize) -> ExitCode {
    let case = match load(case.as_ref()) {
        Ok(case) => case,
        Err((code, message)) => return fail(code, message),
    };
    match dea_mpi::fabric::fabric_share(&case, method_of(method), Rank(rank), ranks, &out) {
        Ok(r) => {
            let me = &r.partition.ranks[rank as usize];
            println!(
                "{}: {} nodes ({} fine, {} ties); rank {} of {} owns {} (predicted ghosts {}, halo {} bytes/step); partitioned in {:.1} s (imbalance {:.3} in work, {:.3} in stored nodes; the largest rank stores {} nodes, about {:.2} GB); built its nodes and {} contact entries in {:.1} s, {:.0} bytes per node, peak resident set {:.2} GB; results in {}",
                r.case, r.panel_nodes, r.fine_nodes, r.ties, r.rank, r.ranks, r.owned_nodes, me.ghost_nodes, me.halo_bytes_per_step, r.partition_s, r.partition.load_imbalance, r.partition.memory_imbalance,
                r.partition.largest_stored_nodes, r.partition.largest_stored_nodes as f64 * dea_mpi::setup::BYTES_PER_NODE / 1e9,
                r.contact_entries, r.build_s, r.bytes_per_node, 1e-9 * r.peak_resident_bytes, out.display()
            );
            ExitCode::SUCCESS
        }
        Err(e) => fail(setup_exit(&e), e),
    }
}

/// The whole panel over the job's ranks.
fn whole(case: Option<PathBuf>, out: PathBuf, method: PartitionMethod) -> ExitCode {
    let (session, comm) = match MpiComm::initialize() {
        Ok(mpi) => mpi,
        Err(e) => return fail(Exit::Usage, e),
    };
    let case = match load_shared(&comm, case.as_ref()) {
        Ok(case) => case,
        Err((code, message)) => return fail_all(&session, code, message),
    };
    if matches!(
        case.target,
        dea_io::case::TargetSpec::ThreeDWeaveCell { .. } | dea_io::case::TargetSpec::ThreeDWovenPanel { .. }
    ) {
        return match dea_mpi::fabric::fabric_cell(&case, comm, &out) {
            Ok(Some(report)) => {
                let (r, c) = (&report.relaxation, &report.cell);
                print_relaxation(r, report.relaxation_s);
                let crimps: Vec<String> =
                    report.crimp_by_role.iter().map(|(role, crimp)| format!("{role} {:.2} %", 100.0 * crimp)).collect();
                println!(
                    "cell: {:.2} x {:.2} mm, {} yarns, {} fibres, {} nodes; thickness {:.1} -> {:.1} um ({:+.1} %), crimp {}, fibre volume fraction {:.3}, {:.1} g/m^2; results in {}",
                    1e3 * report.period_m[0], 1e3 * report.period_m[1], report.yarns.len(), report.fibres, report.nodes, 1e6 * r.before.thickness_m, 1e6 * c.thickness_m,
                    100.0 * report.thickness_change, crimps.join(", "), c.fibre_volume_fraction, 1e3 * c.areal_density_kg_m2, out.display()
                );
                ExitCode::SUCCESS
            }
            Ok(None) => ExitCode::SUCCESS,
            Err(e) => fail_all(&session, setup_exit(&e), e),
        };
    }
    match dea_mpi::fabric::fabric(&case, comm, method_of(method), &out) {
        Ok(Some(report)) => {
            let (c, p) = (&report.cell, &report.panel);
            if let Some(r) = &report.relaxation {
                print_relaxation(r, report.relaxation_s);
            }
            println!(
                "cell: thickness {:.1} um, crimp {:.2} %, yarn {:.0} x {:.0} um, fibre volume fraction {:.3}, {:.1} g/m^2 ({:+.2} % from style 706's 180)",
                1e6 * c.thickness_m, 100.0 * c.crimp, 1e6 * c.yarn_width_m, 1e6 * c.yarn_thickness_m, c.fibre_volume_fraction, 1e3 * c.areal_density_kg_m2, 100.0 * report.style_706_areal_density_deviation
            );
            println!(
                "panel: {} x {} cells ({:.2} mm square), {} layers {:.1} um apart ({:.1} um thick), {} yarns, {} fibres, {} nodes; results in {}",
                p.cells_per_side, p.cells_per_side, 1e3 * p.side_m, p.layers, 1e6 * p.layer_pitch_m, 1e6 * p.thickness_m, p.yarns, p.fibres, p.nodes, out.display()
            );
            if let Some(coarse) = &report.coarse_cell {
                println!(
                    "hybrid: {} fine yarns each way per layer, {} of the nodes fine; coarse cell thickness {:.1} um, crimp {:.2} %; deepest contact as built {:.1} % of a contact distance; the fine region's layers start {:.1} um apart",
                    p.fine_yarns_per_layer, p.fine_nodes, 1e6 * coarse.thickness_m, 100.0 * coarse.crimp, 100.0 * p.largest_overlap_ratio, 1e6 * p.fine_layer_gap_m
                );
                if p.ties > 0 {
                    println!(
                        "transitions: {} ties; tied fine area differs from a coarse fibre's by up to {:.1} %, and centres up to {:.1} % of a coarse contact diameter off its axis",
                        p.ties,
                        100.0 * p.transitions.area_mismatch,
                        100.0 * p.transitions.eccentricity
                    );
                }
            }
            for r in &report.ranks {
                println!(
                    "rank {}: {} nodes + {} ghosts, built in {:.2} s, {:.0} bytes per node",
                    r.rank, r.owned_nodes, r.ghost_nodes, r.build_s, r.bytes_per_node
                );
            }
            ExitCode::SUCCESS
        }
        Ok(None) => ExitCode::SUCCESS,
        Err(e) => fail_all(&session, setup_exit(&e), e),
    }
}
