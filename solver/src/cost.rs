//! What a shot will cost before it runs (docs/theory.md C1): one model, calibrated on the
//! reference shot's measured stages, used by `dea-mpi check` for every case and campaign and
//! through it by `jobs/cost.py`, `scripts/cost-model.py` and `scripts/validation.py`.
//!
//! Each stage of the step costs, per step, a measured time per unit of the count that drives
//! it (owned nodes, nodes held, expected contact-list entries, expected projectile
//! candidates), taken from the reference shot on one rank and the segment graph's counts of
//! that shot. A rank's step is the sum over its stages at its own counts, plus the rods of its
//! ghosts; the step of the job is its slowest rank's. Ranks on different hosts add their halo
//! messages and bytes and the collectives over an interconnect whose figures the calibration
//! states (assumed, not measured here).

use std::collections::BTreeMap;
use std::sync::OnceLock;

use dea_partition::{QualityReport, RankReport};
use serde::{Deserialize, Serialize};

use crate::step::Stage;

/// The calibration the binary ships: `docs/benchmarks/cost-calibration.json`, written by
/// `scripts/bench-shot.py --calibrate`.
pub const SHIPPED: &str = include_str!("../../docs/benchmarks/cost-calibration.json");

/// Whole validation shots against the price, per target kind: `docs/benchmarks/whole-shots.json`,
/// written from the shot records by `scripts/whole-shots.py --write`.
pub const WHOLE_SHOTS: &str = include_str!("../../docs/benchmarks/whole-shots.json");

/// Collectives of one step over every rank: the projectile broadcast, the motion agreement,
/// the error agreement, the load gather (two), and the rebuild vote.
pub const COLLECTIVES_PER_STEP: f64 = 6.0;

/// Measured stage times of the reference shot and the counts they were measured at.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Calibration {
    /// where the measurements come from (file, binary, host)
    pub source: String,
    /// the shot measured
    pub case: String,
    /// runs of the measured binary; those on one rank calibrate, the others check the model
    pub runs: Vec<MeasuredRun>,
    /// the segment graph's counts of the measured shot on one rank
    pub graph: GraphCounts,
    /// the network between hosts, for ranks that do not share one
    pub interconnect: Interconnect,
}

/// One measured run of the reference shot.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeasuredRun {
    /// ranks of the run, all on this host
    pub ranks: u32,
    /// steps of the shot's window
    pub steps: u64,
    /// wall time of the window [s]
    pub wall_s: f64,
    /// seconds of each stage over the window, mean over the ranks [s]
    pub stage_seconds: BTreeMap<String, f64>,
}

/// What the segment graph predicts for the measured shot on one rank.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GraphCounts {
    /// nodes of the shot
    pub owned_nodes: u64,
    /// expected fibre-contact list entries
    pub contact_entries: f64,
    /// expected projectile-contact candidates
    pub projectile_candidates: f64,
}

/// An interconnect between hosts.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Interconnect {
    /// one message's latency [s]
    pub latency_s: f64,
    /// one rank's injection bandwidth [bytes/s]
    pub bandwidth_bytes_per_s: f64,
    /// where the figures come from (ASSUMED unless measured on the target cluster)
    pub basis: String,
}

/// The count a stage's cost follows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Driver {
    /// the rank's owned nodes: integration, output, and the per-step agreements (their cost
    /// on one rank is the work around them)
    OwnedNodes,
    /// the owned nodes whose terms fire per step (all of them without multi-rate stepping,
    /// docs/theory.md T1): rods, ties, failure, the state check
    FiringNodes,
    /// owned and ghost nodes: the motion check, the ghost exchange and the list rebuild
    HeldNodes,
    /// expected fibre-contact list entries evaluated per step (each over its pair's rate)
    ContactEntries,
    /// expected projectile-contact candidates
    ProjectileCandidates,
}

/// The count each stage's cost follows.
pub fn driver(stage: Stage) -> Driver {
    match stage {
        Stage::HaloForward | Stage::ListCheck | Stage::GhostExchange | Stage::NeighbourRebuild => Driver::HeldNodes,
        Stage::FibreContacts => Driver::ContactEntries,
        Stage::ProjectileContacts | Stage::ProjectileLoad => Driver::ProjectileCandidates,
        Stage::Rods | Stage::Ties | Stage::Failure | Stage::StateCheck => Driver::FiringNodes,
        _ => Driver::OwnedNodes,
    }
}

/// Seconds per step per unit of each stage's driver, and of a ghost's rods.
#[derive(Clone, Debug, PartialEq)]
pub struct Rates {
    /// per stage, in `Stage::ALL` order [s per step per unit]
    pub per_stage: [f64; Stage::COUNT],
    /// one ghost node's rods per step [s]: the rods of an owned node
    pub ghost_rods: f64,
}

