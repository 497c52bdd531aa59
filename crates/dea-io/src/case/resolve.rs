//! From a parsed case to the model it describes: every check that parsing alone cannot make,
//! made once, in [`Case::resolve`], which returns the resolved values ([`ResolvedCase`]) that
//! set-up builds from without checking again.

use super::*;
use dea_core::bending::RestAngleLaw;
use dea_core::failure::Unload;
use dea_core::friction::{FibreFrictionSpring, FrictionSpring};
use dea_core::measure::Measure;
use dea_core::shear_gauge::ShearMeasure;
use dea_core::tension_gauge::TensionMeasure;
use dea_fabric::panel::FineRegion;
use dea_fabric::relax::RelaxOptions;

/// The fastest striking speed a case may ask for [m/s]: beyond ballistic speeds, where the
/// contact laws and strengths (quasi-static fits) say nothing.
pub const MOST_STRIKING_SPEED: f64 = 3000.0;

/// The largest friction coefficient a case may ask for [-]: fibre friction lies well below
/// 1, and the stick spring `mu k_n` of a larger one shrinks the stable step in proportion.
pub const MOST_FRICTION_COEFFICIENT: f64 = 2.0;

/// The longest simulated time a case may ask for [s].
pub const LONGEST_END_TIME: f64 = 1e-2;

/// The side of a panel target [m], if the target is one.
fn target_side(target: &ResolvedTarget) -> Option<f64> {
    match target {
        ResolvedTarget::Woven(woven) => Some(woven.layout.side),
        ResolvedTarget::ThreeDPanel { layout, .. } => Some(layout.side),
        _ => None,
    }
}

/// The gauge length of the default shear measure in digital fibre diameters (docs/theory.md I9b).
pub const DEFAULT_SHEAR_GAUGE_DIAMETERS: f64 = 1.0;

/// The longest shear gauge a case may ask for, in fibre diameters: each diameter adds
/// `d / l0` chain ghosts on each side of a rank's nodes, and beyond a few the gauge averages
/// away the bending a projectile's nose imposes.
pub const MOST_SHEAR_GAUGE_DIAMETERS: f64 = 8.0;

/// The gauge length of the tension measure "gauge" in digital fibre diameters, unless a
/// case gives one (docs/theory.md I9c).
pub const DEFAULT_TENSION_GAUGE_DIAMETERS: f64 = 1.0;

/// The tension measure a case that names none gets: the strain over a gauge of one digital
/// fibre diameter (docs/theory.md I9c; the element's own strain, the seed's form, before
/// 2026-12-03).
pub const DEFAULT_TENSION_MEASURE: TensionMeasure = Measure::Gauge { diameters: DEFAULT_TENSION_GAUGE_DIAMETERS };

/// The rest-angle law of a panel whose springs rest bent that names none (docs/theory.md
/// F4b; the seed's cone before 2026-12-03).
pub const DEFAULT_REST_ANGLE_LAW: RestAngleLaw = RestAngleLaw::Smooth;

/// A gauge's length in fibre diameters, `given` at `path` or `default`: positive and at
/// most [`MOST_SHEAR_GAUGE_DIAMETERS`] (for tension too: each diameter adds `d / l0` chain
/// ghosts on each side of a rank's nodes, whichever term reads them).
fn gauge_diameters(path: &str, given: Option<f64>, default: f64) -> Result<f64, CaseError> {
    let diameters = match given {
        None => default,
        Some(d) => positive(path, d)?,
    };
    if diameters > MOST_SHEAR_GAUGE_DIAMETERS {
        return Err(invalid(
            path,
            format!("must be at most {MOST_SHEAR_GAUGE_DIAMETERS} fibre diameters, got {diameters}"),
        ));
    }
    Ok(diameters)
}

/// One term's measure from `failure.<term>_measure` (`name`) and
/// `failure.<term>_gauge_diameters` (`diameters`): `default` when the case names none, a
/// gauge of the given length or else of `gauge_default` diameters, and a gauge length given
/// to the element measure is an error rather than ignored.
fn failure_measure(
    term: &str,
    name: Option<&str>,
    diameters: Option<f64>,
    default: Measure,
    gauge_default: f64,
) -> Result<Measure, CaseError> {
    let (name_path, diameters_path) = (format!("failure.{term}_measure"), format!("failure.{term}_gauge_diameters"));
    let default_name = default.name();
    match name.unwrap_or(default_name) {
        "gauge" => Ok(Measure::Gauge { diameters: gauge_diameters(&diameters_path, diameters, gauge_default)? }),
        "element" => match diameters {
            None => Ok(Measure::Element),
            Some(_) => {
                let default_note = if default_name == "element" { " (the default)" } else { "" };
                Err(invalid(
                    &diameters_path,
                    format!(
                        "applies only to {name_path} \"gauge\"; the \"element\" measure{default_note} has no gauge"
                    ),
                ))
            }
        },
        other => {
            let other_name = if default_name == "element" { "gauge" } else { "element" };
            Err(invalid(&name_path, format!("must be \"{default_name}\" or \"{other_name}\", got \"{other}\"")))
        }
    }
}

