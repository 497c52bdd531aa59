//! From a validated case to a running rank: the problem's description, its partition, and
//! the rank's own nodes (each rank generates only what it owns; ghosts come from their
//! owners).

use dea_core::domain::ContactParameters;
use dea_core::failure::FailureParameters;
use dea_core::projectile::{MeshShape, RigidProjectile, RigidShape};
use dea_projectile::elastic::ElasticModel;
use dea_projectile::import::{read_mesh, read_surface};

use crate::deformable::DeformableProjectile;
use dea_core::stability::{
    design_contact_stiffness, run_time_step, stable_time_step, zigzag_step_limit, BENDING_ZIGZAG_LIMIT,
};
use dea_core::weibull::element_strength;
use std::path::Path;
use std::sync::Arc;

use dea_core::failure::BrokenCount;
use dea_core::guides::Guides;
use dea_core::{Domain, DomainError, FibreId, FibreMaterial, FibreSection, Nodes, Rank, Vec3};
use dea_fabric::cell::PeriodicCell;
use dea_fabric::panel::{transition_nodes, CoarseYarns, FineRegion, WovenPanel};
use dea_fabric::relax::{relax, RelaxReport};
use dea_fabric::tiled::TiledPanel;
use dea_fabric::weave::{PlainWeave, UnitCell};
use dea_fabric::weave3d::ThreeDWeave;
use dea_fabric::SectionPacking;
use dea_fabric::{Fabric, StraightFabric};
use dea_io::case::{
    parse_case, Case, CellSource, ProjectileBody, ResolvedCase, ResolvedProjectile, ResolvedTarget, StraightTarget,
    Strength, WovenTarget, PROJECTILE_SIZE_M,
};
use dea_io::cell::read_cell;
use dea_io::checkpoint::{manifest_path, part_path, read_manifest, read_part, GlobalState, NodeState};
use dea_partition::{Method, Partition, PartitionError, SegmentGraph, ShotLine};
use nalgebra::UnitQuaternion;

use crate::checkpoint::RestoreError;
use crate::comm::Comm;
use crate::distributed::Distributed;

/// Gap between the projectile and the nearest fibre surface at time zero [m].
pub const INITIAL_GAP: f64 = 1e-6;

/// Everything about a case that needs no node: material, fabric, laws, projectile, time step.
pub struct Problem {
    /// the fibre's elastic and strength constants
    pub material: FibreMaterial,
    /// the target's description, from which any node is generated
    pub fabric: Fabric,
    /// how the woven target's unit cell was relaxed (none when read from a cell file)
    pub relaxation: Option<RelaxReport>,
    /// how a hybrid woven target's coarse cell was relaxed
    pub coarse_relaxation: Option<RelaxReport>,
    /// fibre–fibre contact and friction parameters
    pub contact: ContactParameters,
    /// failure criterion and strengths
    pub failure: FailureParameters,
    /// how the elements' tensile strengths are drawn
    pub strength: Strength,
    /// the projectile at time zero
    pub projectile: RigidProjectile,
    /// where the projectile's line of flight crosses the target's top (x, y) [m]
    pub aim: [f64; 2],
    /// a deformable projectile's body (the projectile is then its proxy)
    pub deformable: Option<DeformableProjectile>,
    /// [s]
    pub time_step: f64,
    /// the stable step of `run.time_step_safety` that the bending zigzag's bound shortened
    /// (docs/theory.md I11c), none where that bound does not hold [s]
    pub zigzag_shortened: Option<f64>,
    /// each fibre section's rate: its terms fire every this many steps (docs/theory.md T1;
    /// all 1 without `run.multi_rate`) [-]
    pub rates: Vec<u32>,
    /// contact search distance: largest contact diameter plus the skin [m]
    pub reach: f64,
    /// the single-yarn fixture's guides (docs/theory.md F13; none for other targets)
    pub guides: Guides,
    /// what a spring bent at rest stores below its rest angle (docs/theory.md F4b)
    pub rest_angle_law: dea_core::bending::RestAngleLaw,
}

impl Problem {
    /// Layer of each yarn.
    pub fn layer_of_yarn(&self) -> Vec<u32> {
        (0..self.fabric.yarn_count()).map(|y| self.fabric.yarn_layer(y)).collect()
    }

    /// Layers of the target.
    pub fn layers(&self) -> usize {
        (0..self.fabric.yarn_count()).map(|y| self.fabric.yarn_layer(y) as usize + 1).max().unwrap_or(1)
    }

    /// Fibres of the whole target.
    pub fn fibres(&self) -> usize {
        self.fabric.first_fibres().last().copied().unwrap_or(0) as usize
    }
}