/// What a shot will cost on a given partition.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Price {
    /// ranks of the job
    pub ranks: usize,
    /// of them on one host
    pub ranks_per_host: usize,
    /// steps priced (settle and shot)
    pub steps: u64,
    /// the slowest rank's step [s]
    pub step_s: f64,
    /// of it, messages between hosts [s]
    pub network_s: f64,
    /// slowest rank's computation over the mean [-]
    pub imbalance: f64,
    /// [s]
    pub wall_s: f64,
    /// wall time times ranks [core-hours]
    pub core_hours: f64,
}

/// What whole shots have cost against the price, per target kind (`target.kind` of the case):
/// the reference window is the first 10 us of an impact, and a whole shot near its limit
/// rebuilds more often and holds a wider cone (docs/performance.md). Measured, not modelled:
/// a kind no campaign measured has no band.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct WholeShots {
    /// per target kind, the range of the measured factors
    pub bands: BTreeMap<String, Band>,
}

/// The range of whole shots' wall time per step over the priced step, for one target kind.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Band {
    /// the lowest factor measured [-]
    pub low: f64,
    /// the highest factor measured [-]
    pub high: f64,
    /// shots measured
    pub shots: u32,
    /// the campaigns they belong to (`jobs/campaigns/validation/`)
    pub campaigns: Vec<String>,
}

impl WholeShots {
    /// Reads the measured bands; every error names its field.
    pub fn parse(text: &str) -> Result<Self, String> {
        let whole: WholeShots = serde_json::from_str(text).map_err(|e| e.to_string())?;
        for (kind, band) in &whole.bands {
            if !(band.low.is_finite() && band.low > 0.0 && band.high.is_finite() && band.high >= band.low) {
                return Err(format!("bands.{kind}: low and high must be finite with 0 < low <= high"));
            }
            if band.shots == 0 || band.campaigns.is_empty() {
                return Err(format!("bands.{kind}: measured on no shot"));
            }
        }
        Ok(whole)
    }

    /// The bands in the binary (tested to parse).
    pub fn shipped() -> &'static WholeShots {
        static SHIPPED_WHOLE_SHOTS: OnceLock<WholeShots> = OnceLock::new();
        SHIPPED_WHOLE_SHOTS.get_or_init(|| WholeShots::parse(WHOLE_SHOTS).expect("the shipped bands parse (tested)"))
    }

    /// The band of a target kind, if any campaign of that kind was measured.
    pub fn band(&self, target_kind: &str) -> Option<&Band> {
        self.bands.get(target_kind)
    }
}

impl Calibration {
    /// Reads a calibration; every error names its field.
    pub fn parse(text: &str) -> Result<Self, String> {
        let calibration: Calibration = serde_json::from_str(text).map_err(|e| e.to_string())?;
        let known: Vec<&str> = Stage::ALL.iter().map(|s| s.name()).collect();
        for (k, run) in calibration.runs.iter().enumerate() {
            if run.ranks == 0 || run.steps == 0 || !(run.wall_s.is_finite() && run.wall_s > 0.0) {
                return Err(format!("runs[{k}]: ranks, steps and wall_s must be > 0"));
            }
            for (name, &seconds) in &run.stage_seconds {
                if !known.contains(&name.as_str()) {
                    return Err(format!(
                        "runs[{k}].stage_seconds.{name}: not a stage of the step (one of {})",
                        known.join(", ")
                    ));
                }
                if !(seconds.is_finite() && seconds >= 0.0) {
                    return Err(format!("runs[{k}].stage_seconds.{name}: must be finite and >= 0, got {seconds}"));
                }
            }
        }
        if !calibration.runs.iter().any(|run| run.ranks == 1) {
            return Err("runs: no run on one rank, which the model is calibrated on".into());
        }
        let graph = &calibration.graph;
        if graph.owned_nodes == 0 || !(graph.contact_entries > 0.0) || !(graph.projectile_candidates > 0.0) {
            return Err("graph: owned_nodes, contact_entries and projectile_candidates must be > 0".into());
        }
        let net = &calibration.interconnect;
        if !(net.latency_s.is_finite() && net.latency_s > 0.0) {
            return Err(format!("interconnect.latency_s: must be > 0, got {}", net.latency_s));
        }
        if !(net.bandwidth_bytes_per_s.is_finite() && net.bandwidth_bytes_per_s > 0.0) {
            return Err(format!("interconnect.bandwidth_bytes_per_s: must be > 0, got {}", net.bandwidth_bytes_per_s));
        }
        Ok(calibration)
    }

