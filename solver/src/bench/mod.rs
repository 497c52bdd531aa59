//! `dea-mpi bench`: a dense 19-fibre yarn with contacts and friction active and a sphere
//! pressing in, on every rank of the job; reports the cost of each part of the step.

mod packed;

use std::time::Instant;

use dea_core::projectile::{MeshShape, RigidShape};
use dea_core::Rank;
use dea_core::Vec3;
use dea_io::case::{default_case, Case, ProjectileSpec, TargetSpec, DEFAULT_FSP_DIVISIONS, KM2_600_DENIER_AREA};
use dea_partition::Method;
use dea_projectile::generate::{FspDimensions, Solid};
use serde::Serialize;

use crate::comm::Comm;
use crate::setup::{build_adjusted, SetupError};
use crate::step::{compute_forces, Stage, StageSeconds};

/// Bench results (JSON keys are part of the interface). Costs per node or per pair are
/// core-seconds: the sum over ranks of each stage's time, so they compare across ranks.
#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    /// nodes of the bench's yarn
    pub nodes: u64,
    /// timed steps
    pub steps: u64,
    /// ranks of the job
    pub ranks: usize,
    /// wall time of the timed steps (slowest rank) [s]
    pub wall_s: f64,
    /// core time per node-step: wall x ranks / node-steps [ns]
    pub ns_per_node_step: f64,
    /// fibre-contact stage time per touching pair, on the squeezed yarn held still (every
    /// pair in reach touches; friction evaluated, sticking). A pair has an entry at each of
    /// its nodes, so this is twice the time per entry.
    pub ns_per_contact_pair: f64,
    /// the law and friction alone on the same touching pairs, packed in contiguous arrays:
    /// what `ns_per_contact_pair` would be if the neighbour lists were free (no list, no pair
    /// apart, no partner gathered), the floor it stands on
    pub ns_per_contact_pair_packed: f64,
    /// the same per touching entry: half a pair (a pair of two owned nodes is evaluated
    /// once, for both entries)
    pub ns_per_contact_entry: f64,
    /// touching pair entries per node in that static measurement
    pub static_contacts_per_node: f64,
    /// fibre-contact stage time per neighbour-list entry per step
    pub ns_per_listed_pair: f64,
    /// tension + bending + integration per node-step
    pub ns_per_node_rods: f64,
    /// one neighbour-list build per node, of the squeezed yarn held still: no row changes
    /// (ghost exchange excluded)
    pub ns_per_node_rebuild: f64,
    /// the timed run's rebuild stage per node per rebuild: lists rebuilt where the sphere
    /// and the springing yarn changed them, and every step's motion check (ghost exchange
    /// excluded; none when the run rebuilt nothing)
    pub ns_per_node_rebuild_in_run: Option<f64>,
    /// touching pair entries per owned node during the run (each pair counted at both nodes)
    pub contacts_per_node: f64,
    /// neighbour-list entries per owned node during the run
    pub listed_pairs_per_node: f64,
    /// node-steps per second per core: the inverse of `ns_per_node_step`, scaled [1/s]
    pub node_steps_per_s_per_core: f64,
    /// ghost and list rebuilds in the timed steps
    pub rebuilds: u64,
    /// share of the step's wall time spent in the forward halo (slowest rank) [-]
    pub halo_share: f64,
    /// share spent in every communication (halo, ghost exchange, projectile, reductions) [-]
    pub communication_share: f64,
    /// forward-halo bytes received per step, summed over ranks
    pub halo_bytes_per_step: f64,
    /// ghost nodes / owned nodes, summed over ranks [-]
    pub ghost_fraction: f64,
    /// slowest rank's compute time / mean [-]
    pub load_imbalance: f64,
    /// mean over ranks of each stage's wall time in the timed steps [s]
    pub stage_seconds: StageSeconds,
    /// one contact query near the meshed 17-grain FSP (rank 0) [ns]
    pub ns_per_mesh_surface_query: f64,
    /// the same near the analytic cylinder of its diameter [ns]
    pub ns_per_analytic_surface_query: f64,
    /// triangles of that FSP mesh
    pub mesh_surface_triangles: usize,
}

