//! `dea-mpi check`: validate a case (or a campaign and its shot's case) and print it resolved.

use std::path::PathBuf;
use std::process::ExitCode;

use dea_mpi::cost::{Calibration, WholeShots};
use dea_mpi::{settle, setup};

use super::{fail, in_file, load_case_or_campaign, setup_exit, Exit};

pub const ABOUT: &str = "Validate a case or a V50 campaign and print it resolved, without running";
pub const LONG_ABOUT: &str = "Validate a case, or a V50 campaign and its shot's case, and print it resolved (material,
sections, projectile, nodes, time step, steps, skin), without running. The target is
partitioned over --ranks as `run` would, and `resolved.cost` prices the shot on them (steps,
the slowest rank's step, wall time, core-hours; a campaign's shots and core-hours): the cost
model calibrated on the reference shot (docs/theory.md C1). Steps count to the end time; a
shot that is decided earlier stops earlier, so this is an upper bound.";
pub const EXAMPLES: &str =
    "Examples:\n  dea-mpi check cases/default.json\n  dea-mpi check cases/v50_tiny_bisection.json\n  dea-mpi check cases/km2_706_28_layer_disc.json --ranks 64 --ranks-per-host 32";

#[derive(clap::Args)]
pub struct Args {
    /// case or campaign file (JSON, SI units)
    pub case: PathBuf,
    /// the ranks the case is meant to run on: `check` refuses what `run` on them would (a
    /// share of the target too large for this host's memory or a process's address space)
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    pub ranks: u32,
    /// how many of those ranks share one host like this one (default: all of them)
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub ranks_per_host: Option<u32>,
}

