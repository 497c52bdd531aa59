//! The V50 campaign file: a shot (a case, inline or in a file beside the campaign), a velocity
//! design, and how the estimates are made. Unknown fields are rejected; every error names its
//! field.

use std::path::{Path, PathBuf};

use dea_ballistic::design::Design;
use dea_ballistic::scatter::Scatter;
use serde::{Deserialize, Serialize};

use crate::case::{load_case, Case, CaseError};

/// A whole campaign.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Campaign {
    /// a name for the campaign
    pub name: String,
    /// the shot's case file, relative to the campaign file (or `case`, inline)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub case_file: Option<PathBuf>,
    /// the shot's case, inline (or `case_file`)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub case: Option<Case>,
    /// which velocities are shot
    pub design: Design,
    /// independent sequences of a sequential design, each with its own strength seed
    /// (`failure.seed + replicate`), run concurrently by the rank groups [-]
    #[serde(default = "one")]
    pub replicates: usize,
    /// the MIL-STD-662F estimate: shots of each outcome and the velocity spread allowed
    #[serde(default)]
    pub mil_std_662f: MilStdSpec,
    /// what each shot draws besides its strength seed: aim within a unit cell, yaw and
    /// obliquity; default [`Scatter::default`], or none for a bisection
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scatter: Option<Scatter>,
}

impl Campaign {
    /// The scatter the shots draw: as given, else none for a bisection (it assumes one
    /// realisation) and [`Scatter::default`] for every other design.
    pub fn scatter(&self) -> Scatter {
        match (&self.scatter, &self.design) {
            (Some(scatter), _) => *scatter,
            (None, Design::Bisection { .. }) => Scatter::none(),
            (None, _) => Scatter::default(),
        }
    }
}

fn one() -> usize {
    1
}

/// MIL-STD-662F parameters.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MilStdSpec {
    /// partials and completes each (3, 5 or 7 in the standard)
    pub count: usize,
    /// largest spread of the velocities used [m/s] (38.1 m/s = 125 ft/s for 3 + 3)
    pub spread_m_s: f64,
}

impl Default for MilStdSpec {
    fn default() -> Self {
        Self { count: 3, spread_m_s: 38.1 }
    }
}

fn invalid(path: &str, message: impl Into<String>) -> CaseError {
    CaseError { path: path.to_string(), message: message.into() }
}

/// Whether a JSON document is a campaign: one naming its shot's `case` or `case_file` (a
/// case names neither).
pub fn is_campaign(document: &serde_json::Value) -> bool {
    document.get("case").is_some() || document.get("case_file").is_some()
}

