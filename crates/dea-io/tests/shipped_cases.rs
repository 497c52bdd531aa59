//! The case and campaign files shipped in `cases/` stay valid as the schema changes, and
//! `cases/default.json` is the built-in default case, for users to copy and edit.

use std::path::{Path, PathBuf};

use dea_io::campaign::{is_campaign, load_campaign};
use dea_io::case::{default_case, load_case};

fn cases() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../cases")
}

fn is_campaign_file(path: &Path) -> bool {
    is_campaign(&serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap_or_else(|e| panic!("{}: {e}", path.display())))
}

#[test]
fn every_shipped_case_and_campaign_loads() {
    let mut files: Vec<PathBuf> = std::fs::read_dir(cases()).unwrap().map(|entry| entry.unwrap().path()).filter(|path| path.extension().is_some_and(|e| e == "json")).collect();
    files.sort();
    assert!(files.len() >= 20, "cases/ holds {} files", files.len());
    let mut campaigns = 0;
    for path in &files {
        if is_campaign_file(path) {
            load_campaign(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            campaigns += 1;
        } else {
            load_case(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        }
    }
    assert!(campaigns >= 4, "{campaigns} campaigns");
}

#[test]
fn the_default_case_file_is_the_built_in_default() {
    assert_eq!(load_case(&cases().join("default.json")).unwrap(), default_case());
}
