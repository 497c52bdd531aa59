//! `dea-mpi fit`: the estimates from shots on record, of one campaign or several pooled.

use std::path::PathBuf;
use std::process::ExitCode;

use super::{fail, Exit};

pub const ABOUT: &str = "Estimate V50 from the shots on record of one or more campaigns, pooled";
pub const LONG_ABOUT: &str = "Estimate the ballistic limit from the shots on record in campaign directories that
`dea-mpi v50` wrote (logistic and probit V10/V50/V90 with 95 % intervals, the logistic also by Firth's penalised
likelihood, which has an estimate where the outcomes separate by velocity, MIL-STD-662F, Lambert-Jonas), pooling the
shots of several campaigns fired at one target: the same shot case but for its name, strength seed, striking speed,
end time and checkpoint interval; the same scatter; the same model choices on record. Anything else is refused,
naming the field. Fires nothing and writes nothing.";
pub const EXAMPLES: &str = "Examples:
  dea-mpi fit validation/layers-4-3in validation/layers-4-3in-step-6.25   # two series of one panel, pooled
  dea-mpi fit out/v50 --json                                            # one campaign's estimates, as JSON";

#[derive(clap::Args)]
pub struct Args {
    /// campaign directories (each `dea-mpi v50 --out`)
    #[arg(required = true)]
    pub campaigns: Vec<PathBuf>,
    /// print the estimates as one JSON object (the form of v50.json) instead of lines
    #[arg(long)]
    pub json: bool,
}

pub fn main(Args { campaigns, json }: Args) -> ExitCode {
    if let Some(missing) = campaigns.iter().find(|d| !d.join("provenance.json").is_file()) {
        return fail(
            Exit::File,
            format!("{}: no provenance.json: not a campaign directory that `dea-mpi v50` wrote", missing.display()),
        );
    }
    if let Some(bare) = campaigns.iter().find(|d| !d.join("shots").is_dir()) {
        return fail(
            Exit::File,
            format!(
                "{}: no shots/ directory beside its provenance.json: the campaign's shot records are missing",
                bare.display()
            ),
        );
    }
    let report = match dea_mpi::pool::pooled_report(&campaigns) {
        Ok(report) => report,
        Err(e) => return fail(Exit::BadCase, e),
    };
    if json {
        println!("{}", serde_json::to_string_pretty(&report).expect("a report serialises"));
    } else {
        println!(
            "{}: {} shots ({} partial, {} complete)",
            report.campaign,
            report.shots.len(),
            report.partials,
            report.completes
        );
        super::v50::print_estimates(&report);
    }
    ExitCode::SUCCESS
}
