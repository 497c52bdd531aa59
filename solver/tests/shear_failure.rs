//! Shear failure as a user meets it (issue 31, item 1; docs/theory.md I9b): the binary runs
//! shipped cases with a field or two changed. Under the gauge shear measure (the default) a
//! blunt sphere below its perforation speed breaks nothing in shear at any element length
//! with tension taken on the element (with the tension gauge a small minority, in fragments
//! buckled by their own recoil, theory I9c), where the seed's element measure cuts intact
//! fibres; and the 17-grain FSP's 50 µm edge still cuts in shear.

use std::path::{Path, PathBuf};
use std::process::Command;

fn repository() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Breaks by mode (tension, shear, combined) and the residual velocity [m/s] of `case` run
/// with `edit` applied.
fn run(case: &str, label: &str, edit: impl Fn(&mut serde_json::Value)) -> ([u64; 3], f64) {
    let (breaks, residual, ()) = run_and_read(case, label, edit, |_| ());
    (breaks, residual)
}

/// Where a one-rank run's shear breaks fall, read from its snapshots (`out`), each as
/// (element gid, snapshot).
#[derive(Debug)]
struct ShearBreaks {
    /// those whose fibre had no break in tension or combined at an earlier snapshot
    in_intact_fibres: Vec<(u64, String)>,
    /// those with no element of their fibre within `RECOIL_REACH_M` compressed beyond
    /// `RECOIL_STRAIN` at any snapshot in the `RECOIL_WINDOW_S` before the one that first
    /// lists them
    without_compression: Vec<(u64, String)>,
}

/// How far from a shear break [m] its fibre is searched for recoil compression: four digital
/// fibre diameters of `four_layer_panel.json` (7 fibres in a 600 denier yarn: 91.8 µm),
/// about one Euler half-wave of a fibre compressed by its breaking strain,
/// `pi d / (4 sqrt(epsilon))` (theory I9c).
const RECOIL_REACH_M: f64 = 4.0 * 91.8e-6;
/// The compressive strain that counts as recoil [-]: more than half the breaking strain.
const RECOIL_STRAIN: f64 = -0.015;
/// How long before the snapshot that lists a shear break [s] its compression is looked for:
/// the break happened up to one snapshot interval (0.12 µs at l0/d 0.5) before it is listed,
/// and a stub of a few hundred µm between a break and the clamp rings axially with a period
/// `4 L / c` of about 0.15 µs, its buckles bending it on the way back out of compression.
const RECOIL_WINDOW_S: f64 = 0.3e-6;