pub fn main(Args { case: path, ranks, ranks_per_host }: Args) -> ExitCode {
    // a long set-up (a large cell relaxing) says how far it is, on stderr
    let _logging = dea_mpi::progress::init_logging(0, None);
    let (campaign, case) = match load_case_or_campaign(&path) {
        Ok(loaded) => loaded,
        Err((code, message)) => return fail(code, message),
    };
    let resolved = match case.resolve() {
        Ok(resolved) => resolved,
        Err(e) => return fail(Exit::BadCase, e),
    };
    if let dea_io::case::ResolvedTarget::ThreeDCell { weave, .. } = &resolved.target {
        // a cell for `dea-mpi fabric`: its initial layout, not relaxed
        let material = resolved.material.clone();
        let cell = match setup::laid_out_cell(weave, &material) {
            Ok(cell) => cell,
            Err(e) => return fail(setup_exit(&e), in_file(&e, Some(&path))),
        };
        let printed = serde_json::json!({
            "case": case,
            "resolved": { "material": material, "section": cell.section, "period_m": cell.period, "yarns": cell.yarns, "fibres": cell.fibres(), "nodes": cell.positions.len(), "initial": cell.statistics(&material) }
        });
        println!("{}", serde_json::to_string_pretty(&printed).expect("case serialises"));
        return ExitCode::SUCCESS;
    }
    let problem = match setup::problem(&case) {
        Ok(problem) => problem,
        Err(e) => return fail(setup_exit(&e), in_file(&e, Some(&path))),
    };
    // the refusal `run` makes before its partition, on the ranks the user means to use
    let ranks_per_host = ranks_per_host.unwrap_or(ranks).min(ranks);
    let nodes = problem.fabric.node_count();
    let refuse = |e: setup::SetupError| {
        let hint = format!(
            "; `check --ranks N --ranks-per-host M` checks the ranks meant (here {ranks}, {ranks_per_host} per host)"
        );
        fail(setup_exit(&e), in_file(&e, Some(&path)) + &hint)
    };
    if let Err(e) = setup::shares_fit(nodes, ranks as usize, ranks_per_host as usize, setup::memory_limit()) {
        return refuse(e);
    }
    // the partition `run` would make, its largest share on a host, and the price on it
    let graph = setup::segment_graph(&problem, ranks as usize, None);
    let partition = match dea_partition::partition(&graph, ranks as usize, dea_partition::Method::KWay) {
        Ok(partition) => partition,
        Err(e) => return fail(Exit::BadCase, format!("{}: {e}", path.display())),
    };
    let quality = dea_partition::quality(&graph, &partition);
    let largest = quality.largest_stored_nodes;
    if let Err(e) = setup::largest_share_fits(largest, ranks as usize, ranks_per_host as usize, setup::memory_limit()) {
        return refuse(e);
    }
    let shot_steps = (case.run.end_time_s / problem.time_step).ceil() as u64;
    let settle_steps = case.run.settle.as_ref().map_or(0, |s| settle::settle_steps(s.time_s, problem.time_step));
    let calibration = Calibration::shipped();
    let price = calibration.price(&quality, settle_steps + shot_steps, ranks_per_host as usize);
    let shots = campaign.as_ref().map(|campaign| {
        let sequences = if campaign.design.independent() { 1 } else { campaign.replicates };
        campaign.design.expected_shots() * sequences
    });
    let mut cost = serde_json::json!({
        "ranks": price.ranks,
        "ranks_per_host": price.ranks_per_host,
        "settle_steps": settle_steps,
        "shot_steps": shot_steps,
        "steps": price.steps,
        "step_s": price.step_s,
        "network_s": price.network_s,
        "imbalance": price.imbalance,
        "wall_s": price.wall_s,
        "core_hours": price.core_hours,
        "calibration": calibration.source,
        "interconnect": if price.ranks_per_host < price.ranks { Some(&calibration.interconnect.basis) } else { None },
    });
    if let Some(shots) = shots {
        cost["campaign"] = serde_json::json!({ "shots": shots, "core_hours": shots as f64 * price.core_hours });
    }
    // what whole shots of this kind of target have cost against their price, as measured
    let target_kind = serde_json::to_value(&case.target).expect("a target serialises")["kind"]
        .as_str()
        .expect("a target has a kind")
        .to_string();
    let band = WholeShots::shipped().band(&target_kind);
    cost["whole_shots"] = serde_json::json!(band.map(|band| serde_json::json!({
        "target_kind": target_kind,
        "factor_low": band.low,
        "factor_high": band.high,
        "core_hours_low": band.low * price.core_hours,
        "core_hours_high": band.high * price.core_hours,
        "shots": band.shots,
        "campaigns": band.campaigns,
        "source": "docs/benchmarks/whole-shots.json",
    })));
    let projectile = &problem.projectile;
    let fibres = *problem.fabric.first_fibres().last().expect("a total") as u64;
    let mut printed = serde_json::json!({
        "case": case,
        "resolved": {
            "material": problem.material,
            "sections": problem.fabric.sections(&problem.material),
            "projectile": setup::describe_projectile(projectile, &resolved.projectile.body, problem.deformable.as_ref()),
            "yarns": problem.fabric.yarn_count(),
            "projectile_friction_spring": resolved.projectile_friction_spring.name(),
            "fibre_friction_spring": resolved.fibre_friction_spring.name(),
            "unload": resolved.unload.name(),
            "shear_measure": resolved.shear_measure.name(),
            "shear_gauge_diameters": resolved.shear_measure.gauge_diameters(),
            "tension_measure": resolved.tension_measure.name(),
            "tension_gauge_diameters": resolved.tension_measure.gauge_diameters(),
            "rest_angle_law": resolved.rest_angle_law.name(),
            "relaxation": problem.relaxation,
            "fibres": fibres,
            "nodes": nodes,
            "memory": {
                "ranks": ranks,
                "ranks_per_host": ranks_per_host,
                "bytes_per_rank": setup::share_bytes(nodes, ranks as usize),
                "largest_rank_nodes": largest,
                "stored_imbalance": quality.memory_imbalance,
                "work_imbalance": quality.load_imbalance,
                "largest_rank_bytes": largest as f64 * setup::BYTES_PER_NODE,
                "host_bytes": setup::memory_limit(),
            },
            "cost": cost,
            "time_step_s": problem.time_step,
            "time_step_bound": if problem.zigzag_shortened.is_some() { "bending_zigzag" } else { "stability" },
            "section_rates": problem.rates,
            "steps": shot_steps,
            "skin_m": problem.contact.skin,
            "hybrid": match &problem.fabric {
                dea_fabric::Fabric::Woven(panel) if panel.coarse.is_some() => Some(serde_json::json!({
                    "fine_nodes": panel.fine_node_count(),
                    "fine_yarns_per_layer": panel.fine_yarns_per_layer(),
                    "ties": panel.ties().len(),
                    "transitions": panel.transition_quality(),
                })),
                _ => None,
            },
        }
    });
    if let Some(campaign) = campaign {
        printed["campaign"] = serde_json::json!(campaign);
    }
    for note in case.notes() {
        eprintln!("note: {note}");
    }
    if problem.deformable.is_some() {
        eprintln!("note: cost: a deformable projectile's substeps are not in the price (the calibrated shot's projectile is rigid)");
    }
    if problem.rates.iter().any(|&rate| rate > 1) {
        eprintln!(
            "note: multi-rate stepping: the sections' terms fire every {:?} steps (section_rates); the price counts each node's rods and contacts at its rate, from a single-rate calibration (docs/theory.md C1)",
            problem.rates
        );
    }
    let campaign_line = shots.map_or(String::new(), |shots| {
        format!("; the campaign's {shots} shots about {:.3} core-hours", shots as f64 * price.core_hours)
    });
    let whole_line = match band {
        Some(band) => format!(
            "; whole {target_kind} shots have cost {:.2}-{:.2} times this per step ({} shots of {}: docs/benchmarks/whole-shots.json), so {:.3}-{:.3} core-hours to the end time",
            band.low,
            band.high,
            band.shots,
            band.campaigns.join(", "),
            band.low * price.core_hours,
            band.high * price.core_hours
        ),
        None => format!("; no whole {target_kind} shot has been measured against this price"),
    };
    // "about", not "at most": the price runs every shot to its end time, which bounds the
    // steps, but at the reference window's per-step rates, and a whole shot's later phases
    // rebuild their lists more often and relist more nodes (docs/performance.md, "Cost model")
    eprintln!(
        "cost: about {:.3} core-hours per shot on {} rank(s) ({:.0} s of wall: {} steps to the end time, {:.3} ms each at the reference shot's rates, the slowest rank {:.2} x the mean; a shot decided earlier stops there{whole_line}){campaign_line}",
        price.core_hours,
        price.ranks,
        price.wall_s,
        price.steps,
        1e3 * price.step_s,
        price.imbalance
    );
    println!("{}", serde_json::to_string_pretty(&printed).expect("case serialises"));
    ExitCode::SUCCESS
}
