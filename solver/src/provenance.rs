//! What made a run's outputs (issue 35): `provenance.json` (version, commit, UTC start, host,
//! ranks and command line of every segment, and the case as run) and a short `README.txt`
//! saying what each file of the directory is, written by rank 0 as a run segment starts.

use std::path::Path;

/// The commit the binary was built from (`git rev-parse HEAD` at build time, `build.rs`).
pub const GIT_COMMIT: &str = env!("DEA_GIT_COMMIT");

/// The provenance file of an output directory.
pub const PROVENANCE_FILE: &str = "provenance.json";

/// The file that says what the others are.
pub const README_FILE: &str = "README.txt";

/// `seconds` since the Unix epoch as an ISO 8601 UTC time, `2026-11-26T03:08:51Z` (the
/// civil calendar from days since 1970-01-01, H. Hinnant's `civil_from_days`).
pub fn utc_text(seconds: u64) -> String {
    let (days, rest) = ((seconds / 86_400) as i64, seconds % 86_400);
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let day_of_era = z - era * 146_097;
    let year_of_era = (day_of_era - day_of_era / 1_460 + day_of_era / 36_524 - day_of_era / 146_096) / 365;
    let day_of_year = day_of_era - (365 * year_of_era + year_of_era / 4 - year_of_era / 100);
    let month_index = (5 * day_of_year + 2) / 153;
    let day = day_of_year - (153 * month_index + 2) / 5 + 1;
    let month = if month_index < 10 { month_index + 3 } else { month_index - 9 };
    let year = year_of_era + era * 400 + i64::from(month <= 2);
    format!("{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}Z", rest / 3600, rest / 60 % 60, rest % 60)
}

/// This host's name (the kernel's), or `unknown`.
pub fn host_name() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|name| name.trim().to_string())
        .ok()
        .filter(|name| !name.is_empty())
        .unwrap_or_else(|| "unknown".into())
}

/// One segment of a run: a fresh start, or a restart from a checkpoint.
fn segment(ranks: usize, restarted_at_step: Option<u64>) -> serde_json::Value {
    let now = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs());
    serde_json::json!({
        "dea_mpi_version": env!("CARGO_PKG_VERSION"),
        "git_commit": GIT_COMMIT,
        "started_utc": utc_text(now),
        "host": host_name(),
        "ranks": ranks,
        "command_line": std::env::args().collect::<Vec<_>>(),
        "restarted_at_step": restarted_at_step,
    })
}

const README: &str = "What each file of this run directory is (docs/output.md has every field):

  summary.json     the outcome (perforated, stopped, rebounded or undecided), residual
                   velocity, peak force, broken elements, energy balance, timings
  results.h5       the histories (time, projectile state and force, energies by kind,
                   broken elements by mode and layer, back-face deflection) and the case
  history.csv      the same histories as a table with units in the column names
  fields.xdmf      the fabric's field snapshots for ParaView (open this file): nodes with
                   position, velocity, displacement (from as built), layer and yarn; the
                   intact elements with strain, stress and failure
  broken-elements.xdmf  the broken elements alone (their two nodes fly apart; open it
                   beside fields.xdmf to see where the fabric failed, coloured by failure)
  fields/          the HDF5 parts of the snapshots, one per rank and rank count
  projectile.xdmf  the projectile's surface over time with its vertices' velocities
  progress.json    the last progress report (step, time, ETA, energy balance)
  checkpoint/      the last checkpoint, to continue with `dea-mpi run --restart`
  provenance.json  what made these files: version, git commit, UTC start, host, ranks and
                   command line of each run segment, and the case as run
";

/// Writes (a fresh run) or extends (a restart, `restarted_at_step`) `out/provenance.json`,
/// and writes `out/README.txt`. An unreadable earlier file is started afresh rather than
/// stopping the run.
pub fn record(out: &Path, case_json: &str, ranks: usize, restarted_at_step: Option<u64>) -> std::io::Result<()> {
    // a campaign's shot directory is made by its first output
    std::fs::create_dir_all(out)?;
    let path = out.join(PROVENANCE_FILE);
    let earlier = restarted_at_step
        .and_then(|_| std::fs::read_to_string(&path).ok())
        .and_then(|text| serde_json::from_str::<serde_json::Value>(&text).ok())
        .filter(|value| value["segments"].is_array());
    let mut provenance = earlier.unwrap_or_else(|| {
        let case: serde_json::Value = serde_json::from_str(case_json).unwrap_or(serde_json::Value::Null);
        serde_json::json!({ "case": case, "segments": [] })
    });
    if let Some(segments) = provenance["segments"].as_array_mut() {
        segments.push(segment(ranks, restarted_at_step));
    }
    let text = serde_json::to_string_pretty(&provenance).expect("provenance serialises") + "\n";
    // whole or not at all: written beside and renamed
    let partial = out.join(format!("{PROVENANCE_FILE}.partial"));
    std::fs::write(&partial, text)?;
    std::fs::rename(&partial, &path)?;
    std::fs::write(out.join(README_FILE), README)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn utc_text_follows_the_civil_calendar() {
        assert_eq!(utc_text(0), "1970-01-01T00:00:00Z");
        // 2000-02-29 (a leap day of a century divisible by 400) at 12:34:56
        assert_eq!(utc_text(951_827_696), "2000-02-29T12:34:56Z");
        assert_eq!(utc_text(1_798_676_931), "2026-12-31T00:28:51Z");
        assert_eq!(utc_text(4_107_542_400), "2100-03-01T00:00:00Z");
    }

    #[test]
    fn a_restart_adds_a_segment_and_keeps_the_case() {
        let out = std::env::temp_dir().join(format!("dea-provenance-{}", std::process::id()));
        std::fs::create_dir_all(&out).unwrap();
        record(&out, "{\"name\":\"x\"}", 2, None).unwrap();
        record(&out, "{\"name\":\"ignored on a restart\"}", 3, Some(1200)).unwrap();
        let value: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join(PROVENANCE_FILE)).unwrap()).unwrap();
        assert_eq!(value["case"]["name"], "x");
        let segments = value["segments"].as_array().unwrap();
        assert_eq!(segments.len(), 2);
        assert_eq!((segments[0]["ranks"].as_u64(), segments[1]["ranks"].as_u64()), (Some(2), Some(3)));
        assert_eq!(segments[1]["restarted_at_step"], 1200);
        assert_eq!(segments[0]["git_commit"], GIT_COMMIT);
        assert!(std::fs::read_to_string(out.join(README_FILE)).unwrap().contains("fields.xdmf"));
        std::fs::remove_dir_all(&out).unwrap();
    }
}