    /// The calibration in the binary (tested to parse).
    pub fn shipped() -> &'static Calibration {
        static SHIPPED_CALIBRATION: OnceLock<Calibration> = OnceLock::new();
        SHIPPED_CALIBRATION
            .get_or_init(|| Calibration::parse(SHIPPED).expect("the shipped calibration parses (tested)"))
    }

    /// Each stage's seconds per step per unit of its driver: the mean over the one-rank runs.
    pub fn rates(&self) -> Rates {
        let single: Vec<&MeasuredRun> = self.runs.iter().filter(|run| run.ranks == 1).collect();
        let mut per_stage = [0.0; Stage::COUNT];
        for (slot, stage) in per_stage.iter_mut().zip(Stage::ALL) {
            let per_step: f64 = single
                .iter()
                .map(|run| run.stage_seconds.get(stage.name()).copied().unwrap_or(0.0) / run.steps as f64)
                .sum::<f64>()
                / single.len() as f64;
            *slot = per_step / self.count(driver(stage));
        }
        let rods = Stage::ALL.iter().position(|&s| s == Stage::Rods).expect("a stage");
        Rates { per_stage, ghost_rods: per_stage[rods] }
    }

    /// The measured shot's count of `driver` on one rank.
    fn count(&self, driver: Driver) -> f64 {
        match driver {
            // the calibrated shot is single-rate: every node's terms fire at every step
            Driver::OwnedNodes | Driver::FiringNodes | Driver::HeldNodes => self.graph.owned_nodes as f64,
            Driver::ContactEntries => self.graph.contact_entries,
            Driver::ProjectileCandidates => self.graph.projectile_candidates,
        }
    }

    /// The price of `steps` steps on the partition `report` describes, `ranks_per_host` of
    /// its ranks sharing each host.
    pub fn price(&self, report: &QualityReport, steps: u64, ranks_per_host: usize) -> Price {
        let rates = self.rates();
        let ranks = report.ranks.len().max(1);
        let ranks_per_host = ranks_per_host.clamp(1, ranks);
        let computation: Vec<f64> = report.ranks.iter().map(|rank| rank_computation(&rates, rank)).collect();
        let across_hosts = ranks_per_host < ranks;
        let network: Vec<f64> =
            report.ranks.iter().map(|rank| if across_hosts { self.rank_network(rank, ranks) } else { 0.0 }).collect();
        let (slowest, network_s) = computation
            .iter()
            .zip(&network)
            .map(|(c, n)| (c + n, *n))
            .fold((0.0, 0.0), |best, this| if this.0 > best.0 { this } else { best });
        let mean = computation.iter().sum::<f64>() / ranks as f64;
        let largest = computation.iter().copied().fold(0.0, f64::max);
        let wall_s = slowest * steps as f64;
        Price {
            ranks,
            ranks_per_host,
            steps,
            step_s: slowest,
            network_s,
            imbalance: if mean > 0.0 { largest / mean } else { 1.0 },
            wall_s,
            core_hours: wall_s * ranks as f64 / 3600.0,
        }
    }

    /// One rank's messages per step between hosts: a halo message from each partner and its
    /// bytes, and the collectives' tree of latencies [s].
    fn rank_network(&self, rank: &RankReport, ranks: usize) -> f64 {
        let net = &self.interconnect;
        let halo = rank.partners as f64 * net.latency_s + rank.halo_bytes_per_step as f64 / net.bandwidth_bytes_per_s;
        let collectives = COLLECTIVES_PER_STEP * (ranks as f64).log2().ceil() * net.latency_s;
        halo + collectives
    }
}