/// Reads and validates a campaign and its shot case; errors name the campaign file, or the
/// case file and its field.
pub fn load_campaign(path: &Path) -> Result<(Campaign, Case), CaseError> {
    let source = path.display().to_string();
    let text = crate::case::read_input(path)?;
    let text = crate::case::json_document(&text, &source)?;
    let deserializer = &mut serde_json::Deserializer::from_str(text);
    let mut campaign: Campaign = serde_path_to_error::deserialize(deserializer).map_err(|e| {
        let field = e.path().to_string();
        let inner = e.into_inner().to_string();
        match crate::case::locate_field::<Campaign>(text, &field).filter(|_| field != ".") {
            Some(located) => {
                invalid(&located, format!("{} (in {source})", crate::case::relocated(&inner, text, &located)))
            }
            None => invalid(if field == "." { &source } else { &field }, format!("{inner} (in {source})")),
        }
    })?;
    campaign.design.validate().map_err(|message| {
        let (field, reason) = message.split_once(": ").unwrap_or(("design", &message));
        invalid(field, format!("{reason} (in {source})"))
    })?;
    if let Some(scatter) = &campaign.scatter {
        scatter.validate().map_err(|message| {
            let (field, reason) = message.split_once(": ").unwrap_or(("scatter", &message));
            invalid(field, format!("{reason} (in {source})"))
        })?;
        if matches!(campaign.design, Design::Bisection { .. }) && !scatter.is_none() {
            return Err(invalid(
                "scatter",
                format!("a bisection assumes one realisation, so its shots cannot scatter: give aim \"fixed\" and fixed angles, or choose another design (in {source})"),
            ));
        }
    }
    if !(1..=1000).contains(&campaign.replicates) {
        return Err(invalid("replicates", format!("must be in 1..=1000, got {} (in {source})", campaign.replicates)));
    }
    let spread = campaign.mil_std_662f.spread_m_s;
    if campaign.mil_std_662f.count == 0 || spread.is_nan() || spread <= 0.0 {
        return Err(invalid("mil_std_662f", format!("needs count >= 1 and spread_m_s > 0 (in {source})")));
    }
    let case = match (&campaign.case_file, &campaign.case) {
        (Some(file), None) => {
            if file.as_os_str().is_empty() {
                return Err(invalid("case_file", format!("is empty: name the shot's case file (in {source})")));
            }
            let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
            let file = base.join(file);
            // a file that cannot be read is the campaign's error; a bad field, the case file's
            let case = load_case(&file).map_err(|e| {
                if e.path == file.display().to_string() {
                    invalid("case_file", format!("{}: {} (in {source})", file.display(), e.message))
                } else {
                    e
                }
            })?;
            campaign.case_file = Some(std::path::absolute(&file).unwrap_or(file));
            case
        }
        (None, Some(case)) => {
            case.validate()
                .map_err(|e| invalid(&format!("case.{}", e.path), format!("{} (in {source})", e.message)))?;
            case.clone()
        }
        _ => return Err(invalid(&source, "give exactly one of case_file and case")),
    };
    Ok((campaign, case))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, name: &str, value: &serde_json::Value) -> PathBuf {
        std::fs::create_dir_all(dir).unwrap();
        let path = dir.join(name);
        std::fs::write(&path, value.to_string()).unwrap();
        path
    }

    #[test]
    fn campaigns_load_and_name_their_bad_fields() {
        let dir = std::env::temp_dir().join(format!("dea-campaign-{}", std::process::id()));
        let case = serde_json::to_value(crate::case::default_case()).unwrap();
        write(&dir, "shot.json", &case);
        let good = serde_json::json!({ "name": "c", "case_file": "shot.json", "design": { "kind": "bisection", "low_m_s": 100.0, "high_m_s": 600.0, "resolution_m_s": 10.0 } });
        let (campaign, loaded) = load_campaign(&write(&dir, "good.json", &good)).unwrap();
        assert_eq!(loaded, crate::case::default_case());
        assert!(campaign.case_file.as_ref().unwrap().is_absolute());
        assert_eq!(campaign.replicates, 1);
        let error = |edit: &dyn Fn(&mut serde_json::Value)| {
            let mut value = good.clone();
            edit(&mut value);
            load_campaign(&write(&dir, "bad.json", &value)).unwrap_err()
        };
        let e = error(&|v| v["design"]["high_m_s"] = 50.0.into());
        assert_eq!(e.path, "design.low_m_s");
        let e = error(&|v| v["design"]["resolution_m_s"] = "fine".into());
        assert_eq!(e.path, "design.resolution_m_s", "{e}");
        let e = error(&|v| v["design"]["kind"] = "guess".into());
        assert!(e.path.starts_with("design") && e.message.contains("guess"), "{e}");
        let e = error(&|v| v["shots"] = 3.into());
        assert_eq!(e.path, "shots");
        assert_eq!(campaign.scatter(), Scatter::none(), "a bisection does not scatter");
        let e = error(&|v| v["scatter"] = serde_json::json!({}));
        assert_eq!(e.path, "scatter");
        let e = error(&|v| {
            v["design"] =
                serde_json::json!({ "kind": "monte_carlo", "centre_m_s": 300.0, "spread_m_s": 50.0, "shots": 4 });
            v["scatter"] = serde_json::json!({ "yaw_deg": { "kind": "normal", "std_dev": 5.0 } });
        });
        assert_eq!(e.path, "scatter.yaw_deg");
        let mut monte_carlo = good.clone();
        monte_carlo["design"] =
            serde_json::json!({ "kind": "monte_carlo", "centre_m_s": 300.0, "spread_m_s": 50.0, "shots": 4 });
        let (campaign, _) = load_campaign(&write(&dir, "mc.json", &monte_carlo)).unwrap();
        assert_eq!(campaign.scatter(), Scatter::default());
        let e = error(&|v| v["scatter"] = serde_json::json!({ "aim": "crossing" }));
        assert!(e.path.starts_with("scatter"), "{e}");
        let e = error(&|v| v["case"] = case.clone());
        assert!(e.message.contains("exactly one"), "{e}");
        let e = error(&|v| {
            v.as_object_mut().unwrap().remove("case_file");
            v["case"] = case.clone();
            v["case"]["run"]["end_time_s"] = (-1.0).into();
        });
        assert_eq!(e.path, "case.run.end_time_s");
        let e = error(&|v| v["case_file"] = "missing.json".into());
        assert!(
            e.path == "case_file" && e.message.contains("missing.json: cannot read") && e.message.contains("bad.json"),
            "{e}"
        );
        let e = error(&|v| v["case_file"] = "".into());
        assert!(e.path == "case_file" && e.message.contains("is empty"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