/// The bench case: the default yarn made long enough for `min_nodes` nodes, no failure,
/// the Table 4-2 sphere at 50 m/s.
pub fn bench_case(min_nodes: usize) -> Case {
    let mut case = default_case();
    let fibres = 19;
    let diameter = (4.0 * KM2_600_DENIER_AREA / fibres as f64 / std::f64::consts::PI).sqrt();
    case.name = "bench-19-fibre-yarn".into();
    case.target = TargetSpec::StraightYarn {
        yarn: "km2_600_denier".into(),
        fibres_per_yarn: fibres,
        length_m: (min_nodes as f64 / fibres as f64) * 0.5 * diameter,
        element_length_ratio: 0.5,
        packing: None,
        ends: None,
        hold_lateral: false,
    };
    case.failure.mode = "none".into();
    case.projectile =
        ProjectileSpec { preset: Some("table_4_2_sphere".into()), velocity_m_s: 50.0, ..Default::default() };
    // the run settings of the default case the bench was defined on (session 27 gave the
    // default a settle and a longer end): no settle, the same histories
    case.run.settle = None;
    case.run.end_time_s = 30e-6;
    case.run.history_interval_steps = 50;
    case
}

/// Cost of one contact query of a fibre node near the 17-grain FSP's meshed surface and
/// near the analytic cylinder of the same diameter [ns], and the mesh's triangle count.
/// Query points lie within the contact reach of the surface (where candidates are).
fn surface_query_costs(contact_diameter: f64, skin: f64) -> (f64, f64, usize) {
    use rand::{Rng, SeedableRng};
    let (vertices, triangles) = Solid::Fsp(FspDimensions::SEVENTEEN_GRAIN).mesh(DEFAULT_FSP_DIVISIONS).boundary();
    let reach = 0.5 * contact_diameter + skin;
    let (mesh, _) =
        MeshShape::new(&vertices, triangles, reach, 1.3 * contact_diameter).expect("the FSP mesh is closed");
    let count = mesh.surface.triangles.len();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let points: Vec<Vec3> = (0..200_000)
        .map(|_| {
            let v = mesh.surface.vertices[rng.random_range(0..mesh.surface.vertices.len())];
            v + Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)) * reach
        })
        .collect();
    let radius = 0.5 * FspDimensions::SEVENTEEN_GRAIN.diameter;
    let shapes = [
        RigidShape::Mesh(std::sync::Arc::new(mesh)),
        RigidShape::Cylinder { radius, height: FspDimensions::SEVENTEEN_GRAIN.length, edge_radius: 150e-6 },
    ];
    let costs = shapes.map(|shape| {
        let clock = Instant::now();
        let found: f64 = points.iter().map(|p| shape.distance_and_normal(p).0.min(1.0)).sum();
        std::hint::black_box(found);
        clock.elapsed().as_secs_f64() * 1e9 / points.len() as f64
    });
    (costs[0], costs[1], count)
}

