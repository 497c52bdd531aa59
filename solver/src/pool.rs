//! `dea-mpi fit`: the ballistic limit from the shots on record of one campaign or of several
//! campaigns fired at one target, pooled.
//!
//! A range pools series fired on the same panel and projectile on different days; here a
//! finer up-and-down about a first series' bracket (docs/validation.md, the layer series) is
//! such a series. Pooling is sound for the maximum-likelihood fits whatever design chose the
//! velocities (the likelihood depends on the outcomes alone), so long as every shot is one
//! draw of the same experiment: the same case but for what differs from shot to shot (its
//! name, its strength seed, its striking speed) and for the end time (which only ends a shot,
//! docs/theory.md V1), the same scatter distributions, and the same model choices on record.
//! Anything else is refused, naming the field and the two directories.

use std::path::{Path, PathBuf};

use dea_io::campaign::Campaign;
use dea_io::case::{first_difference, Case};
use serde_json::Value;

use crate::campaign::{estimate, records, CampaignError, CampaignReport, ShotRecord};

/// What one campaign directory's `provenance.json` says it fired.
struct Fired {
    directory: PathBuf,
    campaign: Campaign,
    /// the shot case with the fields that may differ between pooled campaigns taken out,
    /// every default filled in (so that a file written before a field existed compares
    /// equal to one written after)
    comparable: Value,
    shots: Vec<ShotRecord>,
}

/// Case fields that may differ between campaigns pooled into one estimate: the name, the
/// strength seed (each campaign draws its own), the striking speed (each shot has its own) and
/// the end time and checkpoint intervals (they only end or save a shot).
const MAY_DIFFER: [&[&str]; 6] = [
    &["name"],
    &["failure", "seed"],
    &["projectile", "velocity_m_s"],
    &["run", "end_time_s"],
    &["run", "checkpoint_interval_minutes"],
    &["run", "checkpoint_interval_steps"],
];

fn read(directory: &Path) -> Result<Fired, CampaignError> {
    let path = directory.join("provenance.json");
    let failed = |what: String| CampaignError::Output(format!("{}: {what}", path.display()));
    let text = std::fs::read_to_string(&path)
        .map_err(|e| failed(format!("{e} (a campaign directory that `dea-mpi v50` wrote is needed)")))?;
    let provenance: Value = serde_json::from_str(&text).map_err(|e| failed(e.to_string()))?;
    let campaign: Campaign =
        serde_json::from_value(provenance["campaign"].clone()).map_err(|e| failed(format!("\"campaign\": {e}")))?;
    let case: Case =
        serde_json::from_value(provenance["case"].clone()).map_err(|e| failed(format!("\"case\": {e}")))?;
    // a provenance written before the tension measure and the rest-angle law were named
    // left them to the defaults of that time; one written since names them
    let mut comparable = serde_json::to_value(case.with_earlier_defaults_named()).expect("a case serialises");
    // the unloading's default changed without a name in the provenance: the records carry
    // it, and `choices` compares theirs
    if let Some(Value::Object(failure)) = comparable.get_mut("failure") {
        failure.remove("unload");
    }
    for path in MAY_DIFFER {
        let (last, parents) = path.split_last().expect("a path has a field");
        let parent = parents.iter().try_fold(&mut comparable, |v, key| v.get_mut(*key));
        if let Some(Value::Object(fields)) = parent {
            fields.remove(*last);
        }
    }
    let shots = records(directory)?;
    Ok(Fired { directory: directory.to_path_buf(), campaign, comparable, shots })
}

/// The model choices a record was fired with (docs/theory.md I6c, I6d, I7).
fn choices(s: &ShotRecord) -> [(&'static str, &str); 3] {
    [
        ("projectile_friction_spring", &s.projectile_friction_spring),
        ("fibre_friction_spring", &s.fibre_friction_spring),
        ("unload", &s.unload),
    ]
}

/// The estimates from every shot on record in `directories`, pooled; each shot's id becomes
/// `<campaign name>/<id>`. Refuses campaigns that are not draws of one experiment (see the
/// module's doc) and a directory without shots.
pub fn pooled_report(directories: &[PathBuf]) -> Result<CampaignReport, CampaignError> {
    let fired: Vec<Fired> = directories.iter().map(|d| read(d)).collect::<Result<_, _>>()?;
    // one campaign given twice (or a copy of it) would count its shots twice
    for (k, f) in fired.iter().enumerate() {
        let again = fired[..k].iter().find(|g| {
            g.campaign.name == f.campaign.name
                || std::fs::canonicalize(&g.directory).ok() == std::fs::canonicalize(&f.directory).ok()
        });
        if let Some(g) = again {
            return Err(CampaignError::Output(format!(
                "{} and {} are the same campaign ({}): its shots would count twice",
                g.directory.display(),
                f.directory.display(),
                f.campaign.name
            )));
        }
    }
    let Some(first) = fired.first() else {
        return Err(CampaignError::Output("no campaign directory to pool".to_string()));
    };
    let refuse = |other: &Fired, what: String| {
        CampaignError::Output(format!(
            "{} and {} cannot be pooled: {what}",
            first.directory.display(),
            other.directory.display()
        ))
    };
    let scatter = |f: &Fired| serde_json::to_value(f.campaign.scatter()).expect("a scatter serialises");
    if let Some(empty) = fired.iter().find(|f| f.shots.is_empty()) {
        return Err(CampaignError::Output(format!("{}: no shot on record", empty.directory.display())));
    }
    // every shot's model choices against the first shot's
    let reference = &first.shots[0];
    let mut shots = Vec::new();
    for f in &fired {
        if let Some(field) = first_difference(&first.comparable, &f.comparable, "case") {
            return Err(refuse(f, format!("their shot cases differ at {field}")));
        }
        if let Some(field) = first_difference(&scatter(first), &scatter(f), "scatter") {
            return Err(refuse(f, format!("their shots draw from different distributions ({field})")));
        }
        if f.campaign.mil_std_662f != first.campaign.mil_std_662f {
            return Err(refuse(f, "their mil_std_662f settings differ".to_string()));
        }
        for s in &f.shots {
            for ((field, asked), (_, on_record)) in choices(reference).into_iter().zip(choices(s)) {
                if asked != on_record {
                    return Err(refuse(
                        f,
                        format!(
                            "shot {} was fired with {field} \"{on_record}\", shot {} of {} with \"{asked}\"",
                            s.id,
                            reference.id,
                            first.directory.display()
                        ),
                    ));
                }
            }
            let mut pooled = s.clone();
            pooled.id = format!("{}/{}", f.campaign.name, s.id);
            shots.push(pooled);
        }
    }
    let name = fired.iter().map(|f| f.campaign.name.as_str()).collect::<Vec<_>>().join(" + ");
    Ok(estimate(name, shots, &first.campaign.mil_std_662f, Vec::new()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn the_first_difference_names_the_field() {
        let a = json!({"target": {"layers": 4, "side_m": 0.0762}, "run": {"settle": {"time_s": 5e-6}}});
        let b = json!({"target": {"layers": 8, "side_m": 0.0762}, "run": {"settle": {"time_s": 5e-6}}});
        assert_eq!(first_difference(&a, &b, "case").as_deref(), Some("case.target.layers"));
        assert_eq!(first_difference(&a, &a, "case"), None);
        let c = json!({"target": {"layers": 4, "side_m": 0.0762}, "run": {}});
        assert_eq!(first_difference(&a, &c, "case").as_deref(), Some("case.run.settle"));
    }
}