/// One rank's computation per step at its counts [s].
fn rank_computation(rates: &Rates, rank: &RankReport) -> f64 {
    let held = (rank.owned_nodes + rank.ghost_nodes) as f64;
    let stages: f64 = Stage::ALL
        .iter()
        .zip(rates.per_stage)
        .map(|(&stage, rate)| {
            rate * match driver(stage) {
                Driver::OwnedNodes => rank.owned_nodes as f64,
                Driver::FiringNodes => rank.firing_nodes,
                Driver::HeldNodes => held,
                Driver::ContactEntries => rank.firing_entries,
                Driver::ProjectileCandidates => rank.projectile_candidates,
            }
        })
        .sum();
    // a ghost's rods fire as often as the owned nodes' around it, on average
    let firing_share = if rank.owned_nodes > 0 { rank.firing_nodes / rank.owned_nodes as f64 } else { 1.0 };
    stages + rank.ghost_nodes as f64 * firing_share * rates.ghost_rods
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rank(owned: u64, ghosts: u64, partners: u32) -> RankReport {
        RankReport {
            rank: 0,
            owned_nodes: owned,
            ghost_nodes: ghosts,
            work: 0.0,
            contact_entries: 10.0 * owned as f64,
            projectile_candidates: 0.01 * owned as f64,
            firing_nodes: owned as f64,
            firing_entries: 10.0 * owned as f64,
            partners,
            halo_bytes_per_step: 32 * ghosts,
        }
    }

    fn report(ranks: Vec<RankReport>) -> QualityReport {
        QualityReport {
            ranks,
            segments: 0,
            edge_cut: 0,
            load_imbalance: 1.0,
            memory_imbalance: 1.0,
            largest_stored_nodes: 0,
            ghost_fraction: 0.0,
            halo_bytes_per_step: 0,
        }
    }

    fn single_rank_calibration() -> Calibration {
        let mut calibration = Calibration::shipped().clone();
        calibration.runs.retain(|run| run.ranks == 1);
        calibration.runs.truncate(1);
        calibration
    }

    #[test]
    fn the_measured_shot_on_one_rank_is_priced_at_its_own_stages() {
        let calibration = single_rank_calibration();
        let run = &calibration.runs[0];
        let graph = calibration.graph;
        let one = RankReport {
            rank: 0,
            owned_nodes: graph.owned_nodes,
            ghost_nodes: 0,
            work: 0.0,
            contact_entries: graph.contact_entries,
            projectile_candidates: graph.projectile_candidates,
            firing_nodes: graph.owned_nodes as f64,
            firing_entries: graph.contact_entries,
            partners: 0,
            halo_bytes_per_step: 0,
        };
        let price = calibration.price(&report(vec![one]), run.steps, 1);
        let measured: f64 = run.stage_seconds.values().sum();
        assert!((price.wall_s - measured).abs() < 1e-9 * measured, "{} against {measured}", price.wall_s);
        assert_eq!((price.network_s, price.imbalance), (0.0, 1.0));
        assert!((price.core_hours - measured / 3600.0).abs() < 1e-12);
    }

    #[test]
    fn terms_that_fire_every_second_step_cost_half_and_the_rest_every_step() {
        let calibration = single_rank_calibration();
        let rates = calibration.rates();
        let single = rank(1000, 200, 1);
        let mut halved = single.clone();
        halved.firing_nodes *= 0.5;
        halved.firing_entries *= 0.5;
        let of = |driver: Driver, r: &RankReport| -> f64 {
            Stage::ALL
                .iter()
                .zip(rates.per_stage)
                .filter(|(&s, _)| self::driver(s) == driver)
                .map(|(_, rate)| rate)
                .sum::<f64>()
                * match driver {
                    Driver::FiringNodes => r.firing_nodes,
                    Driver::ContactEntries => r.firing_entries,
                    _ => unreachable!(),
                }
        };
        let firing = of(Driver::FiringNodes, &single) + of(Driver::ContactEntries, &single);
        let ghost_rods = 200.0 * rates.ghost_rods;
        let saved = rank_computation(&rates, &single) - rank_computation(&rates, &halved);
        let expected = 0.5 * (firing + ghost_rods);
        assert!((saved - expected).abs() < 1e-12 * expected, "saved {saved} s per step, expected {expected}");
        // rods, failure and the contact sweep fire; integration and the rebuild do not
        for stage in [Stage::Rods, Stage::Failure, Stage::StateCheck, Stage::Ties] {
            assert_eq!(driver(stage), Driver::FiringNodes, "{stage:?}");
        }
        for stage in [Stage::KickDrift, Stage::Kick, Stage::Output] {
            assert_eq!(driver(stage), Driver::OwnedNodes, "{stage:?}");
        }
    }

    #[test]
    fn the_slowest_rank_sets_the_step_and_ghosts_cost_rods_and_rebuild() {
        let calibration = single_rank_calibration();
        let rates = calibration.rates();
        let (a, b) = (rank(1000, 0, 1), rank(3000, 0, 1));
        let priced = calibration.price(&report(vec![a.clone(), b.clone()]), 10, 2);
        assert_eq!(priced.step_s, rank_computation(&rates, &b));
        assert!((priced.imbalance - 1.5).abs() < 1e-12, "3000 against a mean of 2000");
        // a ghost adds its rods and the held-node stages, nothing else
        let held: f64 = Stage::ALL
            .iter()
            .zip(rates.per_stage)
            .filter(|(&s, _)| driver(s) == Driver::HeldNodes)
            .map(|(_, r)| r)
            .sum();
        let ghosted = rank(1000, 100, 1);
        let extra = rank_computation(&rates, &ghosted) - rank_computation(&rates, &a);
        assert!((extra - 100.0 * (held + rates.ghost_rods)).abs() < 1e-12 * extra.abs().max(1e-30));
        assert!(extra > 0.0);
    }

    #[test]
    fn the_network_counts_only_across_hosts() {
        let calibration = single_rank_calibration();
        let ranks: Vec<RankReport> = (0..4).map(|_| rank(1000, 200, 3)).collect();
        let one_host = calibration.price(&report(ranks.clone()), 1, 4);
        assert_eq!(one_host.network_s, 0.0);
        let spread = calibration.price(&report(ranks), 1, 1);
        let net = &calibration.interconnect;
        let expected = 3.0 * net.latency_s + 6400.0 / net.bandwidth_bytes_per_s + 6.0 * 2.0 * net.latency_s;
        assert!((spread.network_s - expected).abs() < 1e-15, "{} against {expected}", spread.network_s);
        assert!((spread.step_s - one_host.step_s - expected).abs() < 1e-15);
    }

    #[test]
    fn bad_calibrations_are_refused_by_field() {
        let shipped: serde_json::Value = serde_json::from_str(SHIPPED).unwrap();
        let refused = |edit: &dyn Fn(&mut serde_json::Value), field: &str| {
            let mut value = shipped.clone();
            edit(&mut value);
            let error = Calibration::parse(&value.to_string()).unwrap_err();
            assert!(error.contains(field), "{field}: {error}");
        };
        refused(&|v| v["runs"][0]["stage_seconds"]["warp_drive"] = 1.0.into(), "runs[0].stage_seconds.warp_drive");
        refused(&|v| v["runs"][0]["stage_seconds"]["rods"] = (-1.0).into(), "runs[0].stage_seconds.rods");
        refused(&|v| v["interconnect"]["latency_s"] = 0.0.into(), "interconnect.latency_s");
        refused(&|v| v["interconnect"]["bandwidth_bytes_per_s"] = (-5.0).into(), "interconnect.bandwidth_bytes_per_s");
        refused(&|v| v["surprise"] = 1.into(), "surprise");
        refused(
            &|v| {
                let runs = v["runs"].as_array_mut().unwrap();
                runs.retain(|r| r["ranks"] != 1);
            },
            "no run on one rank",
        );
    }

    #[test]
    fn the_shipped_whole_shot_bands_parse_and_bad_ones_are_refused_by_field() {
        let shipped = WholeShots::shipped();
        // a woven panel near its limit has cost more per step than the window, a yarn less
        let woven = shipped.band("woven_panel").expect("woven panels measured");
        assert!(woven.low > 1.0 && woven.shots > 0, "{woven:?}");
        assert!(shipped.band("straight_yarn").is_some_and(|yarn| yarn.high < 1.0));
        assert!(shipped.band("three_d_woven_panel").is_none());
        let value: serde_json::Value = serde_json::from_str(WHOLE_SHOTS).unwrap();
        let refused = |edit: &dyn Fn(&mut serde_json::Value), words: &str| {
            let mut bad = value.clone();
            edit(&mut bad);
            let error = WholeShots::parse(&bad.to_string()).unwrap_err();
            assert!(error.contains(words), "{words}: {error}");
        };
        refused(&|v| v["bands"]["woven_panel"]["low"] = 0.0.into(), "bands.woven_panel");
        refused(&|v| v["bands"]["woven_panel"]["high"] = 0.5.into(), "bands.woven_panel");
        refused(&|v| v["bands"]["woven_panel"]["shots"] = 0.into(), "bands.woven_panel: measured on no shot");
        refused(&|v| v["bands"]["woven_panel"]["surprise"] = 1.into(), "surprise");
    }

    #[test]
    fn the_shipped_calibration_covers_the_costly_stages_and_its_wall() {
        let calibration = Calibration::shipped();
        for run in &calibration.runs {
            for stage in [Stage::KickDrift, Stage::NeighbourRebuild, Stage::Rods, Stage::FibreContacts, Stage::Failure]
            {
                assert!(run.stage_seconds.get(stage.name()).is_some_and(|&s| s > 0.0), "{}", stage.name());
            }
            // the stages account for the window's wall (the rest is the run loop between steps)
            let stages: f64 = run.stage_seconds.values().sum();
            assert!(
                (stages / run.wall_s - 1.0).abs() < 0.02,
                "{} rank(s): stages {stages} s of {} s",
                run.ranks,
                run.wall_s
            );
        }
    }
}