/// A case resolved: every value checked and given its default, the material's overrides
/// applied, the weaves made. Set-up builds from this and the case's own fields, and checks
/// only what needs the built fabric: the skin against the fine section's contact diameter, a
/// hybrid disc's transition between two crossings, and the target's size in nodes.
#[derive(Clone, Debug)]
pub struct ResolvedCase {
    /// the fibre material, the preset's with the case's overrides
    pub material: FibreMaterial,
    /// the normal contact law of fibre–fibre and fibre–projectile contact
    pub law: NormalLaw,
    /// inter-fibre friction coefficient mu [-]
    pub friction_coefficient: f64,
    /// the bending model of the sections with mu's weight (5-10) applied
    pub section_inertia: SectionInertia,
    /// fibre–projectile friction coefficient [-]
    pub projectile_friction_coefficient: f64,
    /// how the fibre–projectile friction spring keeps its stretch
    pub projectile_friction_spring: FrictionSpring,
    /// how the fibre–fibre friction spring keeps its stretch
    pub fibre_friction_spring: FibreFrictionSpring,
    /// the elements' tensile strength: none, one value, or Weibull draws
    pub strength: Strength,
    /// fibre shear strength tau_u [Pa] (infinite when failure is off and none is given)
    pub shear_strength: f64,
    /// how the failure criterion measures an element's shear force
    pub shear_measure: ShearMeasure,
    /// how the failure criterion measures an element's tension
    pub tension_measure: TensionMeasure,
    /// when a broken element stops acting
    pub unload: Unload,
    /// what a spring bent at rest stores below its rest angle (docs/theory.md F4b)
    pub rest_angle_law: RestAngleLaw,
    /// the projectile's body, mass, launch and material
    pub projectile: ResolvedProjectile,
    /// the target, with what set-up builds it from
    pub target: ResolvedTarget,
}

/// A target resolved: every size checked, the weaves made.
#[derive(Clone, Debug)]
pub enum ResolvedTarget {
    /// a single fibre, a straight yarn, or layers of straight yarns
    Straight(StraightTarget),
    /// a plain-woven panel, hybrid or not
    Woven(WovenTarget),
    /// a 3-D woven unit cell, for `dea-mpi fabric` to relax (it cannot be struck)
    ThreeDCell {
        /// the weave to lay out
        weave: ThreeDWeave,
        /// how to relax it
        relaxation: RelaxOptions,
    },
    /// a panel tiled from a 3-D woven cell
    ThreeDPanel {
        /// the cell to tile
        cell: CellSource<ThreeDWeave>,
        /// how the panel is stacked and held
        layout: PanelLayout,
    },
}

/// Straight fibres or yarns.
#[derive(Clone, Debug)]
pub struct StraightTarget {
    /// crossed layers and yarns per layer (none: one yarn)
    pub layers: Option<(usize, usize)>,
    /// digital fibres in each yarn
    pub fibres_per_yarn: usize,
    /// each digital fibre's cross-section area: the yarn's over its fibres [m^2]
    pub fibre_area: f64,
    /// [m]
    pub length: f64,
    /// element length over fibre diameter [-]
    pub element_length_ratio: f64,
    /// fibres across the yarn over fibres through it on a square lattice (none: hexagonal
    /// packing) [-]
    pub rectangular_packing: Option<usize>,
    /// each yarn end's sliding mass [kg] and largest friction [N] (none: clamped ends)
    pub sliding_ends: Option<(f64, f64)>,
    /// the fibres are held from spreading across the yarn
    pub hold_lateral: bool,
}

/// A plain-woven panel.
#[derive(Clone, Debug)]
pub struct WovenTarget {
    /// the fine (or only) yarns' cell
    pub fine: CellSource<PlainWeave>,
    /// a hybrid panel's coarse yarns and where the fine ones are
    pub hybrid: Option<HybridTarget>,
    /// how the panel is stacked and held
    pub layout: PanelLayout,
}

/// A hybrid woven panel's coarse part.
#[derive(Clone, Debug)]
pub struct HybridTarget {
    /// the coarse yarns' cell
    pub coarse: CellSource<PlainWeave>,
    /// where the yarns are fine: a band of whole yarns or a disc about the centre
    pub region: FineRegion,
}

/// Where a unit cell comes from: a relaxed cell file, or a weave to generate and relax.
#[derive(Clone, Debug)]
pub enum CellSource<W> {
    /// a cell relaxed before, read from this file
    File(std::path::PathBuf),
    /// the weave to lay out, and how to relax it
    Generate {
        /// the weave
        weave: W,
        /// the relaxation's tolerance, iterations and springs at rest
        relaxation: RelaxOptions,
    },
}

/// How a panel is stacked and held.
#[derive(Clone, Copy, Debug)]
pub struct PanelLayout {
    /// [m]
    pub side: f64,
    /// layers, struck first at the top
    pub layers: usize,
    /// [m]
    pub layer_gap: f64,
    /// each layer's shift against the one above (x, y) [m]
    pub layer_shift: [f64; 2],
    /// what holds the panel: fixed edges or a clamp
    pub boundary: Boundary,
}

/// What `notes` says of a case that draws Weibull strengths.
pub const UNSOURCED_WEIBULL: &str = "failure.weibull: no published KM2 Weibull parameters could be read for this project (docs/theory.md I12), so these are unsourced: treat the results as a sensitivity study of strength scatter, not a prediction";