fn shear_breaks(out: &Path) -> ShearBreaks {
    let file = hdf5::File::open(out.join("fields/ranks-00001-part-00000.h5")).unwrap();
    let mut snapshots = file.member_names().unwrap();
    snapshots.retain(|name| name.starts_with("snapshot-"));
    snapshots.sort();
    // the fibres: chains of the first snapshot's elements, by union of their two nodes
    let first = file.group(&snapshots[0]).unwrap();
    let connectivity = first.dataset("connectivity").unwrap().read_2d::<u32>().unwrap();
    let element_gid = first.dataset("element_gid").unwrap().read_raw::<u64>().unwrap();
    let nodes = first.dataset("gid").unwrap().read_raw::<u64>().unwrap().len();
    let mut parent: Vec<usize> = (0..nodes).collect();
    fn root(parent: &mut [usize], mut a: usize) -> usize {
        while parent[a] != a {
            parent[a] = parent[parent[a]];
            a = parent[a];
        }
        a
    }
    for row in connectivity.rows() {
        let (a, b) = (root(&mut parent, row[0] as usize), root(&mut parent, row[1] as usize));
        parent[a] = b;
    }
    let fibre_of: std::collections::HashMap<u64, usize> = element_gid
        .iter()
        .zip(connectivity.rows())
        .map(|(&gid, row)| (gid, root(&mut parent, row[0] as usize)))
        .collect();
    // each snapshot's unbroken elements: gid -> (fibre, middle [m], strain)
    let state = |name: &str| -> std::collections::HashMap<u64, (usize, [f64; 3], f64)> {
        let group = file.group(name).unwrap();
        let connectivity = group.dataset("connectivity").unwrap().read_2d::<u32>().unwrap();
        let gids = group.dataset("element_gid").unwrap().read_raw::<u64>().unwrap();
        let strain = group.dataset("strain").unwrap().read_raw::<f64>().unwrap();
        let position = group.dataset("position").unwrap().read_2d::<f64>().unwrap();
        let middle = |a: u32, b: u32| -> [f64; 3] {
            std::array::from_fn(|k| 0.5 * (position[[a as usize, k]] + position[[b as usize, k]]))
        };
        gids.iter()
            .zip(connectivity.rows())
            .zip(strain)
            .map(|((&gid, row), strain)| (gid, (fibre_of[&gid], middle(row[0], row[1]), strain)))
            .collect()
    };
    let time = |name: &str| file.group(name).unwrap().dataset("time").unwrap().read_raw::<f64>().unwrap()[0];
    let compressed_near = |name: &str, gid: u64, at: [f64; 3]| {
        state(name).values().any(|&(fibre, middle, strain)| {
            let distance = (0..3).map(|k| (middle[k] - at[k]).powi(2)).sum::<f64>().sqrt();
            fibre == fibre_of[&gid] && distance < RECOIL_REACH_M && strain < RECOIL_STRAIN
        })
    };
    let (mut torn, mut seen) = (std::collections::HashSet::new(), std::collections::HashSet::new());
    let mut found = ShearBreaks { in_intact_fibres: vec![], without_compression: vec![] };
    for (k, name) in snapshots.iter().enumerate() {
        let broken = file.group(&format!("{name}/broken")).unwrap();
        let gids = broken.dataset("element_gid").unwrap().read_raw::<u64>().unwrap();
        let modes = broken.dataset("failure").unwrap().read_raw::<u8>().unwrap();
        let fresh: Vec<(u64, u8)> = gids.into_iter().zip(modes).filter(|(gid, _)| seen.insert(*gid)).collect();
        for &(gid, mode) in &fresh {
            if mode != 2 {
                continue;
            }
            if !torn.contains(&fibre_of[&gid]) {
                found.in_intact_fibres.push((gid, name.clone()));
            }
            // where the element was at the snapshot before, the last that holds it unbroken
            // (a fragment moves a few tens of µm in the window, against a reach of 367 µm)
            let at = state(&snapshots[k.saturating_sub(1)]).get(&gid).map(|&(_, middle, _)| middle);
            let mut recent = snapshots[..=k].iter().filter(|earlier| time(name) - time(earlier) <= RECOIL_WINDOW_S);
            let compressed = at.is_some_and(|at| recent.any(|earlier| compressed_near(earlier, gid, at)));
            if !compressed {
                found.without_compression.push((gid, name.clone()));
            }
        }
        torn.extend(fresh.iter().filter(|(_, mode)| *mode != 2).map(|(gid, _)| fibre_of[gid]));
    }
    found
}

/// [`run`], with `read` given the output directory before it is removed.
fn run_and_read<T>(
    case: &str,
    label: &str,
    edit: impl Fn(&mut serde_json::Value),
    read: impl FnOnce(&Path) -> T,
) -> ([u64; 3], f64, T) {
    let scratch = std::env::temp_dir().join(format!("dea-shear-{}-{label}", std::process::id()));
    let _ = std::fs::remove_dir_all(&scratch);
    std::fs::create_dir_all(&scratch).unwrap();
    let text = std::fs::read_to_string(repository().join("cases").join(case)).unwrap();
    let mut value: serde_json::Value = serde_json::from_str(&text).unwrap();
    edit(&mut value);
    let path = scratch.join("case.json");
    std::fs::write(&path, value.to_string()).unwrap();
    let out = scratch.join("out");
    let done =
        Command::new(env!("CARGO_BIN_EXE_dea-mpi")).arg("run").arg(&path).arg("--out").arg(&out).output().unwrap();
    assert!(done.status.success(), "{label}: {}", String::from_utf8_lossy(&done.stderr));
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let read = read(&out);
    let _ = std::fs::remove_dir_all(&scratch);
    let count = |key: &str| summary[key].as_u64().unwrap();
    (
        [count("broken_elements_tension"), count("broken_elements_shear"), count("broken_elements_combined")],
        summary["residual_velocity_m_s"].as_f64().unwrap(),
        read,
    )
}