/// Runs the benchmark on every rank; rank 0 returns the report.
pub fn bench<C: Comm>(comm: C, min_nodes: usize, steps: u64) -> Result<Option<BenchReport>, SetupError> {
    let case = bench_case(min_nodes);
    // squeezed to 97% of the packing pitch: every neighbour pair is in contact
    let mut run = build_adjusted(&case, comm, Method::KWay, None, |nodes| {
        for p in &mut nodes.position {
            p.y *= 0.97;
            p.z *= 0.97;
        }
    })?;
    let sum = |run: &crate::distributed::Distributed<C>, values: &[f64]| -> Vec<f64> {
        let all = run.comm.gather_f64(values);
        let summed: Vec<f64> =
            (0..values.len()).map(|k| all.as_ref().map_or(0.0, |a| a.iter().map(|v| v[k]).sum())).collect();
        summed
    };
    let owned = run.domain.nodes.n_owned as f64;
    // neighbour-list build cost, on its own
    let samples = 10;
    let clock = Instant::now();
    for _ in 0..samples {
        run.domain.rebuild_neighbours()?;
    }
    let rebuild_seconds = clock.elapsed().as_secs_f64();
    let statics = 20;
    run.timer.reset();
    for _ in 0..statics {
        let instant = run.domain.step;
        compute_forces(&mut run.domain, &mut run.timer, instant)?;
    }
    let static_touching = run.domain.pairs.touching_entries() as f64;
    let static_seconds = run.timer.seconds.get(Stage::FibreContacts);
    let (_, packed_seconds, _) = packed::time_packed_contact_law(&run.domain, statics);
    run.timer.reset();
    let (halo_bytes_before, halo_steps_before, rebuilds_before) = (run.halo_bytes, run.halo_steps, run.rebuilds);
    let (mut touching, mut listed, mut sampled) = (0usize, 0usize, 0usize);
    let mut wall = [0.0];
    run.any(false); // line the ranks up before the clock starts
    let start = Instant::now();
    for step in 0..steps {
        run.step()?;
        if step % 10 == 0 {
            touching += run.domain.pairs.touching_entries();
            listed += run.domain.pairs.len();
            sampled += 1;
        }
    }
    wall[0] = start.elapsed().as_secs_f64();
    run.comm.max_f64(&mut wall);
    let wall = wall[0];
    let stages = run.timer.seconds;
    let compute = stages.computation();
    let communication = stages.total() - compute - stages.get(Stage::Output);
    let mut slowest = [compute, stages.get(Stage::HaloForward), communication];
    run.comm.max_f64(&mut slowest);
    let halo_steps = (run.halo_steps - halo_steps_before).max(1) as f64;
    let stage_sums = sum(&run, &stages.0);
    let totals = sum(
        &run,
        &[
            owned,
            rebuild_seconds,
            static_seconds,
            static_touching,
            packed_seconds,
            touching as f64 / sampled.max(1) as f64,
            listed as f64 / sampled.max(1) as f64,
            stages.get(Stage::FibreContacts),
            stages.get(Stage::Rods) + stages.get(Stage::Ties) + stages.get(Stage::KickDrift) + stages.get(Stage::Kick),
            compute,
            (run.halo_bytes - halo_bytes_before) as f64 / halo_steps,
            run.ghosts() as f64,
            stages.get(Stage::NeighbourRebuild),
        ],
    );
    let rebuilds = run.rebuilds - rebuilds_before;
    if run.comm.rank() != Rank(0) {
        return Ok(None);
    }
    let [nodes, rebuild_seconds, static_seconds, static_touching, packed_seconds, mean_touching, mean_listed, fibre_contacts, rods, compute_total, halo_bytes, ghosts, run_rebuild_seconds] =
        totals[..]
    else {
        unreachable!("thirteen totals")
    };
    let ranks = run.comm.size();
    let node_steps = nodes * steps as f64;
    let section = &run.domain.sections[0];
    let (mesh_query, analytic_query, mesh_triangles) =
        surface_query_costs(section.contact_diameter, run.domain.pairs.skin);
    let ns_per_contact_entry = static_seconds * 1e9 / (static_touching * statics as f64);
    Ok(Some(BenchReport {
        nodes: nodes as u64,
        steps,
        ranks,
        wall_s: wall,
        ns_per_node_step: wall * ranks as f64 * 1e9 / node_steps,
        // every touching pair has an entry at each of its nodes, on whichever ranks
        ns_per_contact_pair: 2.0 * ns_per_contact_entry,
        // over the same pairs: the ghosts' evaluated on both their ranks in each
        ns_per_contact_pair_packed: packed_seconds * 1e9 / (0.5 * static_touching * statics as f64),
        ns_per_contact_entry,
        static_contacts_per_node: static_touching / nodes,
        ns_per_listed_pair: fibre_contacts * 1e9 / (mean_listed * steps as f64),
        ns_per_node_rods: rods * 1e9 / node_steps,
        ns_per_node_rebuild: rebuild_seconds * 1e9 / (samples as f64 * nodes),
        ns_per_node_rebuild_in_run: (rebuilds > 0).then(|| run_rebuild_seconds * 1e9 / (rebuilds as f64 * nodes)),
        contacts_per_node: mean_touching / nodes,
        listed_pairs_per_node: mean_listed / nodes,
        node_steps_per_s_per_core: node_steps / wall / ranks as f64,
        rebuilds,
        halo_share: slowest[1] / wall,
        communication_share: slowest[2] / wall,
        halo_bytes_per_step: halo_bytes,
        ghost_fraction: ghosts / nodes,
        load_imbalance: slowest[0] / (compute_total / ranks as f64),
        stage_seconds: StageSeconds(std::array::from_fn(|k| stage_sums[k] / ranks as f64)),
        ns_per_mesh_surface_query: mesh_query,
        ns_per_analytic_surface_query: analytic_query,
        mesh_surface_triangles: mesh_triangles,
    }))
}