impl Case {
    /// Inputs the case uses that have no published source (docs/theory.md I12), one line each;
    /// `check` prints them and a run logs them.
    pub fn notes(&self) -> Vec<&'static str> {
        let mut notes = Vec::new();
        if self.failure.mode == "weibull" {
            notes.push(UNSOURCED_WEIBULL);
        }
        notes
    }

    /// Material with overrides applied.
    pub(super) fn material(&self) -> Result<FibreMaterial, CaseError> {
        let m = &self.material;
        let mut material = match m.preset.as_str() {
            "kevlar_km2" => FibreMaterial::kevlar_km2(),
            other => {
                return Err(invalid("material.preset", format!("unknown preset {other:?}; known: \"kevlar_km2\"")))
            }
        };
        if let Some(v) = m.longitudinal_modulus_pa {
            // from soft polymer fibres (0.1 GPa) to carbon nanotubes (2 TPa)
            material.longitudinal_modulus = super::ranged("material.longitudinal_modulus_pa", v, 1e8, 2e12)?;
        }
        if let Some(v) = m.transverse_modulus_pa {
            material.transverse_modulus = super::ranged("material.transverse_modulus_pa", v, 1e6, 2e12)?;
        }
        if let Some(v) = m.density_kg_m3 {
            // from foams to tungsten
            material.density = super::ranged("material.density_kg_m3", v, 100.0, 25_000.0)?;
        }
        if let Some(v) = m.compressive_stiffness_ratio {
            if !(0.0..=1.0).contains(&v) {
                return Err(invalid("material.compressive_stiffness_ratio", format!("must be in [0, 1], got {v}")));
            }
            material.compressive_stiffness_ratio = v;
        }
        if let Some(v) = m.filament_diameter_m {
            // from nanofibres (0.1 um) to monofilaments (1 mm)
            material.filament_diameter = super::ranged("material.filament_diameter_m", v, 1e-7, 1e-3)?;
        }
        Ok(material)
    }

    /// Normal contact law.
    pub(super) fn normal_law(&self, material: &FibreMaterial) -> Result<NormalLaw, CaseError> {
        match self.contact.law.as_str() {
            "elastic" => Ok(NormalLaw::Elastic { transverse_modulus: material.transverse_modulus }),
            "elasto_plastic_km2" => Ok(NormalLaw::ElastoPlasticKm2),
            other => Err(invalid(
                "contact.law",
                format!("unknown law {other:?}; known: \"elastic\", \"elasto_plastic_km2\""),
            )),
        }
    }

    /// Strength model.
    pub(super) fn strength(&self) -> Result<Strength, CaseError> {
        let f = &self.failure;
        match f.mode.as_str() {
            "none" => Ok(Strength::None),
            "deterministic" => Ok(Strength::Deterministic(positive(
                "failure.tensile_strength_pa",
                required("failure.tensile_strength_pa", f.tensile_strength_pa)?,
            )?)),
            "weibull" => {
                let w = f
                    .weibull
                    .as_ref()
                    .ok_or_else(|| invalid("failure.weibull", "is required when failure.mode is \"weibull\""))?;
                let second = match (w.shape_2, w.scale_2_pa) {
                    (None, None) => None,
                    (Some(shape), Some(scale)) => Some(WeibullMode {
                        shape: positive("failure.weibull.shape_2", shape)?,
                        scale: positive("failure.weibull.scale_2_pa", scale)?,
                    }),
                    _ => return Err(invalid("failure.weibull", "shape_2 and scale_2_pa go together")),
                };
                let law = WeibullStrength {
                    gauge_length: positive("failure.weibull.gauge_length_m", w.gauge_length_m)?,
                    first: WeibullMode {
                        shape: positive("failure.weibull.shape_1", w.shape_1)?,
                        scale: positive("failure.weibull.scale_1_pa", w.scale_1_pa)?,
                    },
                    second,
                };
                Ok(Strength::Weibull(law, f.seed))
            }
            other => Err(invalid(
                "failure.mode",
                format!("unknown mode {other:?}; known: \"none\", \"deterministic\", \"weibull\""),
            )),
        }
    }

    /// Shear strength tau_u [Pa].
    pub(super) fn shear_strength(&self) -> Result<f64, CaseError> {
        match self.failure.mode.as_str() {
            "none" => Ok(self.failure.shear_strength_pa.unwrap_or(f64::INFINITY)),
            _ => positive(
                "failure.shear_strength_pa",
                required("failure.shear_strength_pa", self.failure.shear_strength_pa)?,
            ),
        }
    }

    /// How the fibre–projectile friction spring keeps its stretch: "rotating" unless the seed's
    /// "anchored" is asked for.
    pub fn projectile_friction_spring(&self) -> Result<FrictionSpring, CaseError> {
        match self.contact.projectile_friction_spring.as_deref() {
            None | Some("rotating") => Ok(FrictionSpring::Rotating),
            Some("anchored") => Ok(FrictionSpring::Anchored),
            Some(other) => Err(invalid(
                "contact.projectile_friction_spring",
                format!("must be \"rotating\" or \"anchored\", got \"{other}\""),
            )),
        }
    }

    /// How the fibre–fibre friction spring keeps its stretch: the seed's "anchored" unless
    /// "projected" is asked for.
    pub fn fibre_friction_spring(&self) -> Result<FibreFrictionSpring, CaseError> {
        let path = "contact.fibre_friction_spring";
        match self.contact.fibre_friction_spring.as_deref() {
            None | Some("anchored") => Ok(FibreFrictionSpring::Anchored),
            Some("projected") => Ok(FibreFrictionSpring::Projected),
            Some("rotating") => Err(invalid(
                path,
                "must be \"anchored\" or \"projected\": the fibre–fibre lists keep one anchor per pair and no stretch, which \"rotating\" needs; \"projected\" is its one-anchor form".to_string(),
            )),
            Some(other) => Err(invalid(path, format!("must be \"anchored\" or \"projected\", got \"{other}\""))),
        }
    }

    /// The rest-angle law a woven panel names, and whether its springs may rest bent (a
    /// generated weave "as_woven", or a cell file, which carries its rest angles whichever
    /// way it was relaxed); `None` for a target without such a field.
    fn rest_angle_law_field(&self) -> Option<(&Option<String>, bool)> {
        match &self.target {
            TargetSpec::WovenPanel { weave, cell_file, rest_angle_law, .. } => {
                Some((rest_angle_law, cell_file.is_some() || weave.bending_at_rest != BendingAtRest::Straight))
            }
            TargetSpec::ThreeDWovenPanel { weave, rest_angle_law, .. } => Some((
                rest_angle_law,
                weave.as_ref().is_none_or(|w| w.bending_at_rest != BendingAtRest::Straight),
            )),
            _ => None,
        }
    }

    /// The rest-angle law the case names, if its target takes the field and names one.
    pub fn named_rest_angle_law(&self) -> Option<&str> {
        self.rest_angle_law_field().and_then(|(law, _)| law.as_deref())
    }

    /// Whether the target has springs bent at rest, for which `target.rest_angle_law` says
    /// something (elsewhere every spring rests straight and the laws coincide).
    pub fn takes_rest_angle_law(&self) -> bool {
        self.rest_angle_law_field().is_some_and(|(_, bent)| bent)
    }

    /// What a spring bent at rest stores below its rest angle: a woven panel's
    /// `target.rest_angle_law`, "smooth" unless the seed's "cone" is asked for
    /// (docs/theory.md F4b). Where every spring rests straight the two coincide, nothing is
    /// named and the law is reported as "cone"; a choice there is an error rather than a
    /// setting without effect.
    pub fn rest_angle_law(&self) -> Result<RestAngleLaw, CaseError> {
        let path = "target.rest_angle_law";
        let Some((chosen, bent)) = self.rest_angle_law_field() else { return Ok(RestAngleLaw::Cone) };
        let law = match chosen.as_deref() {
            None if bent => return Ok(DEFAULT_REST_ANGLE_LAW),
            None => return Ok(RestAngleLaw::Cone),
            Some("cone") => RestAngleLaw::Cone,
            Some("smooth") => RestAngleLaw::Smooth,
            Some(other) => return Err(invalid(path, format!("must be \"smooth\" or \"cone\", got \"{other}\""))),
        };
        if !bent {
            return Err(invalid(
                path,
                format!("\"{}\" says how a spring bent at rest behaves below its rest angle, but target.weave.bending_at_rest is \"straight\": every spring rests straight; leave rest_angle_law out, or set bending_at_rest to \"as_woven\"", law.name()),
            ));
        }
        Ok(law)
    }

    /// The case with the model choices whose defaults have changed named where it left them
    /// to the default: `failure.unload`, `failure.tension_measure` and, where springs rest
    /// bent, `target.rest_angle_law`. A case that names the defaults then compares equal to
    /// one that leaves them unsaid (`run --restart` with a case file), and a checkpoint or a
    /// campaign's provenance that stores it says what it was stepped with under any later
    /// default (`run::naming_choices`).
    pub fn with_named_choices(&self) -> Case {
        let mut case = self.clone();
        case.failure.unload.get_or_insert_with(|| Unload::AtBreak.name().to_string());
        case.failure.tension_measure.get_or_insert_with(|| DEFAULT_TENSION_MEASURE.name().to_string());
        if self.takes_rest_angle_law() {
            if let TargetSpec::WovenPanel { rest_angle_law, .. } | TargetSpec::ThreeDWovenPanel { rest_angle_law, .. } =
                &mut case.target
            {
                rest_angle_law.get_or_insert_with(|| DEFAULT_REST_ANGLE_LAW.name().to_string());
            }
        }
        case
    }

    /// A case stored by a binary that did not yet name `failure.tension_measure` and
    /// `target.rest_angle_law` (a checkpoint's or a campaign provenance's, written before
    /// 2026-12-03): where it left them unsaid it was stepped with the element strain and the
    /// cone, the defaults of that time, and this names them so.
    pub fn with_earlier_defaults_named(&self) -> Case {
        let mut case = self.clone();
        case.failure.tension_measure.get_or_insert_with(|| Measure::Element.name().to_string());
        if self.takes_rest_angle_law() {
            if let TargetSpec::WovenPanel { rest_angle_law, .. } | TargetSpec::ThreeDWovenPanel { rest_angle_law, .. } =
                &mut case.target
            {
                rest_angle_law.get_or_insert_with(|| RestAngleLaw::Cone.name().to_string());
            }
        }
        case
    }

    /// The case with `other`'s run length: its end time and checkpoint intervals. They decide
    /// when a run stops and when it saves itself, never how it moves (docs/theory.md V1).
    fn with_run_length_of(&self, other: &Case) -> Case {
        let mut case = self.clone();
        case.run.end_time_s = other.run.end_time_s;
        case.run.checkpoint_interval_steps = other.run.checkpoint_interval_steps;
        case.run.checkpoint_interval_minutes = other.run.checkpoint_interval_minutes;
        case
    }

    /// The case a checkpoint of this case continues under when `asked` for: this case with
    /// `asked`'s run length, so a shot undecided at its end time runs on to a later one
    /// (`run --restart` with a case file, a campaign shot resumed after the campaign's end
    /// time was raised). `Err` names the first field, other than the run length and a
    /// choice one names and the other leaves to the same default, in which the two differ:
    /// such a checkpoint does not continue.
    pub fn continued_by(&self, asked: &Case) -> Result<Case, String> {
        let continued = self.with_run_length_of(asked);
        let value = |case: &Case| serde_json::to_value(case.with_named_choices()).expect("a case serialises");
        match super::first_difference(&value(&continued), &value(asked), "") {
            Some(field) => Err(field),
            None => Ok(continued),
        }
    }

    /// When a broken element stops acting: at its break unless "next_step" is asked for.
    pub fn unload(&self) -> Result<Unload, CaseError> {
        match self.failure.unload.as_deref() {
            None => Ok(Unload::AtBreak),
            Some(name) => Unload::from_name(name).ok_or_else(|| {
                invalid("failure.unload", format!("must be \"at_break\" or \"next_step\", got \"{name}\""))
            }),
        }
    }

    /// The shear measure of the failure criterion: the gauge of `shear_gauge_diameters`
    /// (default 1) digital fibre diameters unless "element" is asked for.
    pub(super) fn shear_measure(&self) -> Result<ShearMeasure, CaseError> {
        let (name, diameters) = (self.failure.shear_measure.as_deref(), self.failure.shear_gauge_diameters);
        let gauge = DEFAULT_SHEAR_GAUGE_DIAMETERS;
        failure_measure("shear", name, diameters, Measure::Gauge { diameters: gauge }, gauge)
    }

    /// The tension measure of the failure criterion: the gauge of `tension_gauge_diameters`
    /// (default 1) digital fibre diameters unless the seed's "element" is asked for.
    pub(super) fn tension_measure(&self) -> Result<TensionMeasure, CaseError> {
        let (name, diameters) = (self.failure.tension_measure.as_deref(), self.failure.tension_gauge_diameters);
        failure_measure("tension", name, diameters, DEFAULT_TENSION_MEASURE, DEFAULT_TENSION_GAUGE_DIAMETERS)
    }

    /// Projectile resolved from its preset or explicit shape.
    pub(super) fn projectile(&self) -> Result<ResolvedProjectile, CaseError> {
        let p = &self.projectile;
        let divisions = match p.mesh_divisions {
            Some(n) if !(2..=64).contains(&n) => {
                return Err(invalid("projectile.mesh_divisions", format!("must lie in 2..=64, got {n}")))
            }
            n => n,
        };
        let mesh_or = |shape: RigidShape, solid: Solid| match divisions {
            Some(divisions) => ProjectileBody::Generated { solid, divisions },
            None => ProjectileBody::Analytic(shape),
        };
        let fsp = |dimensions: FspDimensions| {
            dimensions.check().map_err(|e| invalid("projectile", e))?;
            finer_than_mesh_allows("projectile.flat_edge_radius_m", dimensions.flat_edge_radius, dimensions.diameter)?;
            finer_than_mesh_allows("projectile.edge_radius_m", dimensions.rim_edge_radius, dimensions.diameter)?;
            Ok(ProjectileBody::Generated {
                solid: Solid::Fsp(dimensions),
                divisions: divisions.unwrap_or(DEFAULT_FSP_DIVISIONS),
            })
        };
        let mass = |default: Option<f64>| match (p.mass_kg, default) {
            (Some(m), _) => ranged("projectile.mass_kg", m, PROJECTILE_MASS_KG.0, PROJECTILE_MASS_KG.1),
            (None, Some(m)) => Ok(m),
            (None, None) => required("projectile.mass_kg", None),
        };
        const PRESETS: &str = "known: \"fsp_17_grain\", \"table_4_2_sphere\", \"table_4_2_rcc\"";
        let (body, mass) = match (&p.preset, &p.shape) {
            (Some(_), Some(_)) => return Err(invalid("projectile", "give either preset or shape, not both")),
            (None, None) => return Err(invalid("projectile", format!("give a preset ({PRESETS}) or a shape"))),
            (Some(name), None) => match name.as_str() {
                "fsp_17_grain" => (fsp(FspDimensions::SEVENTEEN_GRAIN)?, mass(Some(FSP_17_GRAIN_MASS))?),
                "table_4_2_sphere" => {
                    let (shape, m) = table_4_2_sphere();
                    let RigidShape::Sphere { radius } = shape else { unreachable!() };
                    (mesh_or(shape, Solid::Sphere { radius }), mass(Some(m))?)
                }
                "table_4_2_rcc" => {
                    let (shape, m) = table_4_2_rcc();
                    let RigidShape::Cylinder { radius, height, edge_radius } = shape else { unreachable!() };
                    (mesh_or(shape, Solid::Cylinder { radius, height, edge_radius }), mass(Some(m))?)
                }
                other => return Err(invalid("projectile.preset", format!("unknown preset {other:?}; {PRESETS}"))),
            },
            (None, Some(kind)) => {
                let diameter =
                    || projectile_size("projectile.diameter_m", required("projectile.diameter_m", p.diameter_m)?);
                let height = || projectile_size("projectile.height_m", required("projectile.height_m", p.height_m)?);
                let body = match kind.as_str() {
                    "sphere" => {
                        let radius = 0.5 * diameter()?;
                        mesh_or(RigidShape::Sphere { radius }, Solid::Sphere { radius })
                    }
                    "cylinder" => {
                        let (diameter, height) = (diameter()?, height()?);
                        let edge = edge_radius(
                            "projectile.edge_radius_m",
                            required("projectile.edge_radius_m", p.edge_radius_m)?,
                        )?;
                        if edge > 0.5 * diameter.min(height) {
                            return Err(invalid(
                                "projectile.edge_radius_m",
                                format!("must not exceed half the diameter and half the height, got {edge}"),
                            ));
                        }
                        finer_than_mesh_allows("projectile.edge_radius_m", edge, diameter)?;
                        let radius = 0.5 * diameter;
                        mesh_or(
                            RigidShape::Cylinder { radius, height, edge_radius: edge },
                            Solid::Cylinder { radius, height, edge_radius: edge },
                        )
                    }
                    "fsp" => {
                        let standard = FspDimensions::SEVENTEEN_GRAIN;
                        let or = |path: &str,
                                  value: Option<f64>,
                                  default: f64,
                                  check: fn(&str, f64) -> Result<f64, CaseError>| {
                            value.map_or(Ok(default), |v| check(path, v))
                        };
                        fsp(FspDimensions {
                            diameter: or("projectile.diameter_m", p.diameter_m, standard.diameter, projectile_size)?,
                            length: or("projectile.height_m", p.height_m, standard.length, projectile_size)?,
                            flat_width: or(
                                "projectile.flat_width_m",
                                p.flat_width_m,
                                standard.flat_width,
                                projectile_size,
                            )?,
                            bevel_angle: or(
                                "projectile.bevel_angle_deg",
                                p.bevel_angle_deg,
                                standard.bevel_angle.to_degrees(),
                                positive,
                            )?
                            .to_radians(),
                            flat_edge_radius: or(
                                "projectile.flat_edge_radius_m",
                                p.flat_edge_radius_m,
                                standard.flat_edge_radius,
                                edge_radius,
                            )?,
                            rim_edge_radius: or(
                                "projectile.edge_radius_m",
                                p.edge_radius_m,
                                standard.rim_edge_radius,
                                edge_radius,
                            )?,
                        })?
                    }
                    "file" => {
                        let path = required("projectile.mesh_file", p.mesh_file.clone())?;
                        let scale = p.mesh_scale.map_or(Ok(1.0), |s| positive("projectile.mesh_scale", s))?;
                        ProjectileBody::File { path, scale }
                    }
                    other => {
                        return Err(invalid(
                            "projectile.shape",
                            format!("unknown shape {other:?}; known: \"sphere\", \"cylinder\", \"fsp\", \"file\""),
                        ))
                    }
                };
                (body, mass(None)?)
            }
        };
        // a field the shape does not use is a mistake, not something to ignore
        let kind = p.shape.as_deref().unwrap_or("preset");
        let uses = |field: &str| match kind {
            "sphere" => matches!(field, "diameter_m" | "mesh_divisions"),
            "cylinder" => matches!(field, "diameter_m" | "height_m" | "edge_radius_m" | "mesh_divisions"),
            "fsp" => !matches!(field, "mesh_file" | "mesh_scale"),
            "file" => matches!(field, "mesh_file" | "mesh_scale"),
            _ => field == "mesh_divisions",
        };
        let given = [
            ("diameter_m", p.diameter_m.is_some()),
            ("height_m", p.height_m.is_some()),
            ("edge_radius_m", p.edge_radius_m.is_some()),
            ("flat_width_m", p.flat_width_m.is_some()),
            ("bevel_angle_deg", p.bevel_angle_deg.is_some()),
            ("flat_edge_radius_m", p.flat_edge_radius_m.is_some()),
            ("mesh_divisions", p.mesh_divisions.is_some()),
            ("mesh_file", p.mesh_file.is_some()),
            ("mesh_scale", p.mesh_scale.is_some()),
        ];
        if let Some((field, _)) = given.iter().find(|&&(field, set)| set && !uses(field)) {
            return Err(invalid(&format!("projectile.{field}"), format!("does not apply to {kind} projectiles")));
        }
        let angle = |path: &str, degrees: f64| {
            if degrees.is_finite() && degrees.abs() < 80.0 {
                Ok(degrees.to_radians())
            } else {
                Err(invalid(path, format!("must lie within ±80 degrees, got {degrees}")))
            }
        };
        let mut deformable = None;
        if let Some(d) = &p.deformable {
            let youngs_modulus = positive("projectile.deformable.youngs_modulus_pa", d.youngs_modulus_pa)?;
            let model = d.model()?;
            if !(0.0..0.5).contains(&d.poisson_ratio) {
                return Err(invalid(
                    "projectile.deformable.poisson_ratio",
                    format!("must lie in [0, 0.5), got {}", d.poisson_ratio),
                ));
            }
            let hexahedra = match &body {
                ProjectileBody::Generated { .. } => true,
                ProjectileBody::File { path, .. } => path
                    .extension()
                    .and_then(|e| e.to_str())
                    .is_some_and(|e| matches!(e.to_ascii_lowercase().as_str(), "msh" | "inp")),
                ProjectileBody::Analytic(_) => false,
            };
            if !hexahedra {
                return Err(invalid("projectile.deformable", "a deformable projectile needs a hexahedral mesh: mesh_divisions, shape \"fsp\", or a .msh/.inp file"));
            }
            deformable = Some(ElasticBody { youngs_modulus, poisson_ratio: d.poisson_ratio, model });
        }
        Ok(ResolvedProjectile {
            deformable,
            body,
            mass,
            speed: ranged("projectile.velocity_m_s", p.velocity_m_s, 0.0, MOST_STRIKING_SPEED)?,
            offset: p.offset_m,
            obliquity: angle("projectile.obliquity_deg", p.obliquity_deg)?,
            yaw: angle("projectile.yaw_deg", p.yaw_deg)?,
        })
    }

    /// Checks every field that parsing alone cannot, once, and returns what they resolve to:
    /// the model set-up builds from, with nothing left to check or to default.
    pub fn resolve(&self) -> Result<ResolvedCase, CaseError> {
        let material = self.material()?;
        let law = self.normal_law(&material)?;
        let strength = self.strength()?;
        let shear_strength = self.shear_strength()?;
        let shear_measure = self.shear_measure()?;
        let tension_measure = self.tension_measure()?;
        let unload = self.unload()?;
        let projectile_friction_spring = self.projectile_friction_spring()?;
        let fibre_friction_spring = self.fibre_friction_spring()?;
        let rest_angle_law = self.rest_angle_law()?;
        let projectile = self.projectile()?;
        let friction_coefficient =
            ranged("contact.friction_coefficient", self.contact.friction_coefficient, 0.0, MOST_FRICTION_COEFFICIENT)?;
        // the friction coefficient weighs the bending rigidity (5-10) here, once
        let section_inertia = self.bending.with_friction(friction_coefficient);
        let target = match &self.target {
            TargetSpec::SingleFibre { length_m, diameter_m, element_length_ratio } => {
                positive("target.length_m", *length_m)?;
                super::fibre_diameter("target.diameter_m", *diameter_m)?;
                ratio("target.element_length_ratio", *element_length_ratio)?;
                ResolvedTarget::Straight(StraightTarget {
                    layers: None,
                    fibres_per_yarn: 1,
                    fibre_area: std::f64::consts::PI * diameter_m * diameter_m / 4.0,
                    length: *length_m,
                    element_length_ratio: *element_length_ratio,
                    rectangular_packing: None,
                    sliding_ends: None,
                    hold_lateral: false,
                })
            }
            TargetSpec::StraightYarn {
                yarn,
                fibres_per_yarn,
                length_m,
                element_length_ratio,
                packing,
                ends,
                hold_lateral,
            } => {
                let fibre_area = yarn_area(yarn)? / *fibres_per_yarn as f64;
                fibre_count(*fibres_per_yarn)?;
                positive("target.length_m", *length_m)?;
                ratio("target.element_length_ratio", *element_length_ratio)?;
                let rectangular_packing = match packing {
                    None | Some(YarnPackingSpec::Hexagonal) => None,
                    Some(YarnPackingSpec::Rectangular { across_per_through }) => {
                        let path = "target.packing.across_per_through";
                        if !(1..=400).contains(across_per_through) {
                            return Err(invalid(path, format!("must be in 1..=400, got {across_per_through}")));
                        }
                        let through = (1..=20).find(|t| across_per_through * t * t == *fibres_per_yarn);
                        if through.is_none() {
                            return Err(invalid(
                                path,
                                format!(
                                    "{fibres_per_yarn} fibres do not fill rows of {across_per_through} times as many fibres across as through (target.fibres_per_yarn must be {across_per_through} times a square: {})",
                                    (1..=4).map(|t| (across_per_through * t * t).to_string()).collect::<Vec<_>>().join(", ")
                                ),
                            ));
                        }
                        Some(*across_per_through)
                    }
                };
                let sliding_ends = match ends {
                    None | Some(YarnEndsSpec::Clamped) => None,
                    Some(YarnEndsSpec::Sliding { mass_kg, friction_force_n }) => Some((
                        positive("target.ends.mass_kg", *mass_kg)?,
                        non_negative("target.ends.friction_force_n", *friction_force_n)?,
                    )),
                };
                ResolvedTarget::Straight(StraightTarget {
                    layers: None,
                    fibres_per_yarn: *fibres_per_yarn,
                    fibre_area,
                    length: *length_m,
                    element_length_ratio: *element_length_ratio,
                    rectangular_packing,
                    sliding_ends,
                    hold_lateral: *hold_lateral,
                })
            }
            TargetSpec::StraightYarnLayers {
                yarn,
                fibres_per_yarn,
                layers,
                yarns_per_layer,
                length_m,
                element_length_ratio,
            } => {
                let fibre_area = yarn_area(yarn)? / *fibres_per_yarn as f64;
                fibre_count(*fibres_per_yarn)?;
                layer_count(*layers)?;
                if *yarns_per_layer < 1 || *yarns_per_layer > 10_000 {
                    return Err(invalid(
                        "target.yarns_per_layer",
                        format!("must be in 1..=10000, got {yarns_per_layer}"),
                    ));
                }
                positive("target.length_m", *length_m)?;
                ratio("target.element_length_ratio", *element_length_ratio)?;
                ResolvedTarget::Straight(StraightTarget {
                    layers: Some((*layers, *yarns_per_layer)),
                    fibres_per_yarn: *fibres_per_yarn,
                    fibre_area,
                    length: *length_m,
                    element_length_ratio: *element_length_ratio,
                    rectangular_packing: None,
                    sliding_ends: None,
                    hold_lateral: false,
                })
            }
            TargetSpec::WovenPanel {
                weave,
                cell_file,
                side_m,
                layers,
                layer_gap_m,
                layer_shift_m,
                boundary,
                relaxation,
                hybrid,
                rest_angle_law: _,
            } => {
                if cell_file.is_some() && *weave != WeaveSpec::default() {
                    return Err(invalid("target.weave", "a cell_file carries its weave: leave target.weave out"));
                }
                let fine = weave.plain_weave(section_inertia)?;
                positive("target.side_m", *side_m)?;
                let fine_cell = match cell_file {
                    Some(path) => CellSource::File(path.clone()),
                    None => CellSource::Generate {
                        weave: fine.clone(),
                        relaxation: relaxation.options(weave.bending_at_rest),
                    },
                };
                let mut resolved_hybrid = None;
                if let Some(hybrid) = hybrid {
                    let region = match (hybrid.fine_half_width_m, hybrid.fine_radius_m) {
                        (Some(half_width), None) => {
                            positive("target.hybrid.fine_half_width_m", half_width)?;
                            if half_width >= 0.5 * side_m {
                                return Err(invalid("target.hybrid.fine_half_width_m", format!("must be less than half the panel (side_m = {side_m}), got {half_width}: every yarn would be fine")));
                            }
                            FineRegion::Band { half_width }
                        }
                        (None, Some(radius)) => {
                            positive("target.hybrid.fine_radius_m", radius)?;
                            if radius >= 0.5 * std::f64::consts::SQRT_2 * side_m {
                                return Err(invalid(
                                    "target.hybrid.fine_radius_m",
                                    format!("must be less than half the panel's diagonal (side_m = {side_m}), got {radius}: every crossing would be fine"),
                                ));
                            }
                            FineRegion::Disc { radius }
                        }
                        _ => return Err(invalid("target.hybrid", "give exactly one of fine_half_width_m (whole yarns fine) and fine_radius_m (yarns fine within a disc)")),
                    };
                    let coarse = match (&hybrid.cell_file, cell_file) {
                        (Some(_), _) if hybrid.fibres_per_yarn.is_some() || hybrid.element_length_ratio.is_some() => {
                            return Err(invalid("target.hybrid.cell_file", "a coarse cell file carries its fibres and elements: leave target.hybrid.fibres_per_yarn and element_length_ratio out"));
                        }
                        (Some(path), _) => CellSource::File(path.clone()),
                        (None, Some(_)) => return Err(invalid(
                            "target.hybrid.cell_file",
                            "the fine cell comes from target.cell_file, so the coarse one must come from a file too",
                        )),
                        (None, None) => CellSource::Generate {
                            weave: hybrid.coarse_weave(&fine)?,
                            relaxation: relaxation.options(weave.bending_at_rest),
                        },
                    };
                    resolved_hybrid = Some(HybridTarget { coarse, region });
                }
                let layout = panel_layout(*side_m, *layers, *layer_gap_m, layer_shift_m, boundary)?;
                relaxation.validate()?;
                ResolvedTarget::Woven(WovenTarget { fine: fine_cell, hybrid: resolved_hybrid, layout })
            }
            TargetSpec::ThreeDWeaveCell { weave: spec, relaxation } => {
                let weave = spec.weave(section_inertia)?;
                relaxation.validate()?;
                ResolvedTarget::ThreeDCell { weave, relaxation: relaxation.options(spec.bending_at_rest) }
            }
            TargetSpec::ThreeDWovenPanel {
                weave,
                cell_file,
                relaxation,
                side_m,
                layers,
                layer_gap_m,
                layer_shift_m,
                boundary,
                rest_angle_law: _,
            } => {
                let cell = match (weave, cell_file) {
                    (Some(spec), None) => CellSource::Generate {
                        weave: spec.weave(section_inertia)?,
                        relaxation: relaxation.options(spec.bending_at_rest),
                    },
                    (None, Some(path)) => CellSource::File(path.clone()),
                    (Some(_), Some(_)) => {
                        return Err(invalid("target.weave", "a cell_file carries its weave: leave target.weave out"))
                    }
                    (None, None) => {
                        return Err(invalid("target.weave", "is needed unless target.cell_file gives the relaxed cell"))
                    }
                };
                relaxation.validate()?;
                positive("target.side_m", *side_m)?;
                let layout = panel_layout(*side_m, *layers, *layer_gap_m, layer_shift_m, boundary)?;
                ResolvedTarget::ThreeDPanel { cell, layout }
            }
        };
        match self.bending {
            InertiaModel::Effective { k1, k2 } => {
                positive("bending.k1", k1)?;
                positive("bending.k2", k2)?;
            }
            InertiaModel::Free {} | InertiaModel::Locked {} | InertiaModel::None {} => {}
        }
        ranged(
            "contact.projectile_friction_coefficient",
            self.contact.projectile_friction_coefficient,
            0.0,
            MOST_FRICTION_COEFFICIENT,
        )?;
        if let Some(skin) = self.contact.skin_m {
            positive("contact.skin_m", skin)?;
        }
        positive("run.end_time_s", self.run.end_time_s)?;
        if self.run.end_time_s > LONGEST_END_TIME {
            return Err(invalid(
                "run.end_time_s",
                format!("must be at most {LONGEST_END_TIME} s (an impact on armour is over in well under a millisecond), got {}", self.run.end_time_s),
            ));
        }
        if let Some(side) = target_side(&target) {
            for (axis, offset) in ["x", "y"].iter().zip(projectile.offset) {
                if !(offset.is_finite() && offset.abs() <= 0.5 * side) {
                    return Err(invalid(
                        &format!("projectile.offset_m.{axis}"),
                        format!(
                            "must aim at the panel (within half its side, {} m, of its centre), got {offset}",
                            0.5 * side
                        ),
                    ));
                }
            }
        }
        if let Some(settle) = &self.run.settle {
            ranged("run.settle.time_s", settle.time_s, 1e-9, 1e-3)?;
            if let Some(damping) = settle.damping_per_s {
                positive("run.settle.damping_per_s", damping)?;
            }
        }
        let safety = self.run.time_step_safety;
        if !(safety > 0.0 && safety <= 1.0) {
            return Err(invalid("run.time_step_safety", format!("must be in (0, 1], got {safety}")));
        }
        if self.run.history_interval_steps == 0 {
            return Err(invalid("run.history_interval_steps", "must be >= 1, got 0"));
        }
        if self.run.snapshot_interval_steps == Some(0) {
            return Err(invalid("run.snapshot_interval_steps", "must be >= 1, got 0"));
        }
        if self.run.checkpoint_interval_steps == Some(0) {
            return Err(invalid("run.checkpoint_interval_steps", "must be >= 1, got 0"));
        }
        positive("run.checkpoint_interval_minutes", self.run.checkpoint_interval_minutes)?;
        Ok(ResolvedCase {
            material,
            law,
            friction_coefficient,
            section_inertia,
            projectile_friction_coefficient: self.contact.projectile_friction_coefficient,
            projectile_friction_spring,
            fibre_friction_spring,
            strength,
            shear_strength,
            shear_measure,
            tension_measure,
            unload,
            rest_angle_law,
            projectile,
            target,
        })
    }

    /// Checks every field that parsing alone cannot ([`Self::resolve`]).
    pub fn validate(&self) -> Result<(), CaseError> {
        self.resolve().map(drop)
    }
}

