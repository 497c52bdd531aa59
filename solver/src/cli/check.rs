//! `dea-mpi check`: validate a case (or a campaign and its shot's case) and print it resolved.

use std::path::PathBuf;
use std::process::ExitCode;

use dea_mpi::setup;

use super::{fail, in_file, load_case_or_campaign, setup_exit, Exit};

pub const ABOUT: &str = "Validate a case or a V50 campaign and print it resolved, without running";
pub const LONG_ABOUT: &str = "Validate a case, or a V50 campaign and its shot's case, and print it resolved (material,
sections, projectile, nodes, time step, steps, skin), without running.";
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
    if let Err(e) = setup::shares_fit(nodes, ranks as usize, ranks_per_host as usize, setup::memory_limit()) {
        let hint = format!(
            "; `check --ranks N --ranks-per-host M` checks the ranks meant (here {ranks}, {ranks_per_host} per host)"
        );
        return fail(setup_exit(&e), in_file(&e, Some(&path)) + &hint);
    }
    let projectile = &problem.projectile;
    let fibres = *problem.fabric.first_fibres().last().expect("a total") as u64;
    let mut printed = serde_json::json!({
        "case": case,
        "resolved": {
            "material": problem.material,
            "sections": problem.fabric.sections(&problem.material),
            "projectile": setup::describe_projectile(projectile, &resolved.projectile.body, problem.deformable.as_ref()),
            "yarns": problem.fabric.yarn_count(),
            "relaxation": problem.relaxation,
            "fibres": fibres,
            "nodes": nodes,
            "memory": {
                "ranks": ranks,
                "ranks_per_host": ranks_per_host,
                "bytes_per_rank": setup::share_bytes(nodes, ranks as usize),
                "host_bytes": setup::memory_limit(),
            },
            "time_step_s": problem.time_step,
            "steps": (case.run.end_time_s / problem.time_step).ceil(),
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
    println!("{}", serde_json::to_string_pretty(&printed).expect("case serialises"));
    ExitCode::SUCCESS
}
