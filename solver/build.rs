//! Records the git commit the binary is built from, for the provenance of V50 campaigns.

fn main() {
    let commit = std::process::Command::new("git")
        .args(["rev-parse", "HEAD"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .map(|s| s.trim().to_string())
        .unwrap_or_else(|| "unknown (not built from a git checkout)".into());
    let dirty = std::process::Command::new("git").args(["status", "--porcelain", "--untracked-files=no"]).output().ok().is_some_and(|o| !o.stdout.is_empty());
    println!("cargo:rustc-env=DEA_GIT_COMMIT={commit}{}", if dirty { " (with uncommitted changes)" } else { "" });
    // rebuild when HEAD moves (a commit, or a checkout of another branch)
    println!("cargo:rerun-if-changed=../.git/HEAD");
    println!("cargo:rerun-if-changed=../.git/index");
}
