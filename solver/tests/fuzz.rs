//! Hostile and careless input, a bounded sample on every test run: mutated case files,
//! campaigns, Gmsh meshes and checkpoints, each given to `dea-mpi` as a user would. Every
//! invocation must end within its time limit (no hang), by itself (no signal), with a
//! documented exit code (0, 3 bad input, 4 file), never a panic (101); a refusal must say
//! `error:` and name the file it refuses. On a failure the mutated input is kept and the
//! command printed.
//!
//! `DEA_FUZZ_CASES` (default 120) sets the number of case mutations; campaigns, meshes and
//! checkpoints take a share of it. `DEA_FUZZ_SEED` (default 34) picks the sample;
//! `scripts/fuzz.sh N [SEED]` runs a longer one.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// How long one invocation may take before it counts as a hang (the checks take well under a
/// second; the restarts a few).
const LIMIT: Duration = Duration::from_secs(90);

/// A small deterministic generator (SplitMix64): the sample depends on the seed alone.
struct Draw(u64);

impl Draw {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

fn env_or(name: &str, default: u64) -> u64 {
    std::env::var(name).ok().and_then(|v| v.parse().ok()).unwrap_or(default)
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("dea-fuzz-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Runs dea-mpi with a time limit: its exit code (None: killed by a signal) and stderr.
fn dea(args: &[&str]) -> Result<(Option<i32>, String), String> {
    let mut child = Command::new(env!("CARGO_BIN_EXE_dea-mpi"))
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let started = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            let mut stderr = String::new();
            std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut stderr).unwrap();
            return Ok((status.code(), stderr));
        }
        if started.elapsed() > LIMIT {
            let _ = child.kill();
            let _ = child.wait();
            return Err(format!("no answer within {} s (a hang)", LIMIT.as_secs()));
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Checks one invocation against the rules; gives a description of what broke them.
fn judge(args: &[&str], file: &Path, allowed: &[i32]) -> Option<String> {
    let (code, stderr) = match dea(args) {
        Ok(answer) => answer,
        Err(hang) => return Some(hang),
    };
    let name = file.file_name().unwrap().to_str().unwrap();
    match code {
        None => Some(format!("killed by a signal\n{stderr}")),
        Some(101) => Some(format!("panicked\n{stderr}")),
        Some(0) if allowed.contains(&0) => None,
        Some(c) if allowed.contains(&c) => {
            let said = stderr.lines().find(|l| l.starts_with("error:"));
            match said {
                None => Some(format!("exit {c} without an `error:` line\n{stderr}")),
                Some(_) if !stderr.contains(name) => {
                    Some(format!("exit {c}: the error does not name {name}\n{stderr}"))
                }
                Some(_) => None,
            }
        }
        Some(c) => Some(format!("exit {c}, not one of {allowed:?}\n{stderr}")),
    }
}

/// The dotted paths of every value in a JSON document.
fn paths(value: &serde_json::Value, prefix: &str, out: &mut Vec<String>) {
    let children: Vec<(String, &serde_json::Value)> = match value {
        serde_json::Value::Object(map) => map.iter().map(|(k, v)| (k.clone(), v)).collect(),
        serde_json::Value::Array(items) => items.iter().enumerate().map(|(k, v)| (k.to_string(), v)).collect(),
        _ => return,
    };
    for (key, child) in children {
        let path = if prefix.is_empty() { key } else { format!("{prefix}.{key}") };
        out.push(path.clone());
        paths(child, &path, out);
    }
}

/// A dotted path as a JSON pointer.
fn pointer(path: &str) -> String {
    path.split('.').map(|key| format!("/{key}")).collect()
}

/// The object holding the value at `path`, when it is held by an object (not an array).
fn parent<'a>(
    value: &'a mut serde_json::Value,
    path: &str,
) -> Option<&'a mut serde_json::Map<String, serde_json::Value>> {
    let parent = path.rsplit_once('.').map_or(String::new(), |(parent, _)| pointer(parent));
    value.pointer_mut(&parent)?.as_object_mut()
}

/// Values a careless or hostile user puts where a number, a word or an object belongs.
fn hostile(draw: &mut Draw) -> serde_json::Value {
    let choices = [
        serde_json::json!(0),
        serde_json::json!(-1),
        serde_json::json!(1e308),
        serde_json::json!(-1e308),
        serde_json::json!(5e-324),
        serde_json::json!(18446744073709551615u64),
        serde_json::json!(3.5),
        serde_json::json!("text"),
        serde_json::json!(""),
        serde_json::json!(null),
        serde_json::json!(true),
        serde_json::json!([]),
        serde_json::json!({}),
        serde_json::json!([1e308, -1e308]),
        serde_json::json!({ "kind": "nonsense" }),
    ];
    choices[draw.below(choices.len())].clone()
}

/// One mutation of a JSON document, as text: a value replaced, a key removed or added, or
/// the text itself broken.
fn mutate_json(base: &serde_json::Value, draw: &mut Draw) -> (String, String) {
    let mut all = Vec::new();
    paths(base, "", &mut all);
    let mut value = base.clone();
    let path = all[draw.below(all.len())].clone();
    match draw.below(6) {
        0..=2 => {
            let new = hostile(draw);
            *value.pointer_mut(&pointer(&path)).unwrap() = new.clone();
            (value.to_string(), format!("{path} = {new}"))
        }
        3 => {
            let key = path.rsplit('.').next().unwrap();
            if let Some(map) = parent(&mut value, &path) {
                map.remove(key);
            }
            (value.to_string(), format!("{path} removed"))
        }
        4 => {
            if let Some(map) = parent(&mut value, &path) {
                map.insert("unknown_field".into(), serde_json::json!(1));
            }
            (value.to_string(), format!("unknown field beside {path}"))
        }
        _ => {
            let text = serde_json::to_string_pretty(&value).unwrap();
            let at = draw.below(text.len());
            match draw.below(4) {
                0 => (text[..at].to_string(), format!("cut at byte {at}")),
                1 => (
                    format!("{}{}{}", &text[..at], ['{', '"', ',', ']', 'x'][draw.below(5)], &text[at..]),
                    format!("a character into byte {at}"),
                ),
                2 => (format!("{text}\n{text}"), "the document twice".into()),
                _ => (format!("\u{feff}{text}"), "a byte-order mark".into()),
            }
        }
    }
}

fn fuzz_documents(
    dir: &Path,
    base: &serde_json::Value,
    kind: &str,
    count: u64,
    draw: &mut Draw,
    failures: &mut Vec<String>,
) {
    for k in 0..count {
        let (text, what) = mutate_json(base, draw);
        let file = dir.join(format!("{kind}-{k:04}.json"));
        std::fs::write(&file, &text).unwrap();
        let file_arg = file.to_str().unwrap();
        if let Some(broken) = judge(&["check", file_arg], &file, &[0, 3, 4]) {
            failures.push(format!("dea-mpi check {file_arg} ({what}): {broken}"));
        } else {
            std::fs::remove_file(&file).unwrap();
        }
    }
}

/// A small hexahedral cylinder as Gmsh 4.1 ASCII.
fn gmsh(mesh: &dea_projectile::mesh::HexMesh) -> String {
    let n = mesh.nodes.len();
    let mut text = format!("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 {n} 1 {n}\n3 1 0 {n}\n");
    text += &(1..=n).map(|k| format!("{k}\n")).collect::<String>();
    text += &mesh.nodes.iter().map(|x| format!("{:?} {:?} {:?}\n", x.x, x.y, x.z)).collect::<String>();
    let m = mesh.hexes.len();
    text += &format!("$EndNodes\n$Elements\n1 {m} 1 {m}\n3 1 5 {m}\n");
    for (k, hex) in mesh.hexes.iter().enumerate() {
        text += &format!("{}{}\n", k + 1, hex.iter().map(|v| format!(" {}", v + 1)).collect::<String>());
    }
    text + "$EndElements\n"
}

/// One line of a mesh changed: a number made huge, negative or not a number, a line dropped,
/// doubled or cut short, or the file cut.
fn mutate_lines(text: &str, draw: &mut Draw) -> (String, String) {
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let k = draw.below(lines.len());
    let what = match draw.below(6) {
        0 => {
            lines.remove(k);
            format!("line {} dropped", k + 1)
        }
        1 => {
            lines.insert(k, lines[k].clone());
            format!("line {} doubled", k + 1)
        }
        2 => {
            lines.truncate(k);
            format!("cut before line {}", k + 1)
        }
        _ => {
            let words: Vec<&str> = lines[k].split_whitespace().collect();
            if words.is_empty() {
                return (lines.join("\n"), "nothing".into());
            }
            let w = draw.below(words.len());
            let new = ["1000000000000000000", "18446744073709551615", "-1", "0", "nan", "1e400", "x"][draw.below(7)];
            let changed: Vec<&str> =
                words.iter().enumerate().map(|(i, word)| if i == w { new } else { word }).collect();
            lines[k] = changed.join(" ");
            format!("word {} of line {} = {new}", w + 1, k + 1)
        }
    };
    (lines.join("\n") + "\n", what)
}

#[test]
fn hostile_input_is_refused_cleanly_or_accepted() {
    let count = env_or("DEA_FUZZ_CASES", 120);
    let mut draw = Draw(env_or("DEA_FUZZ_SEED", 34));
    let dir = scratch("inputs");
    let cases = Path::new(env!("CARGO_MANIFEST_DIR")).join("../cases");
    let read = |name: &str| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(cases.join(name)).unwrap()).unwrap()
    };
    let mut failures = Vec::new();
    for (k, name) in
        ["default.json", "hybrid_patch.json", "four_layer_fsp.json", "single_fibre_short.json"].iter().enumerate()
    {
        fuzz_documents(&dir, &read(name), &format!("case{k}"), count / 4, &mut draw, &mut failures);
    }
    let mut campaign = read("v50_tiny_monte_carlo.json");
    campaign["case_file"] = cases.join("v50_tiny_shot.json").to_str().unwrap().into();
    fuzz_documents(&dir, &campaign, "campaign", count / 4, &mut draw, &mut failures);

    // meshes, as the rigid body of a small case
    let mesh =
        dea_projectile::generate::Solid::Cylinder { radius: 0.6e-3, height: 1.0e-3, edge_radius: 0.1e-3 }.mesh(2);
    let good = gmsh(&mesh);
    let mut case = read("single_fibre_short.json");
    case["projectile"] =
        serde_json::json!({ "shape": "file", "mesh_file": "body.msh", "mass_kg": 5e-6, "velocity_m_s": 100.0 });
    for k in 0..count / 4 {
        let sub = dir.join(format!("mesh-{k:04}"));
        std::fs::create_dir_all(&sub).unwrap();
        let (text, what) = mutate_lines(&good, &mut draw);
        std::fs::write(sub.join("body.msh"), text).unwrap();
        std::fs::write(sub.join("case.json"), case.to_string()).unwrap();
        let file = sub.join("case.json");
        // a mesh error names the mesh file; an accepted mesh exits 0
        let (code, stderr) = dea(&["check", file.to_str().unwrap()]).unwrap_or((Some(-1), "hang".into()));
        let fine = match code {
            Some(0) => true,
            Some(3 | 4) => stderr.contains("body.msh") && stderr.starts_with("error:"),
            _ => false,
        };
        if fine {
            std::fs::remove_dir_all(&sub).unwrap();
        } else {
            failures.push(format!("dea-mpi check {} (body.msh: {what}): exit {code:?}\n{stderr}", file.display()));
        }
    }
    assert!(
        failures.is_empty(),
        "{} of the fuzzed inputs broke the rules:\n{}",
        failures.len(),
        failures.join("\n---\n")
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_damaged_checkpoint_is_refused_cleanly() {
    let dir = scratch("checkpoints");
    let cases = Path::new(env!("CARGO_MANIFEST_DIR")).join("../cases");
    let mut case: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(cases.join("single_fibre_short.json")).unwrap()).unwrap();
    case["run"]["checkpoint_interval_steps"] = 200.into();
    let case_path = dir.join("case.json");
    std::fs::write(&case_path, case.to_string()).unwrap();
    let first = dir.join("first");
    let (code, stderr) = dea(&["run", case_path.to_str().unwrap(), "--out", first.to_str().unwrap()]).unwrap();
    assert_eq!(code, Some(0), "{stderr}");
    let checkpoint = first.join("checkpoint");
    let files: Vec<PathBuf> =
        std::fs::read_dir(&checkpoint).unwrap().map(|e| e.unwrap().path()).filter(|p| p.is_file()).collect();
    assert!(!files.is_empty());
    let mut draw = Draw(env_or("DEA_FUZZ_SEED", 34));
    let mut failures = Vec::new();
    for k in 0..(env_or("DEA_FUZZ_CASES", 120) / 8).max(4) {
        let copy = dir.join(format!("damaged-{k:03}"));
        std::fs::create_dir_all(&copy).unwrap();
        for file in &files {
            std::fs::copy(file, copy.join(file.file_name().unwrap())).unwrap();
        }
        let victim = copy.join(files[draw.below(files.len())].file_name().unwrap());
        let mut bytes = std::fs::read(&victim).unwrap();
        let at = draw.below(bytes.len());
        let what = if draw.below(2) == 0 {
            bytes.truncate(at);
            format!("{} cut at byte {at}", victim.display())
        } else {
            bytes[at] ^= 1 << draw.below(8);
            format!("{} bit flipped at byte {at}", victim.display())
        };
        std::fs::write(&victim, bytes).unwrap();
        let out = copy.join("out");
        let args =
            ["run", case_path.to_str().unwrap(), "--restart", copy.to_str().unwrap(), "--out", out.to_str().unwrap()];
        // a flip in bytes no reader looks at may pass (exit 0); anything else is a refusal
        // that names the checkpoint
        let name = copy.file_name().unwrap().to_str().unwrap().to_string();
        match dea(&args) {
            Err(hang) => failures.push(format!("{what}: {hang}")),
            Ok((Some(0), _)) => {}
            Ok((Some(3 | 4), stderr)) if stderr.contains("error:") && stderr.contains(&name) => {}
            Ok((code, stderr)) => failures.push(format!("{what}: exit {code:?}\n{stderr}")),
        }
    }
    assert!(failures.is_empty(), "damaged checkpoints broke the rules:\n{}", failures.join("\n---\n"));
    std::fs::remove_dir_all(&dir).unwrap();
}