/// A panel's or a cross-ply's layer count, checked.
fn layer_count(layers: usize) -> Result<usize, CaseError> {
    if (1..=100).contains(&layers) {
        Ok(layers)
    } else {
        Err(invalid("target.layers", format!("must be in 1..=100, got {layers}")))
    }
}

/// The layout of a panel `side_m` square [m]: its layer count, stacking and boundary checked.
fn panel_layout(
    side_m: f64,
    layers: usize,
    layer_gap_m: f64,
    layer_shift_m: &[f64; 2],
    boundary: &BoundarySpec,
) -> Result<PanelLayout, CaseError> {
    layer_count(layers)?;
    stacking(layer_gap_m, layer_shift_m)?;
    if layer_gap_m > side_m {
        return Err(invalid(
            "target.layer_gap_m",
            format!("must be at most the panel's side ({side_m} m), got {layer_gap_m}"),
        ));
    }
    for (axis, shift) in ["x", "y"].iter().zip(layer_shift_m) {
        if shift.abs() > 0.5 * side_m {
            return Err(invalid(
                &format!("target.layer_shift_m.{axis}"),
                format!("must be at most half the panel's side ({} m), got {shift}", 0.5 * side_m),
            ));
        }
    }
    if let BoundarySpec::Clamp { opening_m } = boundary {
        positive("target.boundary.opening_m", *opening_m)?;
        if *opening_m >= side_m {
            return Err(invalid(
                "target.boundary.opening_m",
                format!("must be smaller than the panel (side_m = {side_m}), got {opening_m}"),
            ));
        }
    }
    Ok(PanelLayout {
        side: side_m,
        layers,
        layer_gap: layer_gap_m,
        layer_shift: *layer_shift_m,
        boundary: boundary.boundary(),
    })
}