#[test]
fn a_blunt_sphere_below_its_perforation_speed_breaks_nothing_in_shear_at_any_element_length() {
    // cases/four_layer_panel.json's 0.8 mm sphere at 200 m/s: stopped to about 40 m/s within 4 µs
    // with tension taken on the element's own strain, as when the shear gauge was built
    let slow = |measure: &'static str, ratio: f64, tension: &'static str| {
        move |v: &mut serde_json::Value| {
            v["projectile"]["velocity_m_s"] = 200.0.into();
            v["run"]["end_time_s"] = 4e-6.into();
            v["target"]["element_length_ratio"] = ratio.into();
            v["failure"]["shear_measure"] = measure.into();
            v["failure"]["tension_measure"] = tension.into();
            // snapshots every 50 steps (about 50 ns at l0/d 0.5), to catch a fragment's
            // recoil, which swings from tension to compression within a few of them
            v["run"]["snapshot_interval_steps"] = 50.into();
        }
    };
    for ratio in [0.5, 0.25] {
        let ([tension, shear, _], residual) =
            run("four_layer_panel.json", &format!("gauge-{ratio}"), slow("gauge", ratio, "element"));
        assert!(residual < 100.0, "l0/d {ratio}: the sphere is being stopped ({residual} m/s)");
        assert!(tension > 0, "l0/d {ratio}: fibres under the nose break in tension");
        assert_eq!(shear, 0, "l0/d {ratio}: the gauge measure breaks nothing in shear under a blunt nose");
    }
    // the seed's element measure does, which is what the gauge measure is for
    let ([_, shear, _], _, element) =
        run_and_read("four_layer_panel.json", "element-0.5", slow("element", 0.5, "element"), shear_breaks);
    assert!(shear > 0, "the element measure breaks fibres in shear under a blunt nose");
    assert!(!element.in_intact_fibres.is_empty(), "the element measure cuts intact fibres in shear under a blunt nose");
    // under the tension gauge too (the default since 2026-12-03) a few break in shear, 2 and 6
    // against 21 and 16 in tension at l0/d 0.5 and 0.25, each in a fibre that broke in
    // tension before it, where the fragment recoils into compression and buckles: not an
    // intact fibre under the nose (theory I9c)
    for ratio in [0.5, 0.25] {
        let ([tension, shear, _], residual, found) = run_and_read(
            "four_layer_panel.json",
            &format!("both-gauges-{ratio}"),
            slow("gauge", ratio, "gauge"),
            shear_breaks,
        );
        assert!(residual < 100.0, "l0/d {ratio}, both gauges: the sphere is being stopped ({residual} m/s)");
        assert!(2 * shear < tension, "l0/d {ratio}, both gauges: {shear} in shear against {tension} in tension");
        assert!(
            found.in_intact_fibres.is_empty(),
            "l0/d {ratio}, both gauges: shear breaks in fibres intact before: {:?}",
            found.in_intact_fibres
        );
        assert!(
            found.without_compression.is_empty(),
            "l0/d {ratio}, both gauges: shear breaks with no recoil compression near them: {:?}",
            found.without_compression
        );
    }
    // and the element measure's cuts under the nose are not recoil: some have no compression
    // near them, so the check above can tell the two apart
    assert!(!element.without_compression.is_empty(), "the element measure's shear breaks: {element:?}");
}

#[test]
fn the_17_grain_fsps_edge_still_cuts_in_shear() {
    // a 10 mm patch of style 706 under the 17-grain FSP at 400 m/s (the built-in default case
    // until session 27), two layers, the first 3 µs
    let ([_, shear, _], _) = run("km2_706_patch.json", "fsp", |v| {
        v["target"]["layers"] = 2.into();
        v["run"]["end_time_s"] = 3e-6.into();
    });
    assert!(shear > 0, "the FSP's edge cuts fibres in shear under the gauge measure");
}