/// Why a rank could not be set up.
#[derive(Debug, thiserror::Error)]
pub enum SetupError {
    /// The target cannot be partitioned over the ranks.
    #[error("{0}")]
    Partition(String),
    /// The state as built is not finite or not stable.
    #[error("{0}")]
    Numerical(#[from] DomainError),
    /// a checkpoint that cannot be read or does not fit the case
    #[error("{0}")]
    Checkpoint(String),
    /// a projectile mesh or fabric cell file that cannot be read or is not what it claims
    #[error("{0}")]
    Mesh(String),
    /// a case that parses but describes something that cannot be built (a yarn section too
    /// wide for its spacing)
    #[error("{0}")]
    Case(String),
    /// a unit cell whose relaxation does not converge
    #[error("{0}")]
    Relaxation(String),
}

/// A plain-weave cell: read from its file (then without a report), or generated from its weave
/// and relaxed with the case's contact law. `field` names the case field a weave error is
/// about.
fn relaxed_cell(
    resolved: &ResolvedCase,
    source: &CellSource<PlainWeave>,
    field: &str,
) -> Result<(UnitCell, Option<RelaxReport>), SetupError> {
    let (weave, options) = match source {
        CellSource::File(path) => return read_cell(path).map(|cell| (cell, None)).map_err(SetupError::Mesh),
        CellSource::Generate { weave, relaxation } => (weave, relaxation),
    };
    let material = &resolved.material;
    let mut cell = weave.unit_cell(material).map_err(|e| SetupError::Case(format!("{field}: {e}")))?;
    let report = relax(&mut cell, material, &resolved.law, options)
        .map_err(|e| SetupError::Relaxation(format!("target.relaxation ({field}): {e}")))?;
    Ok((cell, Some(report)))
}

/// Size of the struck layer's periodic unit cell along x and y, where a campaign's scattered
/// aim falls [m], from the weave's spacing or the cell file, without relaxing the cell (the
/// period is the relaxation's boundary, so relaxing keeps it); `None` for straight fibres and
/// yarns.
pub fn aim_cell(case: &Case) -> Result<Option<[f64; 2]>, SetupError> {
    let resolved = case.resolve().map_err(|e| SetupError::Case(e.to_string()))?;
    Ok(match &resolved.target {
        ResolvedTarget::Straight(_) | ResolvedTarget::ThreeDCell { .. } => None,
        ResolvedTarget::Woven(woven) => Some(match &woven.fine {
            CellSource::File(path) => read_cell(path).map_err(SetupError::Mesh)?.periodic.period,
            CellSource::Generate { weave, .. } => [2.0 * weave.yarn_spacing; 2],
        }),
        ResolvedTarget::ThreeDPanel { cell, .. } => Some(match cell {
            CellSource::File(path) => dea_io::cell::read_periodic(path).map_err(SetupError::Mesh)?.1.period,
            CellSource::Generate { weave, .. } => laid_out_cell(weave, &resolved.material)?.period,
        }),
    })
}

/// The 3-D cell `weave` describes, laid out and not yet relaxed.
pub fn laid_out_cell(weave: &ThreeDWeave, material: &FibreMaterial) -> Result<PeriodicCell, SetupError> {
    weave.unit_cell(material).map_err(|e| SetupError::Case(e.in_case()))
}

/// A 3-D woven cell: read from its file (then without a report), or generated from its weave
/// and relaxed with the case's contact law.
fn relaxed_3d_cell(
    resolved: &ResolvedCase,
    source: &CellSource<ThreeDWeave>,
) -> Result<(PeriodicCell, Option<RelaxReport>), SetupError> {
    let (weave, options) = match source {
        CellSource::File(path) => {
            return dea_io::cell::read_periodic(path).map(|(_, cell)| (cell, None)).map_err(SetupError::Mesh);
        }
        CellSource::Generate { weave, relaxation } => (weave, relaxation),
    };
    let mut cell = laid_out_cell(weave, &resolved.material)?;
    let report = relax(&mut cell, &resolved.material, &resolved.law, options)
        .map_err(|e| SetupError::Relaxation(format!("target.relaxation: {e}")))?;
    Ok((cell, Some(report)))
}

/// The relaxed cell of a 3-D weave target: generated and relaxed with the case's contact
/// law, or read from the panel's cell file (then without a report); `None` for other targets.
pub fn three_d_cell(resolved: &ResolvedCase) -> Result<Option<(PeriodicCell, Option<RelaxReport>)>, SetupError> {
    match &resolved.target {
        ResolvedTarget::ThreeDCell { weave, relaxation } => {
            relaxed_3d_cell(resolved, &CellSource::Generate { weave: weave.clone(), relaxation: *relaxation }).map(Some)
        }
        ResolvedTarget::ThreeDPanel { cell, .. } => relaxed_3d_cell(resolved, cell).map(Some),
        _ => Ok(None),
    }
}

/// The unit cell of a woven target (the fine yarns' of a hybrid panel), relaxed with the
/// case's contact law (or read from its cell file, then without a report); `None` for other
/// targets.
pub fn woven_cell(resolved: &ResolvedCase) -> Result<Option<(UnitCell, Option<RelaxReport>)>, SetupError> {
    let ResolvedTarget::Woven(woven) = &resolved.target else {
        return Ok(None);
    };
    relaxed_cell(resolved, &woven.fine, "target.weave").map(Some)
}

/// The coarse yarns' cell of a hybrid woven target, relaxed like the fine one (or read from
/// its file); `None` when the target is not hybrid. Its yarn spacing must be the fine cell's.
pub fn coarse_cell(
    resolved: &ResolvedCase,
    fine: &UnitCell,
) -> Result<Option<(UnitCell, Option<RelaxReport>)>, SetupError> {
    let ResolvedTarget::Woven(WovenTarget { hybrid: Some(hybrid), .. }) = &resolved.target else {
        return Ok(None);
    };
    let (cell, report) = relaxed_cell(resolved, &hybrid.coarse, "target.hybrid")?;
    if cell.yarn_spacing != fine.yarn_spacing || cell.fibres_per_yarn >= fine.fibres_per_yarn {
        return Err(SetupError::Case(format!(
            "target.hybrid.cell_file: the coarse cell ({} fibres per yarn, spacing {:e} m) must have fewer fibres than the fine one ({}) and the same spacing ({:e} m)",
            cell.fibres_per_yarn, cell.yarn_spacing, fine.fibres_per_yarn, fine.yarn_spacing
        )));
    }
    Ok(Some((cell, report)))
}

/// The most nodes a case may have: about 2 PB at the 1.9 kB per node measured
/// (performance.md), beyond any machine, while every rank holds the target's description
/// whole and would run out of memory making it before a single node.
const MOST_NODES: f64 = (1u64 << 40) as f64;

/// The longest Verlet skin a case may ask for, in contact diameters of the fine section.
const MOST_SKIN_IN_DIAMETERS: f64 = 4.0;

/// Refuses a target too large to number or to hold (`field` names its size): `fibres`
/// fibres of at most `nodes_per_fibre` nodes, counted before anything is made. Node and fibre
/// ids are 32-bit.
fn target_fits(field: &str, fibres: f64, nodes_per_fibre: f64) -> Result<(), SetupError> {
    let most_ids = u32::MAX as f64;
    // a NaN count (from an infinite or NaN size) is refused with the rest
    let nodes = fibres * nodes_per_fibre;
    let reason = if nodes_per_fibre.is_nan() || nodes_per_fibre >= most_ids {
        format!("a fibre would have {nodes_per_fibre:.3e} nodes, more than its 32-bit node numbering holds ({most_ids:.3e})")
    } else if fibres.is_nan() || fibres >= most_ids {
        format!("the target would have {fibres:.3e} fibres, more than the 32-bit fibre ids hold ({most_ids:.3e})")
    } else if nodes.is_nan() || nodes > MOST_NODES {
        format!("the target would have {nodes:.3e} nodes, more than the {MOST_NODES:.3e} a case may have (about 2 PB at 1.9 kB per node)")
    } else {
        return Ok(());
    };
    Err(SetupError::Case(format!("{field}: {reason}; a smaller target, or longer elements")))
}

/// Resolves a case ([`Case::resolve`]) and builds its description (reading or generating the
/// projectile's mesh and the fabric's cells).
pub fn problem(case: &Case) -> Result<Problem, SetupError> {
    let resolved = case.resolve().map_err(|e| SetupError::Case(e.to_string()))?;
    let (material, law, strength, shear_strength) =
        (resolved.material.clone(), resolved.law, resolved.strength.clone(), resolved.shear_strength);
    let resolved_shear_measure = resolved.shear_measure;
    let rest_angle_law = resolved.rest_angle_law;
    let guides = match &resolved.target {
        ResolvedTarget::Straight(target) => Guides {
            hold_lateral: target.hold_lateral,
            // each end's friction shared by its fibres' end nodes, as its mass is
            end_friction: target.sliding_ends.map(|(_, friction)| friction / target.fibres_per_yarn as f64),
        },
        _ => Guides::default(),
    };
    let deterministic = match strength {
        Strength::Deterministic(s) => s,
        _ => f64::INFINITY,
    };
    let (mut relaxation, mut coarse_relaxation) = (None, None);
    let fabric = match &resolved.target {
        ResolvedTarget::Straight(StraightTarget {
            layers: None,
            fibres_per_yarn,
            fibre_area,
            length,
            element_length_ratio,
            rectangular_packing,
            sliding_ends,
            hold_lateral: _,
        }) => Fabric::Straight(StraightFabric {
            packing: match rectangular_packing {
                Some(across_per_through) => SectionPacking::Rectangular { across_per_through: *across_per_through },
                None => SectionPacking::Hexagonal,
            },
            clamp_ends: sliding_ends.is_none(),
            end_mass: sliding_ends.map_or(0.0, |(mass, _)| mass),
            ..StraightFabric::single_yarn(
                *length,
                *fibres_per_yarn,
                *fibre_area,
                *element_length_ratio,
                resolved.section_inertia,
                deterministic,
            )
        }),
        ResolvedTarget::Straight(StraightTarget {
            layers: Some((layers, yarns_per_layer)),
            fibres_per_yarn,
            fibre_area,
            length,
            element_length_ratio,
            ..
        }) => Fabric::Straight(StraightFabric::cross_ply(
            *layers,
            *yarns_per_layer,
            *fibres_per_yarn,
            *length,
            *fibre_area,
            *element_length_ratio,
            resolved.section_inertia,
            deterministic,
            &material,
        )),
        ResolvedTarget::Woven(woven) => {
            let (cell, report) = relaxed_cell(&resolved, &woven.fine, "target.weave")?;
            relaxation = report;
            let coarse = match (&woven.hybrid, coarse_cell(&resolved, &cell)?) {
                (Some(hybrid), Some((coarse, report))) => {
                    coarse_relaxation = report;
                    if let FineRegion::Disc { radius } = hybrid.region {
                        if transition_nodes(&cell, &coarse).is_none() {
                            return Err(SetupError::Case(format!(
                                "target.hybrid.fine_radius_m: a fine yarn's fibres cannot end clear of the coarse ones between two crossings ({} fine and {} coarse fibres per yarn, contact diameters {:.1} and {:.1} um, yarn spacing {:.1} um): use more coarse fibres or fine_half_width_m",
                                cell.fibres_per_yarn,
                                coarse.fibres_per_yarn,
                                1e6 * cell.section.contact_diameter,
                                1e6 * coarse.section.contact_diameter,
                                1e6 * cell.yarn_spacing
                            )));
                        }
                        // the crossings nearest the centre lie half a spacing from it each way
                        let nearest = std::f64::consts::FRAC_1_SQRT_2 * cell.yarn_spacing;
                        if radius < nearest {
                            return Err(SetupError::Case(format!(
                                "target.hybrid.fine_radius_m: no crossing lies within {radius} m of the centre (the nearest are {nearest:.3e} m from it), so no yarn would be fine"
                            )));
                        }
                    }
                    Some(CoarseYarns { cell: Arc::new(coarse), fine: hybrid.region })
                }
                _ => None,
            };
            let layout = woven.layout;
            let cells = (layout.side / cell.period()).round().max(1.0);
            let kinds = std::iter::once(&cell).chain(coarse.as_ref().map(|c| &*c.cell));
            let (fibres_per_yarn, nodes_per_period) =
                kinds.fold((0, 0), |(f, n), c| (f.max(c.fibres_per_yarn), n.max(c.nodes_per_period)));
            // two warp and two weft yarns per cell and layer
            target_fits(
                "target.side_m",
                4.0 * cells * layout.layers as f64 * fibres_per_yarn as f64,
                cells * nodes_per_period as f64 + 1.0,
            )?;
            let cells = cells as u32;
            Fabric::Woven(WovenPanel::new(
                Arc::new(cell),
                coarse,
                cells,
                layout.layers as u32,
                layout.layer_gap,
                layout.layer_shift,
                layout.boundary,
                deterministic,
            ))
        }
        ResolvedTarget::ThreeDCell { .. } => {
            return Err(SetupError::Case("target.kind: a three_d_weave_cell is a unit cell for `dea-mpi fabric` to generate and relax; to strike it, tile it with kind three_d_woven_panel".into()));
        }
        ResolvedTarget::ThreeDPanel { cell, layout } => {
            let (cell, report) = relaxed_3d_cell(&resolved, cell)?;
            relaxation = report;
            let tiles = cell.period.map(|p| (layout.side / p).round().max(1.0));
            let most_tiles = tiles[0].max(tiles[1]);
            let nodes_per_period = cell.yarns.iter().map(|y| y.nodes_per_period).max().unwrap_or(0);
            let fibres_per_tile: usize = cell.yarns.iter().map(|y| y.fibres).sum();
            target_fits(
                "target.side_m",
                fibres_per_tile as f64 * most_tiles * layout.layers as f64,
                most_tiles * nodes_per_period as f64 + 1.0,
            )?;
            let tiles = tiles.map(|t| t as u32);
            Fabric::Tiled(TiledPanel::new(
                Arc::new(cell),
                tiles,
                layout.layers as u32,
                layout.layer_gap,
                layout.layer_shift,
                layout.boundary,
                deterministic,
            ))
        }
    };
    if let Fabric::Straight(straight) = &fabric {
        target_fits(
            "target.length_m",
            straight.fibre_total() as f64,
            straight.fibre_length_in_elements().round() + 1.0,
        )?;
    }
    let sections = fabric.sections(&material);
    // the fine section: the one the projectile meets
    let section = &sections[0];
    let largest_contact_diameter = sections.iter().map(|s| s.contact_diameter).fold(0.0, f64::max);
    let contact = ContactParameters {
        law,
        friction_coefficient: resolved.friction_coefficient,
        projectile_friction_coefficient: resolved.projectile_friction_coefficient,
        projectile_friction_spring: resolved.projectile_friction_spring,
        fibre_friction_spring: resolved.fibre_friction_spring,
        skin: case.contact.skin_m.unwrap_or(0.25 * section.contact_diameter),
    };
    // the lists hold every pair within a contact diameter plus the skin, and the projectile's
    // search grid reaches the skin beyond its surface: a skin of metres would never finish
    // (a whole diameter is already slower than the default quarter, performance.md)
    if contact.skin > MOST_SKIN_IN_DIAMETERS * section.contact_diameter {
        return Err(SetupError::Case(format!(
            "contact.skin_m: must be at most {MOST_SKIN_IN_DIAMETERS} contact diameters ({:.3e} m), got {:.3e} m",
            MOST_SKIN_IN_DIAMETERS * section.contact_diameter,
            contact.skin
        )));
    }
    let failure = FailureParameters {
        shear_strength,
        enabled: !matches!(strength, Strength::None),
        shear_measure: resolved_shear_measure,
        tension_measure: resolved.tension_measure,
        unload: resolved.unload,
    };
    let resolved = resolved.projectile.clone();
    // a node overlaps the surface closer than its contact radius, and is a candidate within
    // the skin of that; the seed splits the contact domain into cubes of 1.2-1.5 fibre
    // diameters (§4.2.2)
    let (reach, cell) = (0.5 * largest_contact_diameter + contact.skin, 1.3 * section.contact_diameter);
    let top = fabric.top(&material) + 0.5 * largest_contact_diameter;
    let (projectile, aim, mut deformable) = match resolved.deformable {
        None => {
            let (projectile, aim) = launch(rigid_shape(&resolved.body, reach, cell)?, &resolved, top);
            (projectile, aim, None)
        }
        Some(elastic) => {
            let (body, shape) = deformable_body(
                &resolved,
                (elastic.youngs_modulus, elastic.poisson_ratio, elastic.model),
                reach,
                cell,
                contact.skin,
            )?;
            let (projectile, aim, body) = launch_deformable(body, shape, &resolved, top);
            (projectile, aim, Some(body))
        }
    };
    // a relaxed fabric starts with its crossings pressed in: the contacts may already be
    // deeper than the design strain, and stiffer there
    let starting_strain = match &fabric {
        Fabric::Woven(panel) => 1.25 * panel.largest_overlap_ratio(),
        Fabric::Tiled(panel) => 1.25 * dea_fabric::relax::largest_overlap_ratio(&panel.cell),
        Fabric::Straight(_) => 0.0,
    };
    let stable = stable_time_step(
        &material,
        &sections,
        &contact.law,
        contact.friction_coefficient.max(contact.projectile_friction_coefficient),
        starting_strain,
        case.run.time_step_safety,
    );
    let (mut time_step, shortened_from) = run_time_step(&material, &sections, stable);
    let fibres_step = time_step;
    if let Some(body) = &mut deformable {
        // one layer of fibre nodes, each a contact diameter wide and an element long
        let per_area = (1.0 + contact.projectile_friction_coefficient)
            * design_contact_stiffness(section, &contact.law)
            / (section.contact_diameter * section.element_length);
        let safety = case.run.time_step_safety;
        let whole = safety * body.stable_time_step(per_area);
        if whole < time_step {
            // where the body's small elements would shorten the run's step, they take
            // substeps of their own instead; the contact still bounds the run's step
            let run_step = time_step.min(safety * body.contact_time_step(per_area));
            let substeps = (run_step / (safety * body.body.stable_time_step())).ceil() as u32;
            if substeps > 1 {
                body.substeps = substeps;
                time_step = run_step;
            } else {
                time_step = whole;
            }
        }
    }
    let rates = section_rates(case, &material, &sections, &contact, starting_strain)?;
    let reach = largest_contact_diameter + contact.skin;
    Ok(Problem {
        material,
        fabric,
        relaxation,
        coarse_relaxation,
        contact,
        failure,
        strength,
        projectile,
        aim,
        deformable,
        time_step,
        // a deformable body's substeps may shorten the step further: then its bound holds
        zigzag_shortened: shortened_from.filter(|_| time_step == fibres_step),
        rates,
        reach,
        guides,
        rest_angle_law,
    })
}

/// Each fibre section's rate under `run.multi_rate` (docs/theory.md T1): the largest power of
/// two times the finest section's stable step that stays within its own, each estimated as
/// the run's step is ([`stable_time_step`]); all 1 without it. Refuses a target whose
/// sections would all fire at every step, and intervals that split a coarse step.
fn section_rates(
    case: &Case,
    material: &FibreMaterial,
    sections: &[FibreSection],
    contact: &ContactParameters,
    starting_strain: f64,
) -> Result<Vec<u32>, SetupError> {
    if !case.run.multi_rate {
        return Ok(vec![1; sections.len()]);
    }
    let mu = contact.friction_coefficient.max(contact.projectile_friction_coefficient);
    // each section's step at safety 1, within the bending zigzag's bound taken back to safety 1
    // (the run's step is `safety` times the finest), so no section's zigzag steps past it
    let safety = case.run.time_step_safety;
    let limits: Vec<f64> = sections
        .iter()
        .map(|s| {
            let stable = stable_time_step(material, std::slice::from_ref(s), &contact.law, mu, starting_strain, 1.0);
            stable.min(zigzag_step_limit(material, s) / safety)
        })
        .collect();
    let finest = limits.iter().copied().fold(f64::INFINITY, f64::min);
    let rates = dea_core::multi_rate::rates_for(&limits, finest);
    let largest = rates.iter().copied().max().unwrap_or(1);
    if largest == 1 {
        let steps: Vec<String> = limits.iter().map(|l| format!("{l:.3e} s")).collect();
        return Err(SetupError::Case(format!(
            "run.multi_rate: every fibre section's stable step ({}) is below twice the finest's, so every term would fire at every step; multi-rate stepping needs a hybrid target whose coarse part may step at least twice as long (leave run.multi_rate out)",
            steps.join(", ")
        )));
    }
    let intervals = [
        ("run.history_interval_steps", Some(case.run.history_interval_steps)),
        ("run.snapshot_interval_steps", case.run.snapshot_interval_steps),
        ("run.checkpoint_interval_steps", case.run.checkpoint_interval_steps),
    ];
    for (field, interval) in intervals {
        if let Some(interval) = interval.filter(|n| !n.is_multiple_of(largest as u64)) {
            return Err(SetupError::Case(format!(
                "{field}: with run.multi_rate the coarsest section fires every {largest} steps, and output falls on the instants every section shares: give a multiple of {largest}, got {interval}"
            )));
        }
    }
    Ok(rates)
}

/// A deformable projectile's body at rest and its meshed proxy, the proxy's vertices taken
/// about the body's centre of mass. The cubes follow the moving surface with a margin of
/// one skin.
fn deformable_body(
    resolved: &ResolvedProjectile,
    (youngs_modulus, poisson_ratio, model): (f64, f64, ElasticModel),
    reach: f64,
    cell: f64,
    skin: f64,
) -> Result<(DeformableProjectile, RigidShape), SetupError> {
    let (mesh, source) = match &resolved.body {
        ProjectileBody::Generated { solid, divisions } => {
            (solid.mesh(*divisions), format!("the generated {solid:?} mesh"))
        }
        ProjectileBody::File { path, scale } => {
            let mut mesh = read_mesh(path).map_err(|e| SetupError::Mesh(e.to_string()))?;
            mesh.nodes.iter_mut().for_each(|x| *x *= *scale);
            projectile_spans(path, &mesh.nodes)?;
            (mesh, path.display().to_string())
        }
        ProjectileBody::Analytic(_) => {
            return Err(SetupError::Case(
                "projectile.deformable: a deformable projectile needs a hexahedral mesh".into(),
            ))
        }
    };
    let (vertices, triangles) = mesh.boundary();
    let body = DeformableProjectile::new(mesh, resolved.mass, youngs_modulus, poisson_ratio, model)
        .map_err(|e| SetupError::Mesh(format!("{source}: {e}")))?;
    let (mut shape, _) = MeshShape::new(&vertices, triangles, reach, cell).map_err(|e| surface_error(&source, e))?;
    let (centre, _) = body.body.centre_of_mass();
    let mut surface = Vec::new();
    body.surface_from(&centre, &mut surface);
    shape.set_vertices(&surface);
    shape.surface.set_margin(skin);
    Ok((body, RigidShape::Mesh(Arc::new(shape))))
}

/// [`launch`] for a deformable body: the body's nodes take the launch pose and velocity,
/// and the proxy keeps an unturned frame at the centre of mass (its surface carries the
/// turn).
fn launch_deformable(
    mut body: DeformableProjectile,
    shape: RigidShape,
    resolved: &ResolvedProjectile,
    top: f64,
) -> (RigidProjectile, [f64; 2], DeformableProjectile) {
    let (mut projectile, aim) = launch(shape, resolved, top);
    body.launch(&projectile);
    projectile.orientation = UnitQuaternion::identity();
    let mut surface = Vec::new();
    body.fill_proxy(&mut projectile, &mut surface);
    if let RigidShape::Mesh(mesh) = &mut projectile.shape {
        Arc::make_mut(mesh).set_vertices(&surface);
    }
    (projectile, aim, body)
}

/// Refuses a projectile mesh read from `path` (scaled) whose largest extent lies outside
/// the sizes a projectile may have (`dea_io::case::PROJECTILE_SIZE_M`): a mesh in the wrong
/// unit, whose search grid would not fit in memory.
fn projectile_spans(path: &Path, vertices: &[Vec3]) -> Result<(), SetupError> {
    let (low, high) = dea_core::bounding_box(vertices.iter().copied());
    let extent = (high - low).max();
    let (least, most) = PROJECTILE_SIZE_M;
    if (least..=most).contains(&extent) {
        return Ok(());
    }
    Err(SetupError::Case(format!(
        "projectile.mesh_scale: the scaled mesh {} spans {extent:?} m, and a projectile spans {least:?} to {most:?} m (is the scale the mesh's unit in metres?)",
        path.display()
    )))
}

/// A surface that cannot be used: a fault of its file, or (too large for the contact
/// search against this fibre) of the case, refused before the search is made.
fn surface_error(source: &str, error: dea_core::surface::SurfaceError) -> SetupError {
    match error {
        dea_core::surface::SurfaceError::TooLarge { .. } => SetupError::Case(format!("projectile: {source}: {error}")),
        _ => SetupError::Mesh(format!("{source}: {error}")),
    }
}

/// The projectile's surface: closed form, generated or read from a file (scaled to metres),
/// queried within `reach` through cubes of edge `cell` [m].
fn rigid_shape(body: &ProjectileBody, reach: f64, cell: f64) -> Result<RigidShape, SetupError> {
    let (vertices, triangles, source) = match body {
        ProjectileBody::Analytic(shape) => return Ok(shape.clone()),
        ProjectileBody::Generated { solid, divisions } => {
            let (vertices, triangles) = solid.mesh(*divisions).boundary();
            (vertices, triangles, format!("the generated {solid:?} mesh"))
        }
        ProjectileBody::File { path, scale } => {
            let (vertices, triangles) = read_surface(path).map_err(|e| SetupError::Mesh(e.to_string()))?;
            let vertices: Vec<Vec3> = vertices.iter().map(|v| v * *scale).collect();
            projectile_spans(path, &vertices)?;
            (vertices, triangles, path.display().to_string())
        }
    };
    let (mesh, _) = MeshShape::new(&vertices, triangles, reach, cell).map_err(|e| surface_error(&source, e))?;
    Ok(RigidShape::Mesh(Arc::new(mesh)))
}

/// What `dea-mpi check` reports of a projectile: its shape, mass and launch state, for a
/// meshed one the surface and the density its mass implies, and for a generated one the
/// size of its hexahedral mesh.
pub fn describe_projectile(
    projectile: &RigidProjectile,
    body: &ProjectileBody,
    deformable: Option<&DeformableProjectile>,
) -> serde_json::Value {
    let shape = match &projectile.shape {
        RigidShape::Sphere { radius } => serde_json::json!({ "sphere": { "radius_m": radius } }),
        RigidShape::Cylinder { radius, height, edge_radius } => {
            serde_json::json!({ "cylinder": { "radius_m": radius, "height_m": height, "edge_radius_m": edge_radius } })
        }
        RigidShape::Mesh(mesh) => serde_json::json!({ "mesh": {
            "vertices": mesh.surface.vertices.len(),
            "triangles": mesh.surface.triangles.len(),
            "volume_m3": mesh.volume,
            "implied_density_kg_m3": projectile.mass / mesh.volume,
            "bounding_radius_m": mesh.bounding_radius,
        } }),
    };
    let generated = match body {
        ProjectileBody::Generated { solid, divisions } => {
            let mesh = solid.mesh(*divisions);
            serde_json::json!({ "divisions": divisions, "nodes": mesh.nodes.len(), "hexahedra": mesh.hexes.len() })
        }
        _ => serde_json::Value::Null,
    };
    let elastic = deformable.map_or(serde_json::Value::Null, |d| {
        let m = d.body.material;
        serde_json::json!({ "model": format!("{:?}", m.model), "density_kg_m3": m.density, "youngs_modulus_pa": m.youngs_modulus, "poisson_ratio": m.poisson_ratio, "wave_speed_m_s": m.wave_speed(), "element_time_step_s": d.body.stable_time_step(), "substeps": d.substeps })
    });
    serde_json::json!({
        "shape": shape,
        "generated_mesh": generated,
        "deformable": elastic,
        "mass_kg": projectile.mass,
        "position_m": projectile.position.as_slice(),
        "velocity_m_s": projectile.velocity.as_slice(),
        "orientation_quaternion_wxyz": [projectile.orientation.w, projectile.orientation.i, projectile.orientation.j, projectile.orientation.k],
    })
}

/// The projectile at time zero, and the aim point (x, y) where its centre's line of flight
/// crosses the target's top: along the line of flight `(-sin o, 0, -cos o)` for obliquity
/// `o`, its lowest point `INITIAL_GAP` above the top `top` [m]. The body is turned by the
/// obliquity about y, then yawed about its own x axis.
fn launch(shape: RigidShape, resolved: &ResolvedProjectile, top: f64) -> (RigidProjectile, [f64; 2]) {
    let flight = UnitQuaternion::from_axis_angle(&Vec3::y_axis(), resolved.obliquity);
    let orientation = flight * UnitQuaternion::from_axis_angle(&Vec3::x_axis(), resolved.yaw);
    let direction = flight_direction(resolved.obliquity);
    let below_centre = shape.support(&orientation.inverse_transform_vector(&Vec3::new(0.0, 0.0, -1.0)));
    let travel = (below_centre + INITIAL_GAP) / resolved.obliquity.cos();
    let aim = Vec3::new(resolved.offset[0], resolved.offset[1], top);
    let start = aim - direction * travel;
    (RigidProjectile::new(shape, resolved.mass, start, direction * resolved.speed, orientation), resolved.offset)
}

/// The unit vector of the initial line of flight of a shot at `obliquity` [rad] from the
/// panel's normal: down the normal (-z), turned about y.
pub fn flight_direction(obliquity: f64) -> Vec3 {
    UnitQuaternion::from_axis_angle(&Vec3::y_axis(), obliquity) * Vec3::new(0.0, 0.0, -1.0)
}

/// The yarn-segment graph of a problem, weighted for a shot along its projectile's line.
pub fn segment_graph(problem: &Problem, ranks: usize, segment_positions: Option<u32>) -> SegmentGraph {
    let shot = ShotLine {
        x: problem.aim[0],
        y: problem.aim[1],
        radius: problem.projectile.shape.bounding_radius() + problem.reach,
    };
    let positions =
        segment_positions.unwrap_or_else(|| dea_partition::default_segment_positions(&problem.fabric, ranks));
    dea_partition::segment_graph_at_rates(
        &problem.fabric,
        &problem.material,
        problem.reach,
        Some(shot),
        positions,
        &problem.rates,
    )
}

/// Bytes a rank holds per node of its share: the peak resident set of the 300,010-node
/// bench over its nodes, 545,860 KiB (performance.md, "Memory per node"). The bench's
/// straight yarn lists more pairs per node than a woven panel (the reference shot peaked at
/// 1,369 bytes per node), so the refusals it feeds err on the safe side.
pub const BYTES_PER_NODE: f64 = 1863.0;

/// The memory this process may use [bytes]: the host's, or its control group's limit when
/// that is lower (SLURM and containers set one); `None` when neither can be read.
pub fn memory_limit() -> Option<f64> {
    let host = std::fs::read_to_string("/proc/meminfo")
        .ok()?
        .lines()
        .find_map(|line| line.strip_prefix("MemTotal:")?.trim().strip_suffix("kB")?.trim().parse::<f64>().ok())
        .map(|kb| 1024.0 * kb)?;
    let group =
        std::fs::read_to_string("/sys/fs/cgroup/memory.max").ok().and_then(|text| text.trim().parse::<f64>().ok());
    Some(group.map_or(host, |g| g.min(host)))
}

/// The address space one process may take (`ulimit -v`, RLIMIT_AS) [bytes]; `None` when
/// unlimited.
pub fn address_space_limit() -> Option<f64> {
    let mut limit = libc::rlimit { rlim_cur: 0, rlim_max: 0 };
    // SAFETY: getrlimit writes the struct it is given and nothing else
    let read = unsafe { libc::getrlimit(libc::RLIMIT_AS, &mut limit) } == 0;
    (read && limit.rlim_cur != libc::RLIM_INFINITY).then_some(limit.rlim_cur as f64)
}

/// The memory one of `ranks` ranks needs for its share of `nodes` nodes [bytes].
pub fn share_bytes(nodes: u64, ranks: usize) -> f64 {
    nodes as f64 / ranks as f64 * BYTES_PER_NODE
}

/// Refuses a job whose `ranks_here` ranks on this host could not hold their shares of a
/// target of `nodes` nodes split over `ranks` ranks within `limit` bytes, or whose share
/// alone exceeds one process's address space ([`address_space_limit`]), before the
/// partition and the nodes are made (either would exhaust the memory on the way).
pub fn shares_fit(nodes: u64, ranks: usize, ranks_here: usize, limit: Option<f64>) -> Result<(), SetupError> {
    let per_rank = share_bytes(nodes, ranks);
    let need = format!(
        "its {nodes} nodes need about {:.1} GB on each of the {ranks} ranks they are split over",
        per_rank / 1e9
    );
    share_fits(per_rank, &need, ranks_here, limit)
}

/// After partitioning: refuses a job whose largest share (`largest_stored_nodes`, owned and
/// ghost, of one of `ranks` ranks) would not fit `ranks_here` times in the host's `limit`
/// bytes, or alone in a process's address space. The partition balances stored nodes to
/// within about a tenth of the mean, so this seldom refuses what [`shares_fit`] passed, but
/// the largest share is what a host must hold.
pub fn largest_share_fits(
    largest_stored_nodes: u64,
    ranks: usize,
    ranks_here: usize,
    limit: Option<f64>,
) -> Result<(), SetupError> {
    let bytes = largest_stored_nodes as f64 * BYTES_PER_NODE;
    let need = format!(
        "the partition's largest share, {largest_stored_nodes} owned and ghost nodes of one of the {ranks} ranks, needs about {:.1} GB",
        bytes / 1e9
    );
    share_fits(bytes, &need, ranks_here, limit)
}

/// Whether `ranks_here` ranks of `per_rank` bytes each (`need` says so in words) fit the
/// host's `limit` bytes, and one of them a process's address space.
fn share_fits(per_rank: f64, need: &str, ranks_here: usize, limit: Option<f64>) -> Result<(), SetupError> {
    // the share comes on top of what the process has mapped already (MPI's own segments)
    let mapped = std::fs::read_to_string("/proc/self/statm")
        .ok()
        .and_then(|text| text.split_whitespace().next()?.parse::<f64>().ok())
        .map_or(0.0, |pages| pages * 4096.0);
    if let Some(space) = address_space_limit().filter(|&space| mapped + per_rank > space) {
        return Err(SetupError::Case(format!(
            "target: {need} ({BYTES_PER_NODE} bytes per node, measured), more than the {:.1} GB of address space a process may take here (ulimit -v) beside the {:.1} GB it has mapped already: raise the limit, run on more ranks, or strike a smaller target",
            space / 1e9,
            mapped / 1e9
        )));
    }
    let Some(limit) = limit else { return Ok(()) };
    if per_rank * ranks_here as f64 <= limit {
        return Ok(());
    }
    Err(SetupError::Case(format!(
        "target: {need} ({BYTES_PER_NODE} bytes per node, measured), and the job's {ranks_here} ranks on this host have {:.1} GB between them: run on more hosts or ranks, or strike a smaller target",
        limit / 1e9
    )))
}

/// Rank 0 partitions, every rank receives the result (or the same error). First every rank
/// checks that its host holds its ranks' shares.
fn shared_partition<C: Comm>(
    comm: &C,
    problem: &Problem,
    method: Method,
    segment_positions: Option<u32>,
) -> Result<Partition, SetupError> {
    let fits = shares_fit(problem.fabric.node_count(), comm.size(), comm.ranks_on_host(), memory_limit());
    agree_on(comm, fits, || {
        SetupError::Case(
            "target: another host cannot hold its ranks' shares of it (its rank 0 says how much they need)".into(),
        )
    })?;
    let mut message = Vec::new();
    if comm.rank() == Rank(0) {
        let graph = segment_graph(problem, comm.size(), segment_positions);
        match dea_partition::partition(&graph, comm.size(), method) {
            Ok(partition) => {
                message.push(0);
                // the largest share first: every host checks that it holds its ranks' shares
                let largest = dea_partition::quality(&graph, &partition).largest_stored_nodes;
                message.extend(largest.to_le_bytes());
                message.extend(partition.to_words().iter().flat_map(|w| w.to_le_bytes()));
            }
            Err(e) => {
                message.push(1);
                message.extend(e.to_string().bytes());
            }
        }
    }
    comm.broadcast_bytes(&mut message);
    match message.split_first() {
        Some((0, bytes)) => {
            let words: Vec<u64> =
                bytes.chunks_exact(8).map(|b| u64::from_le_bytes(b.try_into().expect("8 bytes"))).collect();
            let (largest, partition) = words.split_first().expect("rank 0 sends the largest share first");
            let fits = largest_share_fits(*largest, comm.size(), comm.ranks_on_host(), memory_limit());
            agree_on(comm, fits, || {
                SetupError::Case(
                    "target: another host cannot hold its ranks' shares of the partition (its rank 0 says how much they need)"
                        .into(),
                )
            })?;
            Ok(Partition::from_words(partition))
        }
        Some((_, text)) => Err(SetupError::Partition(String::from_utf8_lossy(text).into_owned())),
        None => {
            Err(SetupError::Partition(PartitionError::TooFewSegments { segments: 0, ranks: comm.size() }.to_string()))
        }
    }
}

/// Sets up this rank: partition, own nodes, Weibull strengths, ghosts, initial forces.
pub fn build<C: Comm>(
    case: &Case,
    comm: C,
    method: Method,
    segment_positions: Option<u32>,
) -> Result<Distributed<C>, SetupError> {
    build_adjusted(case, comm, method, segment_positions, |_| {})
}

/// [`build`], with `adjust` applied to the rank's own nodes before the ghosts are fetched
/// (the benchmark squeezes its yarn this way).
pub fn build_adjusted<C: Comm>(
    case: &Case,
    comm: C,
    method: Method,
    segment_positions: Option<u32>,
    adjust: impl FnOnce(&mut Nodes),
) -> Result<Distributed<C>, SetupError> {
    let problem = shared_problem(&comm, case)?;
    let hybrid = matches!(&problem.fabric, Fabric::Woven(panel) if panel.coarse.is_some());
    // said once per process: a campaign's shots share their case's inputs
    static NOTED: std::sync::Once = std::sync::Once::new();
    if comm.rank() == Rank(0) && !case.notes().is_empty() {
        NOTED.call_once(|| {
            for note in case.notes() {
                tracing::warn!("case {:?}: {note}", case.name);
            }
        });
    }
    if let (Fabric::Woven(panel), Rank(0)) = (&problem.fabric, comm.rank()) {
        // a projectile as wide as the free span strikes the holding itself (issue 34: such
        // panels once swallowed their clamped nodes)
        let span = match panel.boundary {
            dea_fabric::panel::Boundary::FixedEdges => panel.side(),
            dea_fabric::panel::Boundary::Clamp { opening_m } => opening_m.min(panel.side()),
        };
        let across = 2.0 * problem.projectile.shape.bounding_radius();
        if across >= span {
            tracing::warn!(
                "case {:?}: the projectile's bounding sphere ({:.1} mm across) is as wide as the panel's free span ({:.1} mm): the fabric is held right beside the projectile, and the outcome says more about the holding than the fabric",
                case.name,
                1e3 * across,
                1e3 * span
            );
        }
        // layers that start apart where the shot strikes are struck one by one
        if panel.layers > 1 && panel.fine_layer_gap() > 0.1 * panel.cell.thickness() {
            tracing::warn!(
                "case {:?}: the coarse yarns are thicker than the fine ones, so the fine region's layers start {:.0} um apart (fine layer {:.0} um thick); choose a coarse fibre count whose relaxed thickness is close to the fine one's (docs/theory.md F8)",
                case.name,
                1e6 * panel.fine_layer_gap(),
                1e6 * panel.cell.thickness()
            );
        }
        let transitions = panel.transition_quality();
        if transitions.area_mismatch > 0.1 || transitions.eccentricity > 0.1 {
            tracing::warn!(
                "case {:?}: where the fine disc's yarns end, a coarse fibre takes up to {:.0} % more or less fine area than its own, or fine ends centred up to {:.0} % of its contact diameter off its axis: the coarse ends bend and part of each wave reflects (one coarse fibre per yarn and fine yarns of full rings, 7 or 19 fibres, avoid both; docs/theory.md F12)",
                case.name,
                100.0 * transitions.area_mismatch,
                100.0 * transitions.eccentricity
            );
        }
    }
    if let (Some(stable), Rank(0)) = (problem.zigzag_shortened, comm.rank()) {
        tracing::info!(
            "case {:?}: the step is {:.3e} s, the bending zigzag's bound (omega dt {BENDING_ZIGZAG_LIMIT}; docs/theory.md I11c), shorter than run.time_step_safety {} gives ({:.3e} s): the elements are short enough for the bending springs to take most of the stiffness",
            case.name,
            problem.time_step,
            case.run.time_step_safety,
            stable
        );
    }
    let mut run = assemble(problem, comm, method, segment_positions, adjust)?;
    match &case.run.settle {
        Some(settle) => {
            run.settle(settle.time_s, settle.damping())?;
        }
        None if hybrid && run.comm.rank() == Rank(0) => {
            tracing::warn!("case {:?}: a hybrid panel starts out of balance where fine and coarse yarns cross; add run.settle (docs/theory.md F8, F9)", case.name);
        }
        None => {}
    }
    Ok(run)
}

/// The rank of a resolved problem: partition, own nodes (`adjust` applied), Weibull
/// strengths, ghosts, initial forces.
pub fn assemble<C: Comm>(
    mut problem: Problem,
    comm: C,
    method: Method,
    segment_positions: Option<u32>,
    adjust: impl FnOnce(&mut Nodes),
) -> Result<Distributed<C>, SetupError> {
    let partition = shared_partition(&comm, &problem, method, segment_positions)?;
    let mut domain = own_domain(&problem, &partition, comm.rank(), adjust);
    let body = take_body(&mut problem, comm.rank());
    if let Strength::Weibull(law, seed) = &problem.strength {
        let (nodes, elements) = (&domain.nodes, &mut domain.elements);
        for i in 0..nodes.n_owned {
            if !nodes.last[i] {
                elements.tensile_strength[i] = element_strength(law, *seed, nodes.gid[i], elements.rest_length[i]);
            }
        }
    }
    let mut run =
        Distributed::new(comm, domain, partition, &problem.fabric.nodes_per_yarn_fibre(), problem.reach, body)?;
    run.layer_of_yarn = problem.layer_of_yarn();
    run.fibres = problem.fibres();
    let (point, direction) = crate::deflection::line_of_flight(&problem.projectile);
    run.locate_back_face(point, direction);
    Ok(run)
}

/// This rank's nodes of `problem` as generated (`adjust` applied), in a domain without
/// ghosts; rank 0 owns the projectile.
pub(crate) fn own_domain(
    problem: &Problem,
    partition: &Partition,
    me: Rank,
    adjust: impl FnOnce(&mut Nodes),
) -> Domain {
    let mut built = problem.fabric.build(&problem.material, |yarn, k| partition.rank_of_position(yarn, k) == me);
    adjust(&mut built.nodes);
    let mut domain = Domain::assemble(
        problem.material.clone(),
        built.sections,
        built.nodes,
        built.elements,
        problem.contact,
        problem.failure,
        Some(problem.projectile.clone()),
        problem.time_step,
    );
    domain.set_ties(built.ties);
    domain.set_rates(problem.rates.clone());
    domain.set_guides(problem.guides);
    domain.bending.rest_law = problem.rest_angle_law;
    // a deformable body is integrated beside the domain (rank 0), not as a rigid body
    domain.owns_projectile = me == Rank(0) && problem.deformable.is_none();
    domain
}

/// The deformable body for this rank: rank 0 integrates it (every rank's proxy shows it).
fn take_body(problem: &mut Problem, me: Rank) -> Option<DeformableProjectile> {
    problem.deformable.take().filter(|_| me == Rank(0))
}

/// A run restored from a checkpoint on this rank.
pub struct Restored<C: Comm> {
    /// the checkpoint's case
    pub case: Case,
    /// this rank's part of the run
    pub run: Distributed<C>,
    /// the checkpoint's whole-run state
    pub global: GlobalState,
}

/// Every rank learns whether any rank failed; all return an error (their own, or
/// `elsewhere` where another rank failed).
fn agree_on<C: Comm, T>(
    comm: &C,
    local: Result<T, SetupError>,
    elsewhere: impl FnOnce() -> SetupError,
) -> Result<T, SetupError> {
    let mut failed = [if local.is_err() { 1.0 } else { 0.0 }];
    comm.max_f64(&mut failed);
    match local {
        Err(e) => Err(e),
        Ok(_) if failed[0] > 0.0 => Err(elsewhere()),
        Ok(value) => Ok(value),
    }
}

/// [`problem`] on every rank, failing together (a mesh file one node cannot read ends the
/// whole job).
pub fn shared_problem<C: Comm>(comm: &C, case: &Case) -> Result<Problem, SetupError> {
    agree_on(comm, problem(case), || SetupError::Mesh("another rank could not read the projectile mesh".into()))
}

fn unreadable_checkpoint() -> SetupError {
    SetupError::Checkpoint("another rank could not read the checkpoint".into())
}

/// Restores a run from a checkpoint directory on this job's ranks (any number of them).
pub fn restore<C: Comm>(directory: &Path, comm: C, method: Method) -> Result<Restored<C>, SetupError> {
    let global = read_manifest(directory).map_err(|e| SetupError::Checkpoint(e.to_string()));
    let global = agree_on(&comm, global, unreadable_checkpoint)?;
    let mut case = parse_case(&global.case_json, &manifest_path(directory).display().to_string())
        .map_err(|e| SetupError::Checkpoint(e.to_string()))?;
    // a checkpoint names how broken elements unload (Case::with_named_choices); one without
    // the name was stepped before the choice existed, when they acted for one more step,
    // and continues so; one without the tension measure or the rest-angle law was stepped
    // before they were named, with the element strain and the cone
    if case.failure.unload.is_none() {
        case.failure.unload = Some(dea_core::failure::Unload::NextStep.name().to_string());
    }
    let case = case.with_earlier_defaults_named();
    let mut problem = shared_problem(&comm, &case)?;
    let partition = shared_partition(&comm, &problem, method, None)?;
    let me = comm.rank();
    let stride = problem.fabric.gid_stride() as u64;
    let owned = |gid: u64| partition.rank_of(FibreId((gid / stride) as u32), (gid % stride) as u32) == me;
    let mut state = NodeState::default();
    let mut read = Ok(());
    for part in 0..global.parts {
        match read_part(&part_path(directory, part)) {
            Ok(rows) if rows.checksum() != global.part_checksums[part as usize] => {
                read = Err(SetupError::Checkpoint(format!(
                    "{}: not the part this checkpoint's manifest was written with (a part of another checkpoint?)",
                    part_path(directory, part).display()
                )));
                break;
            }
            Ok(rows) => state.append_selected(&rows, owned),
            Err(e) => {
                read = Err(SetupError::Checkpoint(e.to_string()));
                break;
            }
        }
    }
    agree_on(&comm, read, unreadable_checkpoint)?;
    let state = state.sorted();
    let mut domain = own_domain(&problem, &partition, me, |_| {});
    let body = take_body(&mut problem, me);
    let mut counts = [state.gid.len() as i64, domain.nodes.n_owned as i64];
    comm.sum_i64(&mut counts);
    if counts[0] != counts[1] || counts[0] as u64 != global.nodes {
        return Err(SetupError::Checkpoint(format!(
            "{}: holds {} nodes, of which {} belong to the case's {} nodes",
            directory.display(),
            global.nodes,
            counts[0],
            counts[1]
        )));
    }
    domain.step = global.step;
    domain.time = global.time;
    if me == Rank(0) {
        domain.broken = BrokenCount { tension: global.broken[0], shear: global.broken[1], combined: global.broken[2] };
    }
    let mut run = Distributed::restore(
        comm,
        domain,
        partition,
        &problem.fabric.nodes_per_yarn_fibre(),
        problem.reach,
        &state,
        &global.projectile,
        body,
    )
    .map_err(|e| match e {
        RestoreError::Numerical(e) => SetupError::Numerical(e),
        RestoreError::Mismatch(m) => SetupError::Checkpoint(format!("{}: {m}", directory.display())),
    })?;
    run.layer_of_yarn = problem.layer_of_yarn();
    run.fibres = problem.fibres();
    let (point, direction) = crate::deflection::line_of_flight(&problem.projectile);
    run.locate_back_face(point, direction);
    run.rebuilds = global.rebuilds;
    run.domain.pairs.builds = global.list_builds;
    Ok(Restored { case, run, global })
}

/// Lowest point of the projectile along z [m].
pub fn projectile_bottom(projectile: &RigidProjectile) -> f64 {
    projectile.position.z - projectile.shape.support(&projectile.orientation.inverse_transform_vector(&-Vec3::z()))
}

/// Highest point of the projectile along z [m].
pub fn projectile_top(projectile: &RigidProjectile) -> f64 {
    projectile.position.z + projectile.shape.support(&projectile.orientation.inverse_transform_vector(&Vec3::z()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use dea_core::stability::bending_zigzag_frequency;
    use dea_io::case::TargetSpec;

    #[test]
    fn an_oblique_yawed_shot_starts_just_above_the_target_on_its_line_of_flight() {
        let shape = RigidShape::Cylinder { radius: 1.7e-3, height: 3.7e-3, edge_radius: 50e-6 };
        let (obliquity, yaw) = (30f64.to_radians(), 10f64.to_radians());
        let resolved = ResolvedProjectile {
            body: ProjectileBody::Analytic(shape.clone()),
            mass: 1e-3,
            speed: 400.0,
            offset: [1e-3, -2e-3],
            obliquity,
            yaw,
            deformable: None,
        };
        let top = 0.5e-3;
        let (projectile, aim) = launch(shape, &resolved, top);
        assert_eq!(aim, [1e-3, -2e-3]);
        // lowest point a gap above the top (to rounding)
        assert!(
            (projectile_bottom(&projectile) - (top + INITIAL_GAP)).abs() < 1e-15,
            "{}",
            projectile_bottom(&projectile)
        );
        // flight tilted towards -x by the obliquity
        let direction = projectile.velocity / 400.0;
        assert!((direction - Vec3::new(-obliquity.sin(), 0.0, -obliquity.cos())).norm() < 1e-15);
        // the centre's line of flight crosses the top at the aim point
        let t = (projectile.position.z - top) / -projectile.velocity.z;
        let crossing = projectile.position + projectile.velocity * t;
        assert!((crossing.x - aim[0]).abs() < 1e-15 && (crossing.y - aim[1]).abs() < 1e-15);
        // the body axis (nose at body -z) is the yaw away from the line of flight
        let nose = projectile.orientation * Vec3::new(0.0, 0.0, -1.0);
        assert!((nose.dot(&direction).acos() - yaw).abs() < 1e-12);
    }

    #[test]
    fn a_target_too_large_to_number_or_hold_or_a_skin_of_metres_is_refused_naming_its_field() {
        let refusal = |case: &Case| problem(case).err().expect("refused").to_string();
        // a 1 km panel: 6.9e14 nodes, refused before its description is made
        // the 10 mm style 706 patch: one woven cell, no hybrid region
        let patch = Path::new(env!("CARGO_MANIFEST_DIR")).join("../cases/km2_706_patch.json");
        let mut panel = dea_io::case::load_case(&patch).unwrap();
        let TargetSpec::WovenPanel { side_m, .. } = &mut panel.target else { unreachable!("the patch is woven") };
        *side_m = 1e3;
        let error = refusal(&panel);
        assert!(error.contains("target.side_m") && error.contains("6.881e14 nodes"), "{error}");
        // a 10 m one is still a case (its nodes are made only rank by rank)
        let TargetSpec::WovenPanel { side_m, .. } = &mut panel.target else { unreachable!() };
        *side_m = 10.0;
        assert_eq!(problem(&panel).expect("a 10 m panel").fabric.node_count(), 68_807_466_816);
        // a 1000 km fibre: more nodes than its 32-bit numbering holds (they wrapped to a
        // shorter fibre before)
        let mut fibre = dea_io::case::default_case();
        fibre.target = TargetSpec::SingleFibre { length_m: 1e6, diameter_m: 50e-6, element_length_ratio: 0.5 };
        let error = refusal(&fibre);
        assert!(error.contains("target.length_m") && error.contains("32-bit node numbering"), "{error}");
        fibre.target = TargetSpec::SingleFibre { length_m: 1e3, diameter_m: 50e-6, element_length_ratio: 0.5 };
        assert_eq!(problem(&fibre).expect("a 1 km fibre").fabric.node_count(), 40_000_001);
        // a skin of metres: the lists and the projectile's search grid would never be made
        fibre.contact.skin_m = Some(5.0);
        let error = refusal(&fibre);
        assert!(error.contains("contact.skin_m: must be at most 4 contact diameters"), "{error}");
        fibre.contact.skin_m = Some(100e-6);
        assert!(problem(&fibre).is_ok(), "two contact diameters");
    }

    #[test]
    fn multi_rate_stepping_is_refused_where_it_would_split_an_output_or_change_nothing() {
        let refusal = |case: &Case| problem(case).err().expect("refused").to_string();
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../cases/hybrid_disc_two_layer_settle.json");
        let mut hybrid = dea_io::case::load_case(&path).unwrap();
        hybrid.run.multi_rate = true;
        assert_eq!(problem(&hybrid).unwrap().rates, vec![1, 2]);
        hybrid.run.history_interval_steps = 25;
        let error = refusal(&hybrid);
        assert!(error.contains("run.history_interval_steps") && error.contains("multiple of 2, got 25"), "{error}");
        hybrid.run.history_interval_steps = 20;
        hybrid.run.checkpoint_interval_steps = Some(7);
        let error = refusal(&hybrid);
        assert!(error.contains("run.checkpoint_interval_steps") && error.contains("got 7"), "{error}");
        hybrid.run.checkpoint_interval_steps = None;
        hybrid.run.snapshot_interval_steps = Some(301);
        assert!(refusal(&hybrid).contains("run.snapshot_interval_steps"));
        // one section: every term would fire at every step
        let patch = Path::new(env!("CARGO_MANIFEST_DIR")).join("../cases/km2_706_patch.json");
        let mut woven = dea_io::case::load_case(&patch).unwrap();
        woven.run.multi_rate = true;
        let error = refusal(&woven);
        assert!(error.contains("run.multi_rate") && error.contains("every term would fire at every step"), "{error}");
        woven.run.multi_rate = false;
        assert_eq!(problem(&woven).unwrap().rates, vec![1]);
    }

    #[test]
    fn the_bending_zigzag_bounds_the_run_step_and_each_sections_rate() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../cases/hybrid_disc_two_layer_settle.json");
        let mut value: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        value["run"]["multi_rate"] = true.into();
        let built = |value: &serde_json::Value| {
            problem(&dea_io::case::parse_case(&value.to_string(), "hybrid.json").unwrap()).unwrap()
        };
        // l0/d 0.5: the stable step holds
        let as_shipped = built(&value);
        assert_eq!((as_shipped.zigzag_shortened, as_shipped.rates.clone()), (None, vec![1, 2]));
        // l0/d 0.125 in the disc: the zigzag's bound, on the run's step and on each section's
        value["target"]["weave"]["element_length_ratio"] = 0.125.into();
        value["target"]["hybrid"]["element_length_ratio"] = 0.5.into();
        value["run"]["history_interval_steps"] = 32.into();
        value["run"]["snapshot_interval_steps"] = 320.into();
        let fine = built(&value);
        let stable = fine.zigzag_shortened.expect("the bound holds at l0/d 0.125");
        assert!(fine.time_step < stable);
        let sections = fine.fabric.sections(&fine.material);
        let zigzag = |(section, rate): (&FibreSection, &u32)| {
            *rate as f64 * fine.time_step * bending_zigzag_frequency(&fine.material, section)
        };
        let products: Vec<f64> = sections.iter().zip(&fine.rates).map(zigzag).collect();
        assert!((products[0] - BENDING_ZIGZAG_LIMIT).abs() < 1e-12, "{products:?}");
        assert!(products.iter().all(|&p| p <= BENDING_ZIGZAG_LIMIT * (1.0 + 1e-12)), "{products:?}");
        assert_eq!(fine.rates, vec![1, 16], "the coarse yarns take more of the shorter steps");
    }

    #[test]
    fn a_host_that_cannot_hold_its_ranks_shares_refuses_the_job() {
        // 1e9 nodes over 64 ranks: 29 GB each; eight of them on a 24 GB host cannot be
        let error = shares_fit(1_000_000_000, 64, 8, Some(24e9)).err().expect("refused").to_string();
        assert!(
            error.contains("29.1 GB on each of the 64 ranks")
                && error.contains("the job's 8 ranks on this host have 24.0 GB"),
            "{error}"
        );
        // over 512 ranks, four to a host: 3.6 GB each, 14.6 GB together
        assert!(shares_fit(1_000_000_000, 512, 4, Some(24e9)).is_ok());
        // no limit known: no refusal
        assert!(shares_fit(1_000_000_000, 1, 1, None).is_ok());
        assert!(memory_limit().is_some_and(|bytes| bytes > 1e9), "this host's memory is read");
    }

    #[test]
    fn the_largest_share_of_the_partition_must_fit_too() {
        // the 28-layer disc panel's largest of 64 shares of session 28 (5,138,942 owned and
        // ghost nodes, 9.6 GB): two to a 24 GB host fit, three do not
        assert!(largest_share_fits(5_138_942, 64, 2, Some(24e9)).is_ok());
        let error = largest_share_fits(5_138_942, 64, 3, Some(24e9)).err().expect("refused").to_string();
        assert!(
            error.contains("largest share, 5138942 owned and ghost nodes of one of the 64 ranks, needs about 9.6 GB")
                && error.contains("the job's 3 ranks on this host have 24.0 GB"),
            "{error}"
        );
    }
}
