//! `dea-mpi v50`: a V50 campaign on groups of ranks firing concurrently.

use std::path::PathBuf;
use std::process::ExitCode;

use dea_core::Rank;
use dea_mpi::campaign::{CampaignError, CampaignReport, Group, Progress};
use dea_mpi::comm::mpi::MpiComm;
use dea_mpi::comm::Comm;
use dea_mpi::run::RunError;

use super::{fail, fail_all, load_campaign_shared, setup_exit, Exit};

pub const ABOUT: &str = "Run a V50 campaign, its shots on groups of ranks at once";
pub const LONG_ABOUT: &str = "Run a V50 campaign: the shots its design asks for, on groups of --ranks-per-shot ranks
firing concurrently; every shot's record is kept the moment it ends (OUT/shots/), so a rerun skips finished shots and
resumes an interrupted one from its checkpoint. Writes OUT/v50.json (logistic and probit V10/V50/V90 with 95 %
intervals, the logistic by Firth's penalised likelihood, MIL-STD-662F, Lambert-Jonas, bisection brackets) and
OUT/provenance.json. SIGTERM or SIGUSR1: every group checkpoints its shot and the job stops with exit code 75.";
pub const EXAMPLES: &str = "Examples:\n  mpirun -np 4 dea-mpi v50 campaign.json --out out/v50 --ranks-per-shot 2\n  dea-mpi v50 campaign.json --out out/v50          # again: only the missing shots run";

#[derive(clap::Args)]
pub struct Args {
    /// campaign file (JSON)
    pub campaign: PathBuf,
    /// output directory
    #[arg(long, default_value = "out/v50")]
    pub out: PathBuf,
    /// ranks per shot (divides the job's ranks); default: all of them, one shot at a time
    #[arg(long)]
    pub ranks_per_shot: Option<usize>,
    /// fire at most this many new shots per group, then stop (exit 0; the next run
    /// continues): a campaign spread over several jobs
    #[arg(long)]
    pub shots_per_group: Option<usize>,
}

pub fn main(Args { campaign, out, ranks_per_shot, shots_per_group }: Args) -> ExitCode {
    let (session, comm) = match MpiComm::initialize() {
        Ok(mpi) => mpi,
        Err(e) => return fail(Exit::Usage, e),
    };
    let ranks = comm.size();
    let per_shot = ranks_per_shot.unwrap_or(ranks);
    if per_shot == 0 || ranks % per_shot != 0 {
        return fail_all(
            &session,
            Exit::Usage,
            format!("--ranks-per-shot {per_shot} does not divide the job's {ranks} ranks"),
        );
    }
    let (campaign_spec, case, text) = match load_campaign_shared(&comm, &campaign) {
        Ok(loaded) => loaded,
        Err((code, message)) => return fail_all(&session, code, message),
    };
    let stop_signal = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGTERM, signal_hook::consts::SIGUSR1] {
        if let Err(e) = signal_hook::flag::register(signal, stop_signal.clone()) {
            return fail_all(&session, Exit::Usage, format!("cannot handle signal {signal}: {e}"));
        }
    }
    let _logging = match dea_mpi::progress::init_logging(comm.rank().0, None) {
        Ok(span) => span,
        Err(e) => return fail(Exit::File, format!("logging: {e}")),
    };
    let group = Group { index: comm.rank().0 as usize / per_shot, count: ranks / per_shot };
    let group_comm = comm.split(group.index as u32);
    let result = dea_mpi::campaign::run_group(
        &campaign_spec,
        &case,
        group_comm,
        group,
        &out,
        shots_per_group,
        Some(stop_signal),
    );
    let code = match &result {
        Ok(_) => 0,
        Err(CampaignError::Setup { error, .. }) => setup_exit(error) as u8,
        Err(CampaignError::Scatter(_)) => Exit::BadCase as u8,
        Err(CampaignError::Run { error: RunError::Numerical(_), .. }) => Exit::Numerical as u8,
        Err(CampaignError::Run { error: RunError::Interrupted(_), .. }) => Exit::Interrupted as u8,
        Err(CampaignError::Run { error: RunError::Output(_), .. }) | Err(CampaignError::Output(_)) => Exit::File as u8,
    };
    if let Err(e) = &result {
        // the group's own error: its rank 0 says what it was
        if comm.rank().0 as usize == group.index * per_shot {
            eprintln!("error: group {}: {e}", group.index);
        }
    }
    // the whole job ends with the most serious code of any group
    let mut worst = [code as f64];
    comm.max_f64(&mut worst);
    if worst[0] != 0.0 {
        session.barrier();
        return ExitCode::from(worst[0] as u8);
    }
    let mut paused = [matches!(result, Ok(Progress::Paused)) as u8 as f64];
    comm.max_f64(&mut paused);
    if comm.rank() != Rank(0) {
        return ExitCode::SUCCESS;
    }
    if paused[0] != 0.0 {
        println!(
            "{}: paused after --shots-per-group {} new shots per group; run again to continue",
            campaign_spec.name,
            shots_per_group.unwrap_or(0)
        );
    }
    let report = match dea_mpi::campaign::report(&campaign_spec, &out)
        .and_then(|r| dea_mpi::campaign::write_report(&r, &campaign_spec, &case, &text, &out).map(|()| r))
    {
        Ok(report) => report,
        Err(e) => return fail(Exit::File, e),
    };
    println!(
        "{}: {} shots ({} partial, {} complete) on {} group(s) of {} rank(s); results in {}",
        report.campaign,
        report.shots.len(),
        report.partials,
        report.completes,
        group.count,
        per_shot,
        out.display()
    );
    print_estimates(&report);
    ExitCode::SUCCESS
}

/// The estimates as `v50` and `fit` print them, one line each.
pub fn print_estimates(report: &CampaignReport) {
    if report.held_at_end > 0 {
        let held: Vec<&str> =
            report.shots.iter().filter(|s| s.stopped_by == "end_time_s").map(|s| s.id.as_str()).collect();
        println!(
            "warning: {} partial(s) were still undecided at the case's end time ({}); a longer run.end_time_s would decide them: raise it in the case, remove their records (shots/<id>.json) and run the campaign again, and each goes on from the checkpoint at its end (shots/<id>/checkpoint) where that is still on disk",
            report.held_at_end,
            held.join(", ")
        );
    }
    let fits = [
        ("logistic", "", &report.logistic),
        ("probit", "", &report.probit),
        ("Firth", "penalised ", &report.firth_logistic),
    ];
    for (name, penalised, fit) in fits {
        match fit {
            Ok(f) => println!(
                "{name:>9}: V50 {:.1} m/s (95 %: {:.1}..{:.1} delta method, {:.1}..{:.1} profile {penalised}likelihood), V10 {:.1}, V90 {:.1}",
                f.v50.velocity, f.v50.low, f.v50.high, f.v50.profile_low, f.v50.profile_high, f.v10.velocity, f.v90.velocity
            ),
            Err(e) => println!("{name:>9}: {e}"),
        }
    }
    if report.logistic.is_err() && report.firth_logistic.is_ok() {
        println!("           (Firth: the logistic curve by Firth's penalised likelihood, which has a maximum where the outcomes separate by velocity; docs/theory.md V11)");
    }
    match &report.mil_std_662f {
        Ok(m) => println!(
            "MIL-STD-662F: V50 {:.1} m/s from {} + {} shots within {:.1} m/s",
            m.v50, m.count, m.count, m.spread
        ),
        Err(e) => println!("MIL-STD-662F: {e}"),
    }
    match &report.lambert_jonas {
        Ok(l) => {
            println!("Lambert-Jonas: v_bl {:.1} m/s (a {:.3}, p {:.2}, rms {:.1} m/s)", l.v_bl, l.a, l.p, l.rms_m_s);
            if !l.bounds_reached.is_empty() {
                println!(
                    "               {} at a bound of the range searched (a at most {}, p {} to {}): the shots do not fix the curve (docs/theory.md V4)",
                    l.bounds_reached.join(" and "),
                    dea_ballistic::lambert_jonas::A_MAX,
                    dea_ballistic::lambert_jonas::P_RANGE.0,
                    dea_ballistic::lambert_jonas::P_RANGE.1
                );
            }
        }
        Err(e) => println!("Lambert-Jonas: {e}"),
    }
    for (r, (low, high)) in report.bisection_brackets.iter().enumerate() {
        println!("bisection {r}: between {low:.1} and {high:.1} m/s (V50 ~ {:.1})", 0.5 * (low + high));
    }
}
