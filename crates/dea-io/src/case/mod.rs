//! The case file: everything a user sets, in SI units. Unknown fields are rejected and every
//! error names the field path (`target.fibres_per_yarn: must be >= 1, got 0`).

use dea_core::contact::NormalLaw;
use dea_core::material::{InertiaModel, SectionInertia};
use dea_core::projectile::RigidShape;
use dea_core::weibull::{WeibullMode, WeibullStrength};
use dea_core::FibreMaterial;
use dea_fabric::panel::Boundary;
use dea_fabric::relax::BendingAtRest;
use dea_fabric::weave::PlainWeave;
use dea_fabric::weave3d::{Pattern, ThreeDWeave, WarpPath, YarnKind};
use dea_projectile::elastic::ElasticModel;
use dea_projectile::generate::{FspDimensions, Solid};
use serde::{Deserialize, Serialize};

mod resolve;

pub use resolve::{
    CellSource, HybridTarget, PanelLayout, ResolvedCase, ResolvedTarget, StraightTarget, WovenTarget, UNSOURCED_WEIBULL,
};

/// A case error: where and why.
#[derive(Debug, thiserror::Error, PartialEq)]
#[error("{path}: {message}")]
pub struct CaseError {
    /// dotted field path, or the file name for errors about the file itself
    pub path: String,
    /// what is wrong, and what would be right
    pub message: String,
}

fn invalid(path: &str, message: impl Into<String>) -> CaseError {
    CaseError { path: path.to_string(), message: message.into() }
}

/// A whole case.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Case {
    /// a name for the run
    pub name: String,
    /// fibre material preset, optionally with overrides
    #[serde(default)]
    pub material: MaterialSpec,
    /// what is struck
    pub target: TargetSpec,
    /// bending model (5-7)…(5-10); default: effective with k1 = 0.8, k2 = 1 (seed §5.3)
    #[serde(default = "default_bending")]
    pub bending: InertiaModel,
    /// fibre–fibre and fibre–projectile contact
    pub contact: ContactSpec,
    /// failure criterion and strengths
    pub failure: FailureSpec,
    /// the projectile and its flight
    pub projectile: ProjectileSpec,
    /// time, output and the settle
    pub run: RunSpec,
}

fn default_bending() -> InertiaModel {
    InertiaModel::Effective { k1: 0.8, k2: 1.0 }
}

/// Material: a preset name plus optional overrides of single properties.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    /// "kevlar_km2" (seed Table 4-1)
    pub preset: String,
    /// E_L [Pa]
    pub longitudinal_modulus_pa: Option<f64>,
    /// E_T [Pa]
    pub transverse_modulus_pa: Option<f64>,
    /// density [kg/m^3]
    pub density_kg_m3: Option<f64>,
    /// compressive / tensile axial stiffness [-]
    pub compressive_stiffness_ratio: Option<f64>,
    /// real filament diameter [m]
    pub filament_diameter_m: Option<f64>,
}

impl Default for MaterialSpec {
    fn default() -> Self {
        Self {
            preset: "kevlar_km2".into(),
            longitudinal_modulus_pa: None,
            transverse_modulus_pa: None,
            density_kg_m3: None,
            compressive_stiffness_ratio: None,
            filament_diameter_m: None,
        }
    }
}

/// How a straight yarn's digital fibres sit in its section.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum YarnPackingSpec {
    /// rings around the axis, touching (the default)
    Hexagonal,
    /// rows on a square lattice at the contact diameter, `across_per_through` times as many
    /// fibres across the yarn (y) as through its thickness (z): seed Table 5-1 keeps 4 for
    /// every fibre count, so `fibres_per_yarn` must be `across_per_through` times a square
    Rectangular {
        /// fibres across over fibres through the thickness [-]
        across_per_through: usize,
    },
}

/// How a straight yarn's ends are held.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum YarnEndsSpec {
    /// every fibre's end nodes fixed (the default)
    Clamped,
    /// each end of the yarn carries a mass that slides along the yarn (x) on a surface whose
    /// friction resists with at most `friction_force_n` (seed §5.3, Fig. 5-5: "a small mass
    /// … constrained by a friction surface parallel to yarn alignment. The maximum friction
    /// of each mass is 10 N"); mass and friction are shared equally by the fibres' end nodes
    Sliding {
        /// the mass at each end of the yarn [kg]
        mass_kg: f64,
        /// the largest friction force on each end's mass [N]
        friction_force_n: f64,
    },
}

/// What the projectile strikes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum TargetSpec {
    /// one fibre of circular section along x, both ends clamped (seed §6.1)
    SingleFibre {
        /// [m]
        length_m: f64,
        /// [m]
        diameter_m: f64,
        /// element length / fibre diameter [-]
        element_length_ratio: f64,
    },
    /// a straight yarn of digital fibres along x, hexagonally packed with its ends clamped
    /// unless the fixture fields say otherwise (seed §5.3's single-yarn model: rectangular
    /// packing, sliding ends, the lateral hold)
    StraightYarn {
        /// yarn preset: "km2_600_denier" (area 4.63e-8 m^2, ~400 filaments)
        yarn: String,
        /// digital fibres per yarn
        fibres_per_yarn: usize,
        /// [m]
        length_m: f64,
        /// element length / digital fibre diameter [-]
        element_length_ratio: f64,
        /// how the fibres sit in the section (absent: hexagonal)
        #[serde(default, skip_serializing_if = "Option::is_none")]
        packing: Option<YarnPackingSpec>,
        /// how the yarn's ends are held (absent: clamped)
        #[serde(default, skip_serializing_if = "Option::is_none")]
        ends: Option<YarnEndsSpec>,
        /// keep the fibres from spreading across the yarn (y): seed §5.3's "fibers are
        /// constrained from spreading laterally"
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        hold_lateral: bool,
    },
    /// stacked layers of parallel straight yarns, along x in even layers and along y in odd
    /// ones (a cross-ply: crossing yarns without weaving), every yarn clamped at both ends;
    /// layer 0 is on top, struck first
    StraightYarnLayers {
        /// yarn preset: "km2_600_denier"
        yarn: String,
        /// digital fibres per yarn
        fibres_per_yarn: usize,
        /// number of layers
        layers: usize,
        /// yarns side by side in each layer
        yarns_per_layer: usize,
        /// length of every yarn (the panel is square) [m]
        length_m: f64,
        /// element length / digital fibre diameter [-]
        element_length_ratio: f64,
    },
    /// a plain-woven panel: a unit cell generated and relaxed with periodic boundaries
    /// (or read from a `dea-mpi fabric` cell file), tiled to a square and stacked in layers;
    /// layer 0 is on top, struck first
    WovenPanel {
        /// the weave of every layer (ignored parts must be absent when `cell_file` is set)
        #[serde(default)]
        weave: WeaveSpec,
        /// a relaxed cell written by `dea-mpi fabric` (`cell.h5`), used instead of relaxing
        #[serde(default, skip_serializing_if = "Option::is_none")]
        cell_file: Option<std::path::PathBuf>,
        /// side of the square panel, rounded to whole unit cells (at least one) [m]
        side_m: f64,
        /// number of layers (1..=28 and beyond, up to 100)
        layers: usize,
        /// gap between the contact surfaces of neighbouring layers; 0 = touching [m]
        #[serde(default)]
        layer_gap_m: f64,
        /// in-plane shift of each layer relative to the one above (x, y) [m]
        #[serde(default)]
        layer_shift_m: [f64; 2],
        /// how the panel is held: {"kind": "fixed_edges"} or {"kind": "clamp", "opening_m": ...}
        #[serde(default = "default_boundary")]
        boundary: BoundarySpec,
        /// when the relaxation stops
        #[serde(default)]
        relaxation: RelaxationSpec,
        /// coarse yarns away from the impact point: a yarn-based hybrid mesh (seed §2.3.4.1)
        #[serde(default, skip_serializing_if = "Option::is_none")]
        hybrid: Option<Box<HybridSpec>>,
        /// what a spring bent at rest (`weave.bending_at_rest` "as_woven", or a cell file's)
        /// stores below its rest angle: "smooth" (the default, a quartic through straight) or
        /// "cone" (the seed's `K_t (theta - theta_0)^2 / 2` down to straight, the default
        /// before 2026-12-03; docs/theory.md F4b)
        #[serde(default, skip_serializing_if = "Option::is_none")]
        rest_angle_law: Option<String>,
    },
    /// a 3-D woven unit cell (seed chapter 3: orthogonal, layer-to-layer, angle interlock),
    /// generated and relaxed with periodic boundaries by `dea-mpi fabric`. Panels of 3-D
    /// weaves are not built, so a run refuses it.
    ThreeDWeaveCell {
        /// the 3-D weave to generate
        weave: Box<Weave3dSpec>,
        /// when the relaxation stops
        #[serde(default)]
        relaxation: RelaxationSpec,
    },
    /// a panel tiled from a relaxed 3-D woven cell, centred on the origin; layer 0 on top
    ThreeDWovenPanel {
        /// the weave, generated and relaxed at set-up; absent when `cell_file` is given
        #[serde(default, skip_serializing_if = "Option::is_none")]
        weave: Option<Box<Weave3dSpec>>,
        /// a relaxed 3-D cell written by `dea-mpi fabric` (`cell.h5`), used instead of relaxing
        #[serde(default, skip_serializing_if = "Option::is_none")]
        cell_file: Option<std::path::PathBuf>,
        #[serde(default)]
        /// when the relaxation of a generated weave stops
        relaxation: RelaxationSpec,
        /// side of the square panel, rounded to whole cells each way (at least one) [m]
        side_m: f64,
        /// number of stacked panels (1..=100)
        #[serde(default = "one_layer")]
        layers: usize,
        /// gap between the contact surfaces of neighbouring panels; 0 = touching [m]
        #[serde(default)]
        layer_gap_m: f64,
        /// in-plane shift of each panel relative to the one above (x, y) [m]
        #[serde(default)]
        layer_shift_m: [f64; 2],
        /// how the panel is held: {"kind": "fixed_edges"} or {"kind": "clamp", "opening_m": ...}
        #[serde(default = "default_boundary")]
        boundary: BoundarySpec,
        /// what a spring bent at rest (`weave.bending_at_rest` "as_woven", or a cell file's)
        /// stores below its rest angle: "smooth" (the default, a quartic through straight) or
        /// "cone" (the seed's `K_t (theta - theta_0)^2 / 2` down to straight, the default
        /// before 2026-12-03; docs/theory.md F4b)
        #[serde(default, skip_serializing_if = "Option::is_none")]
        rest_angle_law: Option<String>,
    },
}

/// The stacking fields of a panel target: a gap of at least 0, a finite shift.
fn stacking(layer_gap_m: f64, layer_shift_m: &[f64; 2]) -> Result<(), CaseError> {
    non_negative("target.layer_gap_m", layer_gap_m)?;
    for (axis, v) in ["x", "y"].iter().zip(layer_shift_m) {
        if !v.is_finite() {
            return Err(invalid(&format!("target.layer_shift_m.{axis}"), format!("must be finite, got {v}")));
        }
    }
    Ok(())
}

fn one_layer() -> usize {
    1
}

/// A 3-D weave: a named pattern or a table of gaps, and its yarns.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Weave3dSpec {
    /// "orthogonal", "layer_to_layer" or "angle_interlock"; absent when `columns` is given
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pattern: Option<Pattern>,
    /// the warp-direction columns across the cell, each a stack of yarns listed bottom to
    /// top: {"role": "stuffer" | "binder", "gaps": [gap at each filler column]}, gap 0 below
    /// every filler layer, gap L above them all
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub columns: Option<Vec<Vec<WarpPath>>>,
    /// layers of filler (weft) yarns
    pub filler_layers: u32,
    /// centre distance of neighbouring filler columns, along x [m]
    pub pick_spacing_m: f64,
    /// centre distance of neighbouring warp-direction columns, along y [m]
    pub end_spacing_m: f64,
    /// the filler yarn: {"area_m2", "section_aspect"}
    pub filler: YarnKind,
    /// digital fibres of a filler yarn (1..=400); every digital fibre has the filler's
    /// section, so other yarns hold round(area / fibre area) of them
    pub filler_fibres: usize,
    /// the stuffer yarn; default: the filler's
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stuffer: Option<YarnKind>,
    /// the binder yarn; default: the filler's
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub binder: Option<YarnKind>,
    /// element length / digital fibre diameter; default 0.5 [-]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub element_length_ratio: Option<f64>,
    /// tension of a filler yarn during relaxation, the same stress in every yarn; default 0.5 [N]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub filler_tension_n: Option<f64>,
    /// the shape the bending springs rest in: "straight" (default: the springs act during
    /// relaxation, which a 3-D cell needs to converge; docs/theory.md F10) or "as_woven" (F4)
    #[serde(default = "straight")]
    pub bending_at_rest: BendingAtRest,
}

fn straight() -> BendingAtRest {
    BendingAtRest::Straight
}

impl Weave3dSpec {
    /// The weave the spec describes, every field checked.
    /// `inertia` is the case's bending model with its friction weight applied.
    pub fn weave(&self, inertia: SectionInertia) -> Result<ThreeDWeave, CaseError> {
        let layers = self.filler_layers;
        if !(1..=50).contains(&layers) {
            return Err(invalid("target.weave.filler_layers", format!("must be in 1..=50, got {layers}")));
        }
        let columns = match (self.pattern, &self.columns) {
            (Some(_), Some(_)) => return Err(invalid("target.weave.columns", "give a pattern or columns, not both")),
            (None, None) => {
                return Err(invalid("target.weave.pattern", "is needed unless target.weave.columns gives the topology"))
            }
            (Some(pattern), None) if layers < 2 => {
                return Err(invalid(
                    "target.weave.filler_layers",
                    format!("the {pattern:?} pattern needs at least 2 filler layers, got {layers}"),
                ))
            }
            (Some(pattern), None) => pattern.columns(layers),
            (None, Some(columns)) => columns.clone(),
        };
        let kind = |path: &str, kind: &YarnKind| -> Result<YarnKind, CaseError> {
            positive(&format!("{path}.area_m2"), kind.area_m2)?;
            ranged(&format!("{path}.section_aspect"), kind.section_aspect, 1.0, 50.0)?;
            Ok(*kind)
        };
        let filler = kind("target.weave.filler", &self.filler)?;
        let mut weave = ThreeDWeave {
            filler_layers: layers,
            columns,
            pick_spacing: yarn_spacing("target.weave.pick_spacing_m", self.pick_spacing_m)?,
            end_spacing: yarn_spacing("target.weave.end_spacing_m", self.end_spacing_m)?,
            filler,
            filler_fibres: fibre_count_at("target.weave.filler_fibres", self.filler_fibres)?,
            stuffer: kind("target.weave.stuffer", self.stuffer.as_ref().unwrap_or(&filler))?,
            binder: kind("target.weave.binder", self.binder.as_ref().unwrap_or(&filler))?,
            element_length_ratio: 0.5,
            filler_tension: 0.5,
            inertia,
        };
        for (path, kind) in [("target.weave.stuffer", weave.stuffer), ("target.weave.binder", weave.binder)] {
            let fibres = weave.fibres_of(&kind);
            if fibres > 400 {
                return Err(invalid(
                    &format!("{path}.area_m2"),
                    format!("holds {fibres} digital fibres of the filler's section, more than 400"),
                ));
            }
        }
        if let Some(v) = self.element_length_ratio {
            weave.element_length_ratio = ratio("target.weave.element_length_ratio", v)?;
        }
        if let Some(v) = self.filler_tension_n {
            weave.filler_tension = positive("target.weave.filler_tension_n", v)?;
        }
        weave.check_topology().map_err(|e| invalid("target.weave", e.to_string()))?;
        Ok(weave)
    }
}

/// A hybrid mesh: near the panel's centre the yarns keep the weave's digital fibres;
/// elsewhere they have fewer, thicker ones with longer elements, in a cell of their own
/// relaxed the same way (or read from a file). The fine region is either a band
/// (`fine_half_width_m`: yarns fine or coarse over their whole length) or a disc
/// (`fine_radius_m`: yarns fine within it and tied to their coarse fibres beyond).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HybridSpec {
    /// distance from the panel's centre within which a yarn's centreline makes it fine [m]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fine_half_width_m: Option<f64>,
    /// radius about the panel's centre within which the yarns' crossings are fine [m]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fine_radius_m: Option<f64>,
    /// digital fibres of a coarse yarn (1..=400, fewer than a fine yarn's); absent when
    /// `cell_file` gives the coarse cell
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fibres_per_yarn: Option<usize>,
    /// element length / digital fibre diameter of the coarse yarns; default: the weave's [-]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub element_length_ratio: Option<f64>,
    /// a relaxed coarse cell written by `dea-mpi fabric` (`coarse_cell.h5`)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cell_file: Option<std::path::PathBuf>,
}

impl HybridSpec {
    /// The coarse yarns' weave: `fine` with the coarse fibre count and element length.
    pub fn coarse_weave(&self, fine: &PlainWeave) -> Result<PlainWeave, CaseError> {
        let fibres = self.fibres_per_yarn.ok_or_else(|| {
            invalid("target.hybrid.fibres_per_yarn", "is needed unless target.hybrid.cell_file gives the coarse cell")
        })?;
        let fibres = fibre_count_at("target.hybrid.fibres_per_yarn", fibres)?;
        if fibres >= fine.fibres_per_yarn {
            return Err(invalid(
                "target.hybrid.fibres_per_yarn",
                format!("must be fewer than the fine yarns' {} digital fibres, got {fibres}", fine.fibres_per_yarn),
            ));
        }
        let mut coarse = PlainWeave { fibres_per_yarn: fibres, ..fine.clone() };
        if let Some(v) = self.element_length_ratio {
            coarse.element_length_ratio = ratio("target.hybrid.element_length_ratio", v)?;
        }
        Ok(coarse)
    }
}

/// A plain weave: a fabric preset with optional overrides.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WeaveSpec {
    /// "km2_style_706": KM2 600 denier, 34 x 34 yarns per inch (DuPont; docs/theory.md F1)
    pub preset: String,
    /// digital fibres per yarn (1..=400)
    pub fibres_per_yarn: usize,
    /// centre distance of neighbouring parallel yarns [m]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub yarn_spacing_m: Option<f64>,
    /// width / thickness of the yarn section the fibres are packed in [-]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub section_aspect: Option<f64>,
    /// initial crimp before relaxation; default: the least that keeps crossing yarns apart [-]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub initial_crimp: Option<f64>,
    /// tension of a yarn during relaxation, kept in the relaxed fabric [N]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub yarn_tension_n: Option<f64>,
    /// element length / digital fibre diameter [-]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub element_length_ratio: Option<f64>,
    /// the shape the bending springs rest in: "as_woven" (the relaxed crimp, the default) or
    /// "straight" (the crimp holds them bent; docs/theory.md F4)
    #[serde(default = "as_woven")]
    pub bending_at_rest: BendingAtRest,
}

fn as_woven() -> BendingAtRest {
    BendingAtRest::AsWoven
}

impl Default for WeaveSpec {
    fn default() -> Self {
        Self {
            preset: "km2_style_706".into(),
            fibres_per_yarn: 4,
            yarn_spacing_m: None,
            section_aspect: None,
            initial_crimp: None,
            yarn_tension_n: None,
            element_length_ratio: None,
            bending_at_rest: BendingAtRest::AsWoven,
        }
    }
}

/// Panel support.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum BoundarySpec {
    /// both ends of every fibre fixed (a struct variant, so that a stray field such as an
    /// opening is refused rather than dropped)
    FixedEdges {},
    /// every node outside a centred square opening fixed (seed §6.2.2: 12 in in 15 in fabric)
    Clamp {
        /// side of the opening [m]
        opening_m: f64,
    },
}

fn default_boundary() -> BoundarySpec {
    BoundarySpec::FixedEdges {}
}

/// When the relaxation of the unit cell stops.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RelaxationSpec {
    /// largest nodal force at the end over the initial one [-]
    #[serde(default = "default_relaxation_tolerance")]
    pub tolerance: f64,
    /// iterations before giving up (exit 5)
    #[serde(default = "default_relaxation_iterations")]
    pub max_iterations: u64,
}

fn default_relaxation_tolerance() -> f64 {
    1e-6
}

fn default_relaxation_iterations() -> u64 {
    500_000
}

impl Default for RelaxationSpec {
    fn default() -> Self {
        Self { tolerance: default_relaxation_tolerance(), max_iterations: default_relaxation_iterations() }
    }
}

impl RelaxationSpec {
    fn validate(&self) -> Result<(), CaseError> {
        ranged("target.relaxation.tolerance", self.tolerance, 1e-14, 0.1)?;
        if self.max_iterations == 0 {
            return Err(invalid("target.relaxation.max_iterations", "must be >= 1, got 0"));
        }
        Ok(())
    }

    /// The relaxation's options, with the springs resting as `bending_at_rest` says.
    pub fn options(&self, bending_at_rest: BendingAtRest) -> dea_fabric::relax::RelaxOptions {
        dea_fabric::relax::RelaxOptions {
            tolerance: self.tolerance,
            max_iterations: self.max_iterations,
            bending_at_rest,
        }
    }
}

impl WeaveSpec {
    /// The weave the spec names (validated: call [`Case::validate`] first for field errors).
    /// `inertia` is the case's bending model with its friction weight applied.
    pub fn plain_weave(&self, inertia: SectionInertia) -> Result<PlainWeave, CaseError> {
        let mut weave = match self.preset.as_str() {
            "km2_style_706" => {
                PlainWeave::km2_style_706(fibre_count_at("target.weave.fibres_per_yarn", self.fibres_per_yarn)?)
            }
            other => {
                return Err(invalid(
                    "target.weave.preset",
                    format!("unknown fabric {other:?}; known: \"km2_style_706\""),
                ))
            }
        };
        weave.inertia = inertia;
        if let Some(v) = self.yarn_spacing_m {
            weave.yarn_spacing = yarn_spacing("target.weave.yarn_spacing_m", v)?;
        }
        if let Some(v) = self.section_aspect {
            weave.section_aspect = ranged("target.weave.section_aspect", v, 1.0, 50.0)?;
        }
        if let Some(v) = self.initial_crimp {
            weave.initial_crimp = Some(ranged("target.weave.initial_crimp", v, 0.0, 0.5)?);
        }
        if let Some(v) = self.yarn_tension_n {
            weave.yarn_tension = positive("target.weave.yarn_tension_n", v)?;
        }
        if let Some(v) = self.element_length_ratio {
            weave.element_length_ratio = ratio("target.weave.element_length_ratio", v)?;
        }
        Ok(weave)
    }
}

impl BoundarySpec {
    /// The panel boundary.
    pub fn boundary(&self) -> Boundary {
        match *self {
            BoundarySpec::FixedEdges {} => Boundary::FixedEdges,
            BoundarySpec::Clamp { opening_m } => Boundary::Clamp { opening_m },
        }
    }
}

/// KM2 600 denier: 600 g per 9000 m at 1440 kg/m^3 (PHYSICS.md §6).
pub const KM2_600_DENIER_AREA: f64 = 0.6 / 9000.0 / 1440.0;

/// Contact model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContactSpec {
    /// "elastic" (4-8) or "elasto_plastic_km2" (4-9, 4-10)
    pub law: String,
    /// inter-fibre friction coefficient [-] (seed: 0.3)
    pub friction_coefficient: f64,
    /// fibre–projectile friction coefficient [-]
    pub projectile_friction_coefficient: f64,
    /// how the fibre–projectile friction spring keeps its stretch while a contact lasts:
    /// "rotating" (the default: in the tangent plane, turned with the normal, docs/theory.md
    /// I6c) or "anchored" (the seed's (4-13) as written: the partner's position at first touch,
    /// which creates energy where the normal turns under a sliding node)
    #[serde(default)]
    pub projectile_friction_spring: Option<String>,
    /// how the fibre–fibre friction spring keeps its stretch: "anchored" (the default, the
    /// seed's (4-13) as written) or "projected" (the anchor kept in the tangent plane, so a
    /// press along one normal never turns into stretch along a later one; docs/theory.md I6d)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fibre_friction_spring: Option<String>,
    /// Verlet skin [m]; default a quarter of the largest contact diameter
    pub skin_m: Option<f64>,
}

/// Failure model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FailureSpec {
    /// "none", "deterministic" (one strength) or "weibull" (per-element strengths)
    pub mode: String,
    /// deterministic tensile strength [Pa] (Table 4-1: 3.8e9)
    pub tensile_strength_pa: Option<f64>,
    /// shear strength tau_u [Pa] (seed §5.2.2: 0.7672e9)
    pub shear_strength_pa: Option<f64>,
    /// how an element's shear force (5-4) is measured: "gauge" (the default: the moment over a
    /// gauge of `shear_gauge_diameters` digital fibre diameters, docs/theory.md I9b) or
    /// "element" (the seed's form as written, which does not converge at a kink)
    #[serde(default)]
    pub shear_measure: Option<String>,
    /// gauge length of the "gauge" shear measure in digital fibre diameters [-] (default 1)
    #[serde(default)]
    pub shear_gauge_diameters: Option<f64>,
    /// how an element's tension (4-16) is measured: "gauge" (the default: the strain averaged
    /// over a gauge of `tension_gauge_diameters` digital fibre diameters, docs/theory.md I9c)
    /// or "element" (the element's own strain, the seed's form and the default before
    /// 2026-12-03)
    #[serde(default)]
    pub tension_measure: Option<String>,
    /// gauge length of the "gauge" tension measure in digital fibre diameters [-] (default 1)
    #[serde(default)]
    pub tension_gauge_diameters: Option<f64>,
    /// when a broken element stops acting: "at_break" (the default: its forces leave the
    /// step of its break) or "next_step" (they stay for that step, the order of every result
    /// before the choice was named; docs/theory.md I7)
    #[serde(default)]
    pub unload: Option<String>,
    /// bimodal Weibull law (2-1) for mode "weibull"
    pub weibull: Option<WeibullSpec>,
    /// seed of the strength streams
    #[serde(default)]
    pub seed: u64,
}

/// Parameters of (2-1); the seed gives none (docs/theory.md).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WeibullSpec {
    /// gauge length L0 [m]
    pub gauge_length_m: f64,
    /// Weibull modulus m of the first mode [-]
    pub shape_1: f64,
    /// [Pa]
    pub scale_1_pa: f64,
    /// Weibull modulus of the second mode, for a bimodal strength [-]
    pub shape_2: Option<f64>,
    /// [Pa]
    pub scale_2_pa: Option<f64>,
}

/// Projectile: a preset ("fsp_17_grain", "table_4_2_sphere", "table_4_2_rcc") or an explicit
/// shape ("sphere", "cylinder", "fsp", or "file" for an imported mesh).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProjectileSpec {
    /// a preset name, or none for an explicit shape
    pub preset: Option<String>,
    /// "sphere", "cylinder", "fsp" or "file" when no preset is given
    pub shape: Option<String>,
    /// [m]
    pub diameter_m: Option<f64>,
    /// cylinder height, FSP length [m]
    pub height_m: Option<f64>,
    /// cylinder striking-edge radius; FSP rim radius (where flat and cuts meet the side) [m]
    pub edge_radius_m: Option<f64>,
    /// FSP: width of the flat between the cuts [m]
    pub flat_width_m: Option<f64>,
    /// FSP: angle of the cut faces to the flat [deg]
    pub bevel_angle_deg: Option<f64>,
    /// FSP: radius of the edges between the flat and the cuts [m]
    pub flat_edge_radius_m: Option<f64>,
    /// mesh a sphere or cylinder (an FSP is always meshed, by default with 6): elements
    /// along a quarter of the rim
    pub mesh_divisions: Option<usize>,
    /// shape "file": a Gmsh 4.1 .msh, ABAQUS .inp or STL file, relative to the case file;
    /// its -z side faces the target
    pub mesh_file: Option<std::path::PathBuf>,
    /// factor from the file's length unit to metres (default 1)
    pub mesh_scale: Option<f64>,
    /// [kg]
    pub mass_kg: Option<f64>,
    /// striking speed [m/s]
    pub velocity_m_s: f64,
    /// lateral offset of the aim point from the target centre (x, y) [m]
    #[serde(default)]
    pub offset_m: [f64; 2],
    /// angle of the line of flight to the target normal, tilted towards -x [deg]
    #[serde(default)]
    pub obliquity_deg: f64,
    /// angle of the body axis to the line of flight, turned about the axis normal to it
    /// in the plane of obliquity [deg]
    #[serde(default)]
    pub yaw_deg: f64,
    /// a deformable projectile: linear-elastic hexahedra (none: rigid)
    pub deformable: Option<DeformableSpec>,
}

/// Elastic constants of a deformable projectile; its density is its mass over its volume.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DeformableSpec {
    /// [Pa]
    pub youngs_modulus_pa: f64,
    /// [-]
    pub poisson_ratio: f64,
    /// "corotational" (linear elasticity at any rotation; the default) or "neo_hookean"
    /// (the same at small strain, hyperelastic at large strain)
    #[serde(default)]
    pub model: Option<String>,
}

impl DeformableSpec {
    /// The stress model.
    pub fn model(&self) -> Result<ElasticModel, CaseError> {
        match self.model.as_deref() {
            None | Some("corotational") => Ok(ElasticModel::Corotational),
            Some("neo_hookean") => Ok(ElasticModel::NeoHookean),
            Some(other) => Err(invalid(
                "projectile.deformable.model",
                format!("unknown model {other:?}; known: \"corotational\", \"neo_hookean\""),
            )),
        }
    }
}

/// Run control.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunSpec {
    /// simulated time at which the run ends [s]
    pub end_time_s: f64,
    /// fraction of the critical time step used [-]
    #[serde(default = "default_safety")]
    pub time_step_safety: f64,
    /// steps between two history samples
    #[serde(default = "default_history_interval")]
    pub history_interval_steps: u64,
    /// stop once the projectile has passed the whole target and moves away
    #[serde(default = "default_true")]
    pub stop_on_perforation: bool,
    /// steps between field snapshots (fields.xdmf; none: no snapshots)
    #[serde(default)]
    pub snapshot_interval_steps: Option<u64>,
    /// write a checkpoint every this many steps (none: only by wall time and on signals)
    #[serde(default)]
    pub checkpoint_interval_steps: Option<u64>,
    /// write a checkpoint every this many minutes of wall time [min]
    #[serde(default = "default_checkpoint_minutes")]
    pub checkpoint_interval_minutes: f64,
    /// a damped settle of the assembled target before the shot (a hybrid panel's crossings
    /// of fine and coarse yarns start out of balance); none: the shot starts as built
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub settle: Option<SettleSpec>,
    /// multi-rate stepping (docs/theory.md T1): each fibre section's terms fire at its own
    /// stable step, the largest power of two times the finest section's that it allows; a
    /// hybrid target's coarse part then costs a fraction of a step. Off: every term at every
    /// step. The history, snapshot and checkpoint intervals must then be multiples of the
    /// largest rate, which `dea-mpi check` prints.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub multi_rate: bool,
}

/// The settle before the shot: the target moves without friction, failure or projectile
/// under mass-proportional damping, then starts the shot at rest with fresh contact
/// histories (docs/theory.md F6).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SettleSpec {
    /// simulated time of the settle [s]
    pub time_s: f64,
    /// damping rate c of `m dv/dt = F - c m v`; default 10 / time_s [1/s]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub damping_per_s: Option<f64>,
}

impl SettleSpec {
    /// The damping rate [1/s].
    pub fn damping(&self) -> f64 {
        self.damping_per_s.unwrap_or(10.0 / self.time_s)
    }
}

fn default_checkpoint_minutes() -> f64 {
    30.0
}

fn default_safety() -> f64 {
    0.5
}
fn default_history_interval() -> u64 {
    50
}
fn default_true() -> bool {
    true
}

/// Projectile resolved to SI values.
#[derive(Clone, Debug, PartialEq)]
pub struct ResolvedProjectile {
    /// its surface: analytic, generated or imported
    pub body: ProjectileBody,
    /// [kg]
    pub mass: f64,
    /// [m/s]
    pub speed: f64,
    /// [m]
    pub offset: [f64; 2],
    /// [rad]
    pub obliquity: f64,
    /// [rad]
    pub yaw: f64,
    /// a deformable body's elastic constants and model
    pub deformable: Option<ElasticBody>,
}

/// A deformable projectile's material, resolved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ElasticBody {
    /// Young's modulus [Pa]
    pub youngs_modulus: f64,
    /// Poisson's ratio [-]
    pub poisson_ratio: f64,
    /// the constitutive model
    pub model: ElasticModel,
}

/// What the projectile's surface is made of.
#[derive(Clone, Debug, PartialEq)]
pub enum ProjectileBody {
    /// the closed-form sphere or rounded cylinder
    Analytic(RigidShape),
    /// a built-in hexahedral mesh
    Generated {
        /// the solid
        solid: Solid,
        /// mesh divisions across it
        divisions: usize,
    },
    /// a mesh file, lengths multiplied by `scale`
    File {
        /// the mesh file
        path: std::path::PathBuf,
        /// length factor to metres [-]
        scale: f64,
    },
}

/// Mesh divisions of the FSP when the case gives none: the edges are resolved at any
/// division count, this sets the size away from them.
pub const DEFAULT_FSP_DIVISIONS: usize = 6;

/// The 17-grain FSP's mass, 17 grains [kg].
pub const FSP_17_GRAIN_MASS: f64 = 17.0 * 64.798_91e-6;

/// Failure resolved.
#[derive(Clone, Debug, PartialEq)]
pub enum Strength {
    /// unbreakable fibres
    None,
    /// every element the same tensile strength [Pa]
    Deterministic(f64),
    /// Weibull-distributed strengths and the seed of their draw
    Weibull(WeibullStrength, u64),
}

/// Table 4-2 steel sphere: d = 5.56 mm, m = 0.692 g.
pub fn table_4_2_sphere() -> (RigidShape, f64) {
    (RigidShape::Sphere { radius: 5.56e-3 / 2.0 }, 0.692e-3)
}

/// Table 4-2 steel RCC: d = 3.4 mm, h = 3.7 mm, m = 0.2592 g; the seed gives no edge radius
/// for it: 50 µm, the value of its single-yarn cylinder (§5.3).
pub fn table_4_2_rcc() -> (RigidShape, f64) {
    (RigidShape::Cylinder { radius: 3.4e-3 / 2.0, height: 3.7e-3, edge_radius: 50e-6 }, 0.2592e-3)
}

fn positive(path: &str, value: f64) -> Result<f64, CaseError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(invalid(path, format!("must be > 0, got {value}")))
    }
}

fn non_negative(path: &str, value: f64) -> Result<f64, CaseError> {
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        Err(invalid(path, format!("must be >= 0, got {value}")))
    }
}

fn required<T>(path: &str, value: Option<T>) -> Result<T, CaseError> {
    value.ok_or_else(|| invalid(path, "is required here"))
}

fn fibre_count(value: usize) -> Result<usize, CaseError> {
    fibre_count_at("target.fibres_per_yarn", value)
}

fn fibre_count_at(path: &str, value: usize) -> Result<usize, CaseError> {
    if (1..=400).contains(&value) {
        Ok(value)
    } else {
        Err(invalid(path, format!("must be in 1..=400, got {value}")))
    }
}

fn ranged(path: &str, value: f64, low: f64, high: f64) -> Result<f64, CaseError> {
    if value.is_finite() && value >= low && value <= high {
        Ok(value)
    } else {
        Err(invalid(path, format!("must be in [{low:?}, {high:?}], got {value:?}")))
    }
}

/// The sizes a projectile's diameter, height and flat may have [m]: from a fibre's
/// diameter to 100 mm, beyond the largest fragment-simulating projectile (20 mm) and
/// small-arms bullet. Outside them a projectile is a typing error, and its mesh and search
/// grid would not fit in memory.
pub const PROJECTILE_SIZE_M: (f64, f64) = (10e-6, 0.1);
/// The edge radii a projectile may have [m]: from 1 µm (the 17-grain FSP's are 50 and
/// 150 µm, `FspDimensions::SEVENTEEN_GRAIN`) up; generated meshes resolve them, so a
/// vanishing one has no end.
pub const EDGE_RADIUS_M: (f64, f64) = (1e-6, 0.05);
/// The masses a projectile may have [kg]: 1 µg to 10 kg (a 17-grain FSP is 1.1 g); a
/// vanishing mass leaves a body whose inertia cannot be inverted.
pub const PROJECTILE_MASS_KG: (f64, f64) = (1e-9, 10.0);

/// The widest yarn spacing a weave may have [m]: 20 mm, over twenty times that of the
/// fabrics modelled here (style 706: 0.75 mm); a unit cell is meshed at a fibre's scale, so
/// one of metres would not fit in memory.
pub const MOST_YARN_SPACING_M: f64 = 0.02;

fn yarn_spacing(path: &str, value: f64) -> Result<f64, CaseError> {
    let value = positive(path, value)?;
    if value <= MOST_YARN_SPACING_M {
        Ok(value)
    } else {
        Err(invalid(path, format!("must be at most {MOST_YARN_SPACING_M:?} m, got {value:?}")))
    }
}

fn projectile_size(path: &str, value: f64) -> Result<f64, CaseError> {
    ranged(path, value, PROJECTILE_SIZE_M.0, PROJECTILE_SIZE_M.1)
}

fn edge_radius(path: &str, value: f64) -> Result<f64, CaseError> {
    ranged(path, value, EDGE_RADIUS_M.0, EDGE_RADIUS_M.1)
}

/// The generated meshes resolve an edge's rounding with facets of its own size: an edge
/// radius under a thousandth of the diameter would take millions of them (a 100 mm FSP with
/// 1 µm edges took 94 s and 4 GB to mesh).
fn finer_than_mesh_allows(path: &str, radius: f64, diameter: f64) -> Result<(), CaseError> {
    if radius >= 1e-3 * diameter {
        Ok(())
    } else {
        Err(invalid(
            path,
            format!("must be at least a thousandth of the diameter ({:?} m), got {radius:?}", 1e-3 * diameter),
        ))
    }
}

/// An element length in fibre diameters: from a hundredth (finer than any convergence study
/// needs; below it a fibre's node count is the case's size rather than its physics) to 4.
fn ratio(path: &str, value: f64) -> Result<f64, CaseError> {
    if value.is_finite() && (0.01..=4.0).contains(&value) {
        Ok(value)
    } else {
        Err(invalid(path, format!("must be in [0.01, 4], got {value}")))
    }
}

/// The diameter of a single digital fibre: from a micrometre (finer than any filament) to
/// 10 mm [m].
pub(crate) fn fibre_diameter(path: &str, value: f64) -> Result<f64, CaseError> {
    ranged(path, value, 1e-6, 1e-2)
}

/// Cross-section area of a yarn preset [m^2].
pub fn yarn_area(name: &str) -> Result<f64, CaseError> {
    match name {
        "km2_600_denier" => Ok(KM2_600_DENIER_AREA),
        other => Err(invalid("target.yarn", format!("unknown yarn {other:?}; known: \"km2_600_denier\""))),
    }
}

/// Parses and validates case text; `source` names the file in errors.
pub fn parse_case(text: &str, source: &str) -> Result<Case, CaseError> {
    let text = json_document(text, source)?;
    let deserializer = &mut serde_json::Deserializer::from_str(text);
    let case: Case = serde_path_to_error::deserialize(deserializer).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.into_inner().to_string();
        if path == "." {
            return CaseError { path: source.to_string(), message: format!("{inner} (in {source})") };
        }
        match locate_field::<Case>(text, &path) {
            Some(field) => {
                CaseError { message: format!("{} (in {source})", relocated(&inner, text, &field)), path: field }
            }
            None => CaseError { path, message: format!("{inner} (in {source})") },
        }
    })?;
    case.validate().map_err(|e| CaseError { message: format!("{} (in {source})", e.message), ..e })?;
    Ok(case)
}

/// The first field (a dotted path below `path`, such as `run.end_time_s` below `""` or
/// `case.run.end_time_s` below `"case"`; fields in alphabetical order) at which two JSON
/// documents differ; `None` when they are equal. Names what keeps two cases apart where one
/// must continue or pool with the other.
pub fn first_difference(a: &serde_json::Value, b: &serde_json::Value, path: &str) -> Option<String> {
    match (a, b) {
        (serde_json::Value::Object(x), serde_json::Value::Object(y)) => {
            let mut keys: Vec<&String> = x.keys().chain(y.keys()).collect();
            keys.sort();
            keys.dedup();
            keys.into_iter().find_map(|key| {
                let inner = if path.is_empty() { key.clone() } else { format!("{path}.{key}") };
                match (x.get(key), y.get(key)) {
                    (Some(p), Some(q)) => first_difference(p, q, &inner),
                    _ => Some(inner),
                }
            })
        }
        _ if a == b => None,
        _ => Some(if path.is_empty() { "(the whole value)".to_string() } else { path.to_string() }),
    }
}

/// The field an error inside an internally tagged enum is about. serde reads such an enum
/// (a `target`, a `design`, a `boundary`) whole before it looks at its fields, so its errors
/// carry only the enum's own path. The culprit is the deepest field under `path` whose
/// removal, or replacement by a plain value of some type, makes the whole document read;
/// `None` when no single field does (two errors, or a wrong word the probes cannot mend: the
/// enum's path is then the best there is).
pub(crate) fn locate_field<T: serde::de::DeserializeOwned>(text: &str, path: &str) -> Option<String> {
    let document: serde_json::Value = serde_json::from_str(text).ok()?;
    // a dotted path as a JSON pointer (field names hold neither '/' nor '~')
    let pointer = |dotted: &[&str]| dotted.iter().map(|key| format!("/{key}")).collect::<String>();
    let base: Vec<&str> = path.split('.').collect();
    let mut candidates: Vec<Vec<String>> = Vec::new();
    fn walk(value: &serde_json::Value, prefix: &mut Vec<String>, out: &mut Vec<Vec<String>>) {
        if let serde_json::Value::Object(map) = value {
            for (key, child) in map {
                // the tag: without it every variant is wrong
                if key == "kind" {
                    continue;
                }
                prefix.push(key.clone());
                out.push(prefix.clone());
                walk(child, prefix, out);
                prefix.pop();
            }
        }
    }
    walk(document.pointer(&pointer(&base))?, &mut Vec::new(), &mut candidates);
    candidates.sort_by_key(|c| std::cmp::Reverse(c.len()));
    candidates.into_iter().find_map(|relative| {
        let (key, parents) = relative.split_last()?;
        let parent: Vec<&str> = base.iter().copied().chain(parents.iter().map(String::as_str)).collect();
        let parent = pointer(&parent);
        let probes = [
            None,
            Some(serde_json::json!(0)),
            Some(serde_json::json!(1)),
            Some(serde_json::json!(0.5)),
            Some(serde_json::json!("")),
            Some(serde_json::json!(false)),
            Some(serde_json::json!([])),
            Some(serde_json::json!({})),
            Some(serde_json::Value::Null),
        ];
        let fixed = probes.into_iter().any(|probe| {
            let mut trial = document.clone();
            let Some(map) = trial.pointer_mut(&parent).and_then(serde_json::Value::as_object_mut) else { return false };
            match probe {
                None => map.remove(key),
                Some(value) => map.insert(key.clone(), value),
            };
            serde_json::from_value::<T>(trial).is_ok()
        });
        fixed.then(|| format!("{path}.{}", relative.join(".")))
    })
}

/// An error `message` moved to `field`: serde's position (the end of the enclosing enum)
/// is replaced by the line of the field's key when the key occurs once in the text.
pub(crate) fn relocated(message: &str, text: &str, field: &str) -> String {
    let bare = message.rsplit_once(" at line ").map_or(message, |(head, _)| head);
    let key = format!("\"{}\"", field.rsplit('.').next().unwrap_or(field));
    let mut found = text.match_indices(&key);
    match (found.next(), found.next()) {
        (Some((at, _)), None) => format!("{bare} at line {}", text[..at].lines().count().max(1)),
        _ => bare.to_string(),
    }
}

/// The JSON document of a case or campaign file's `text`: a UTF-8 byte-order mark (which some
/// editors write) is skipped, and text that is not one JSON document (a syntax error, or
/// anything after the document, such as a second case) is refused with its line and column
/// before any field is looked at, so a syntax error is never reported as a field's.
pub fn json_document<'a>(text: &'a str, source: &str) -> Result<&'a str, CaseError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    match serde_json::from_str::<serde::de::IgnoredAny>(text) {
        Ok(_) => Ok(text),
        Err(e) => Err(invalid(source, format!("not one JSON document: {e}"))),
    }
}

/// The largest case or campaign file read [bytes]: a case is a page of JSON.
pub const MAX_INPUT_BYTES: u64 = 16 << 20;

/// The text of a case or campaign file: a regular file (a FIFO or a device such as
/// /dev/urandom could block or never end) of at most [`MAX_INPUT_BYTES`], in UTF-8.
pub fn read_input(path: &std::path::Path) -> Result<String, CaseError> {
    let source = path.display().to_string();
    let metadata = std::fs::metadata(path).map_err(|e| invalid(&source, format!("cannot read: {e}")))?;
    if !metadata.is_file() {
        return Err(invalid(&source, "not a regular file (a FIFO, a device or a directory cannot be a case)"));
    }
    if metadata.len() > MAX_INPUT_BYTES {
        return Err(invalid(
            &source,
            format!("{} bytes: larger than the {MAX_INPUT_BYTES} bytes a case or campaign may have", metadata.len()),
        ));
    }
    std::fs::read_to_string(path).map_err(|e| invalid(&source, format!("cannot read: {e}")))
}

/// Reads, parses and validates a case file; a relative mesh or cell file is taken relative to
/// the case file and made absolute (so that a checkpoint's copy of the case finds it too).
pub fn load_case(path: &std::path::Path) -> Result<Case, CaseError> {
    let text = read_input(path)?;
    let mut case = parse_case(&text, &path.display().to_string())?;
    let base = path.parent().map(std::path::Path::to_path_buf).unwrap_or_default();
    let (cell_file, coarse_cell_file) = match &mut case.target {
        TargetSpec::WovenPanel { cell_file, hybrid, .. } => {
            (cell_file.as_mut(), hybrid.as_mut().and_then(|h| h.cell_file.as_mut()))
        }
        TargetSpec::ThreeDWovenPanel { cell_file, .. } => (cell_file.as_mut(), None),
        _ => (None, None),
    };
    for file in [case.projectile.mesh_file.as_mut(), cell_file, coarse_cell_file]
        .into_iter()
        .flatten()
        .filter(|f| f.is_relative())
    {
        let joined = base.join(&*file);
        *file = std::path::absolute(&joined).unwrap_or(joined);
    }
    Ok(case)
}

/// The built-in default case: the validation set's 1 in panel (issue 31,
/// `jobs/campaigns/validation/panel-1in-4-layers.json`) struck at 300 m/s: a 25.4 mm square
/// of four layers of KM2 style 706, 4 digital fibres per yarn within 6 mm of the centre and 1
/// beyond (the unit cells relaxed on the spot), every fibre end fixed, settled for 5 us, then
/// struck at its centre by the 17-grain FSP (meshed, its measured edge radii resolved) until
/// it is through (about 36 us) or 100 us have passed. It is that campaign's first shot
/// (snapshots and the end time, never reached, aside) under the default rotating
/// fibre–projectile friction spring; the campaign keeps the seed's anchored one it was fired
/// with, which gives that shot bit for bit (docs/theory.md I6c, docs/validation.md). The
/// 10 mm patch it replaces is `cases/km2_706_patch.json`.
pub fn default_case() -> Case {
    Case {
        name: "default-km2-706-1in-panel".into(),
        material: MaterialSpec::default(),
        target: TargetSpec::WovenPanel {
            weave: WeaveSpec::default(),
            cell_file: None,
            side_m: 0.0254,
            layers: 4,
            layer_gap_m: 0.0,
            layer_shift_m: [0.0, 0.0],
            boundary: BoundarySpec::FixedEdges {},
            relaxation: RelaxationSpec::default(),
            hybrid: Some(Box::new(HybridSpec {
                fine_half_width_m: None,
                fine_radius_m: Some(0.006),
                fibres_per_yarn: Some(1),
                element_length_ratio: None,
                cell_file: None,
            })),
            rest_angle_law: None,
        },
        bending: default_bending(),
        contact: ContactSpec {
            law: "elasto_plastic_km2".into(),
            friction_coefficient: 0.3,
            projectile_friction_coefficient: 0.3,
            projectile_friction_spring: None,
            fibre_friction_spring: None,
            skin_m: None,
        },
        failure: FailureSpec {
            mode: "deterministic".into(),
            tensile_strength_pa: Some(3.8e9),
            shear_strength_pa: Some(0.7672e9),
            shear_measure: None,
            shear_gauge_diameters: None,
            tension_measure: None,
            tension_gauge_diameters: None,
            unload: None,
            weibull: None,
            seed: 1,
        },
        projectile: ProjectileSpec { preset: Some("fsp_17_grain".into()), velocity_m_s: 300.0, ..Default::default() },
        run: RunSpec {
            end_time_s: 100e-6,
            time_step_safety: 0.5,
            // the validation campaign's: the outcome is judged at each history sample
            history_interval_steps: 200,
            stop_on_perforation: true,
            snapshot_interval_steps: Some(2000),
            checkpoint_interval_steps: None,
            checkpoint_interval_minutes: default_checkpoint_minutes(),
            settle: Some(SettleSpec { time_s: 5e-6, damping_per_s: None }),
            multi_rate: false,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The 10 mm style 706 patch (`cases/km2_706_patch.json`, the built-in default until
    /// session 27), every field written out: one woven cell, no hybrid, no settle.
    fn default_json() -> serde_json::Value {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../cases/km2_706_patch.json");
        serde_json::to_value(load_case(&path).unwrap()).unwrap()
    }

    fn error_for(edit: impl FnOnce(&mut serde_json::Value)) -> CaseError {
        let mut value = default_json();
        edit(&mut value);
        parse_case(&value.to_string(), "case.json").unwrap_err()
    }

    #[test]
    fn a_checkpoint_continues_under_another_run_length_only() {
        let case: Case = serde_json::from_value(default_json()).unwrap();
        let mut longer = case.clone();
        longer.run.end_time_s *= 2.0;
        longer.run.checkpoint_interval_minutes = 5.0;
        longer.run.checkpoint_interval_steps = Some(1000);
        assert_eq!(case.continued_by(&longer), Ok(longer.clone()));
        // the default unloading named or left unsaid is the same case
        let mut named = case.clone();
        named.failure.unload = Some("at_break".into());
        assert_eq!(case.continued_by(&named), Ok(case.clone()));
        // and so with every choice whose default changed, named at today's defaults
        let named = case.with_named_choices();
        assert_eq!(named.failure.tension_measure.as_deref(), Some("gauge"));
        assert!(matches!(&named.target, TargetSpec::WovenPanel { rest_angle_law: Some(law), .. } if law == "smooth"));
        assert_eq!(case.continued_by(&named), Ok(case.clone()));
        assert_eq!(named.continued_by(&case), Ok(named.clone()));
        // a checkpoint from before the choices were named was stepped with the earlier
        // defaults, which today's case does not continue
        let earlier = case.with_earlier_defaults_named();
        assert_eq!(earlier.failure.tension_measure.as_deref(), Some("element"));
        assert!(matches!(&earlier.target, TargetSpec::WovenPanel { rest_angle_law: Some(law), .. } if law == "cone"));
        assert_eq!(earlier.continued_by(&case), Err("failure.tension_measure".to_string()));
        let mut seeds = case.clone();
        seeds.failure.tension_measure = Some("element".into());
        assert_eq!(earlier.continued_by(&seeds), Err("target.rest_angle_law".to_string()));
        if let TargetSpec::WovenPanel { rest_angle_law, .. } = &mut seeds.target {
            *rest_angle_law = Some("cone".into());
        }
        assert_eq!(earlier.continued_by(&seeds), Ok(earlier.clone()));
        // one that named them keeps its names
        assert_eq!(named.with_earlier_defaults_named(), named);
        let mut other = longer.clone();
        other.run.history_interval_steps += 1;
        assert_eq!(case.continued_by(&other), Err("run.history_interval_steps".to_string()));
        other.projectile.velocity_m_s += 1.0;
        assert_eq!(case.continued_by(&other), Err("projectile.velocity_m_s".to_string()));
    }

    #[test]
    fn an_error_inside_a_tagged_enum_names_its_field_and_line() {
        let e = error_for(|v| v["target"]["weave"]["fibres_per_yarn"] = "x".into());
        assert_eq!(e.path, "target.weave.fibres_per_yarn", "{e}");
        let e =
            error_for(|v| v["target"]["boundary"] = serde_json::json!({ "kind": "fixed_edges", "opening_m": 0.002 }));
        assert_eq!(e.path, "target.boundary.opening_m", "{e}");
        let e = error_for(|v| v["bending"]["k1"] = serde_json::json!([]));
        assert_eq!(e.path, "bending.k1", "{e}");
        // the line is the key's, not the end of the enclosing object's
        let mut value = default_json();
        value["target"]["layer_gap_m"] = "thin".into();
        let text = serde_json::to_string_pretty(&value).unwrap();
        let line = text.lines().position(|l| l.contains("\"layer_gap_m\"")).unwrap() + 1;
        let e = parse_case(&text, "case.json").unwrap_err();
        assert_eq!(e.path, "target.layer_gap_m", "{e}");
        assert!(e.message.contains(&format!("at line {line} (in case.json)")), "{e}");
        // a field that is missing is named by its parent and the message
        let e = error_for(|v| {
            v["target"]["weave"].as_object_mut().unwrap().remove("fibres_per_yarn");
        });
        assert!(e.path.starts_with("target") && e.message.contains("missing field `fibres_per_yarn`"), "{e}");
    }

    #[test]
    fn default_case_round_trips_and_validates() {
        let text = serde_json::to_string_pretty(&default_case()).unwrap();
        assert_eq!(parse_case(&text, "x").unwrap(), default_case());
    }

    #[test]
    fn sizes_beyond_any_projectile_or_fabric_are_refused_with_brief_numbers() {
        let e = error_for(|v| {
            v["projectile"] =
                serde_json::json!({ "shape": "fsp", "height_m": 1e300, "mass_kg": 1.1e-3, "velocity_m_s": 300.0 });
        });
        assert_eq!((e.path.as_str(), e.to_string().contains("got 1e300")), ("projectile.height_m", true), "{e}");
        let e = error_for(|v| {
            v["projectile"] = serde_json::json!({ "shape": "fsp", "flat_edge_radius_m": 1e-6, "mass_kg": 1.1e-3, "velocity_m_s": 300.0 });
        });
        assert_eq!(e.path, "projectile.flat_edge_radius_m", "a thousandth of the 5.46 mm diameter at least: {e}");
        let e = error_for(|v| {
            v["projectile"] =
                serde_json::json!({ "shape": "sphere", "diameter_m": 1e-3, "mass_kg": 1e-300, "velocity_m_s": 50.0 });
        });
        assert_eq!(e.path, "projectile.mass_kg");
        let e = error_for(|v| v["target"]["weave"]["yarn_spacing_m"] = 1.0.into());
        assert_eq!(e.path, "target.weave.yarn_spacing_m");
    }

    #[test]
    fn errors_name_the_field() {
        let e = error_for(|v| v["target"]["weave"]["fibres_per_yarn"] = 0.into());
        assert_eq!(e.path, "target.weave.fibres_per_yarn");
        assert!(e.message.contains("got 0"), "{e}");
        let e = error_for(|v| v["run"]["bogus"] = 1.into());
        assert_eq!(e.path, "run.bogus");
        assert!(e.message.contains("unknown field"), "{e}");
        let e = error_for(|v| v["contact"]["friction_coefficient"] = "high".into());
        assert_eq!(e.path, "contact.friction_coefficient");
        let e = error_for(|v| v["projectile"]["preset"] = "musket_ball".into());
        assert_eq!(e.path, "projectile.preset");
        let e = error_for(|v| v["failure"]["mode"] = "weibull".into());
        assert_eq!(e.path, "failure.weibull");
        let e = error_for(|v| v["run"]["end_time_s"] = (-1.0).into());
        assert_eq!(e.path, "run.end_time_s");
        // a stray field beside a variant without fields is refused, not dropped
        let e =
            error_for(|v| v["target"]["boundary"] = serde_json::json!({ "kind": "fixed_edges", "opening_m": 0.002 }));
        assert!(e.message.contains("unknown field `opening_m`"), "{e}");
        let e = error_for(|v| v["bending"] = serde_json::json!({ "model": "free", "k1": 0.8 }));
        assert!(e.message.contains("unknown field `k1`"), "{e}");
        let e = parse_case("{ not json", "broken.json").unwrap_err();
        assert!(e.to_string().contains("broken.json"), "{e}");
    }

    #[test]
    fn the_single_yarn_fixtures_fields_are_checked_by_name() {
        let fixture = |edit: &dyn Fn(&mut serde_json::Value)| {
            let mut value = default_json();
            value["target"] = serde_json::json!({
                "kind": "straight_yarn", "yarn": "km2_600_denier", "fibres_per_yarn": 16, "length_m": 0.0254,
                "element_length_ratio": 0.5, "packing": { "kind": "rectangular", "across_per_through": 4 },
                "ends": { "kind": "sliding", "mass_kg": 1e-6, "friction_force_n": 10.0 }, "hold_lateral": true
            });
            edit(&mut value);
            parse_case(&value.to_string(), "yarn.json").and_then(|case| case.resolve())
        };
        let resolved = fixture(&|_| {}).unwrap();
        let ResolvedTarget::Straight(target) = resolved.target else { panic!("a straight yarn") };
        assert_eq!(
            (target.rectangular_packing, target.sliding_ends, target.hold_lateral),
            (Some(4), Some((1e-6, 10.0)), true)
        );
        let e = fixture(&|v| v["target"]["fibres_per_yarn"] = 20.into()).unwrap_err();
        assert_eq!(e.path, "target.packing.across_per_through");
        assert!(e.message.contains("4, 16, 36, 64"), "{e}");
        let e = fixture(&|v| v["target"]["ends"]["mass_kg"] = 0.0.into()).unwrap_err();
        assert_eq!(e.path, "target.ends.mass_kg");
        let e = fixture(&|v| v["target"]["ends"]["friction_force_n"] = (-1.0).into()).unwrap_err();
        assert_eq!(e.path, "target.ends.friction_force_n");
        let e = fixture(&|v| v["target"]["ends"]["spring"] = 1.0.into()).unwrap_err();
        assert!(e.message.contains("unknown field `spring`"), "{e}");
        // absent fixture fields: today's yarn, hexagonal and clamped, and written as it was
        let plain = fixture(&|v| {
            let target = v["target"].as_object_mut().unwrap();
            target.remove("packing");
            target.remove("ends");
            target.remove("hold_lateral");
        })
        .unwrap();
        let ResolvedTarget::Straight(target) = plain.target else { panic!("a straight yarn") };
        assert_eq!((target.rectangular_packing, target.sliding_ends, target.hold_lateral), (None, None, false));
        let mut value = default_json();
        value["target"] = serde_json::json!({
            "kind": "straight_yarn", "yarn": "km2_600_denier", "fibres_per_yarn": 16, "length_m": 0.0254,
            "element_length_ratio": 0.5
        });
        let written = serde_json::to_string(&parse_case(&value.to_string(), "x.json").unwrap()).unwrap();
        assert!(!written.contains("packing") && !written.contains("hold_lateral"), "{written}");
    }

    #[test]
    fn values_beyond_any_impact_are_refused_naming_their_field() {
        let refused = |edit: &dyn Fn(&mut serde_json::Value), field: &str| {
            let mut value = default_json();
            edit(&mut value);
            let e = parse_case(&value.to_string(), "case.json").and_then(|c| c.resolve().map(drop)).unwrap_err();
            assert_eq!(e.path, field, "{e}");
        };
        refused(&|v| v["projectile"]["velocity_m_s"] = 1e200.into(), "projectile.velocity_m_s");
        refused(&|v| v["contact"]["friction_coefficient"] = 1e308.into(), "contact.friction_coefficient");
        refused(&|v| v["contact"]["friction_coefficient"] = 30.0.into(), "contact.friction_coefficient");
        refused(
            &|v| v["contact"]["projectile_friction_coefficient"] = 5.0.into(),
            "contact.projectile_friction_coefficient",
        );
        refused(&|v| v["projectile"]["offset_m"] = serde_json::json!([5.0, 0.0]), "projectile.offset_m.x");
        refused(&|v| v["target"]["layer_shift_m"] = serde_json::json!([0.0, 1.0]), "target.layer_shift_m.y");
        refused(&|v| v["target"]["layer_gap_m"] = 1.0.into(), "target.layer_gap_m");
        refused(&|v| v["run"]["end_time_s"] = 1.0.into(), "run.end_time_s");
        // the built-in default and an aim point off centre on the panel are fine
        let mut value = default_json();
        value["projectile"]["offset_m"] = serde_json::json!([0.004, -0.002]);
        parse_case(&value.to_string(), "case.json").unwrap().resolve().unwrap();
    }

    #[test]
    fn the_projectile_friction_spring_rotates_unless_the_seeds_anchor_is_asked_for() {
        use dea_core::friction::FrictionSpring;
        let spring = |edit: &dyn Fn(&mut serde_json::Value)| {
            let mut value = serde_json::to_value(default_case()).unwrap();
            edit(&mut value);
            parse_case(&value.to_string(), "x.json")
                .and_then(|case| case.resolve())
                .map(|r| r.projectile_friction_spring)
        };
        assert_eq!(spring(&|_| {}).unwrap(), FrictionSpring::Rotating);
        let named = |name: &str| spring(&|v| v["contact"]["projectile_friction_spring"] = name.into());
        assert_eq!(named("rotating").unwrap(), FrictionSpring::Rotating);
        assert_eq!(named("anchored").unwrap(), FrictionSpring::Anchored);
        let e = named("fixed").unwrap_err();
        assert_eq!(e.path, "contact.projectile_friction_spring", "{e}");
        assert!(e.to_string().contains("\"rotating\" or \"anchored\", got \"fixed\""), "{e}");
    }

    #[test]
    fn the_fibre_friction_spring_is_the_seeds_anchor_unless_the_projected_one_is_asked_for() {
        use dea_core::friction::FibreFrictionSpring;
        let spring = |edit: &dyn Fn(&mut serde_json::Value)| {
            let mut value = serde_json::to_value(default_case()).unwrap();
            edit(&mut value);
            parse_case(&value.to_string(), "x.json").and_then(|case| case.resolve()).map(|r| r.fibre_friction_spring)
        };
        assert_eq!(spring(&|_| {}).unwrap(), FibreFrictionSpring::Anchored);
        let named = |name: &str| spring(&|v| v["contact"]["fibre_friction_spring"] = name.into());
        assert_eq!(named("anchored").unwrap(), FibreFrictionSpring::Anchored);
        assert_eq!(named("projected").unwrap(), FibreFrictionSpring::Projected);
        for (name, says) in [("rotating", "keep one anchor per pair"), ("turned", "got \"turned\"")] {
            let e = named(name).unwrap_err();
            assert_eq!(e.path, "contact.fibre_friction_spring", "{e}");
            assert!(e.to_string().contains("\"anchored\" or \"projected\"") && e.to_string().contains(says), "{e}");
        }
    }

    #[test]
    fn broken_elements_unload_at_their_break_unless_the_next_step_is_asked_for() {
        use dea_core::failure::Unload;
        let unload = |edit: &dyn Fn(&mut serde_json::Value)| {
            let mut value = serde_json::to_value(default_case()).unwrap();
            edit(&mut value);
            parse_case(&value.to_string(), "x.json").and_then(|case| case.resolve()).map(|r| r.unload)
        };
        assert_eq!(unload(&|_| {}).unwrap(), Unload::AtBreak);
        let named = |name: &str| unload(&|v| v["failure"]["unload"] = name.into());
        assert_eq!(named("at_break").unwrap(), Unload::AtBreak);
        assert_eq!(named("next_step").unwrap(), Unload::NextStep);
        let e = named("later").unwrap_err();
        assert_eq!(e.path, "failure.unload", "{e}");
        assert!(e.to_string().contains("\"at_break\" or \"next_step\", got \"later\""), "{e}");
        // naming the default changes nothing but the name (a --restart with its case file)
        let case = default_case().with_named_choices();
        assert_eq!(case.failure.unload.as_deref(), Some("at_break"));
        let mut next = default_case().with_named_choices();
        next.failure.unload = Some("next_step".into());
        assert_eq!(next.with_named_choices(), next);
    }

    #[test]
    fn the_shear_measure_is_the_gauge_unless_the_seeds_element_form_is_asked_for() {
        use dea_core::shear_gauge::ShearMeasure;
        let measure = |edit: &dyn Fn(&mut serde_json::Value)| {
            let mut value = serde_json::to_value(default_case()).unwrap();
            edit(&mut value);
            parse_case(&value.to_string(), "x.json").and_then(|case| case.resolve()).map(|r| r.shear_measure)
        };
        assert_eq!(
            measure(&|_| {}).unwrap(),
            ShearMeasure::Gauge { diameters: resolve::DEFAULT_SHEAR_GAUGE_DIAMETERS }
        );
        assert_eq!(measure(&|v| v["failure"]["shear_measure"] = "element".into()).unwrap(), ShearMeasure::Element);
        assert_eq!(
            measure(&|v| v["failure"]["shear_gauge_diameters"] = 2.5.into()).unwrap(),
            ShearMeasure::Gauge { diameters: 2.5 }
        );
        let refused = |edit: &dyn Fn(&mut serde_json::Value), field: &str, words: &str| {
            let e = measure(edit).unwrap_err();
            assert_eq!(e.path, field, "{e}");
            assert!(e.to_string().contains(words), "{e}");
        };
        refused(
            &|v| v["failure"]["shear_measure"] = "nodal".into(),
            "failure.shear_measure",
            "\"gauge\" or \"element\"",
        );
        refused(&|v| v["failure"]["shear_gauge_diameters"] = 0.0.into(), "failure.shear_gauge_diameters", "got 0");
        refused(&|v| v["failure"]["shear_gauge_diameters"] = 50.0.into(), "failure.shear_gauge_diameters", "at most 8");
        refused(
            &|v| {
                v["failure"]["shear_measure"] = "element".into();
                v["failure"]["shear_gauge_diameters"] = 1.0.into();
            },
            "failure.shear_gauge_diameters",
            "no gauge",
        );
    }

    #[test]
    fn the_tension_measure_is_the_gauge_unless_the_seeds_element_form_is_asked_for() {
        use dea_core::tension_gauge::TensionMeasure;
        let measure = |edit: &dyn Fn(&mut serde_json::Value)| {
            let mut value = serde_json::to_value(default_case()).unwrap();
            edit(&mut value);
            parse_case(&value.to_string(), "x.json").and_then(|case| case.resolve()).map(|r| r.tension_measure)
        };
        let gauge = TensionMeasure::Gauge { diameters: resolve::DEFAULT_TENSION_GAUGE_DIAMETERS };
        assert_eq!(measure(&|_| {}).unwrap(), gauge);
        assert_eq!(measure(&|v| v["failure"]["tension_measure"] = "gauge".into()).unwrap(), gauge);
        assert_eq!(measure(&|v| v["failure"]["tension_measure"] = "element".into()).unwrap(), TensionMeasure::Element);
        assert_eq!(
            measure(&|v| v["failure"]["tension_gauge_diameters"] = 2.5.into()).unwrap(),
            TensionMeasure::Gauge { diameters: 2.5 }
        );
        assert_eq!(
            measure(&|v| {
                v["failure"]["tension_measure"] = "gauge".into();
                v["failure"]["tension_gauge_diameters"] = 2.5.into();
            })
            .unwrap(),
            TensionMeasure::Gauge { diameters: 2.5 }
        );
        let refused = |edit: &dyn Fn(&mut serde_json::Value), field: &str, words: &str| {
            let e = measure(edit).unwrap_err();
            assert_eq!(e.path, field, "{e}");
            assert!(e.to_string().contains(words), "{e}");
        };
        let gauge = |diameters: f64| {
            move |v: &mut serde_json::Value| {
                v["failure"]["tension_measure"] = "gauge".into();
                v["failure"]["tension_gauge_diameters"] = diameters.into();
            }
        };
        refused(
            &|v| v["failure"]["tension_measure"] = "nodal".into(),
            "failure.tension_measure",
            "\"gauge\" or \"element\"",
        );
        refused(&gauge(0.0), "failure.tension_gauge_diameters", "got 0");
        refused(&gauge(-1.0), "failure.tension_gauge_diameters", "got -1");
        refused(&gauge(50.0), "failure.tension_gauge_diameters", "at most 8");
        // a gauge length without the gauge would be silently ignored
        refused(
            &|v| {
                v["failure"]["tension_measure"] = "element".into();
                v["failure"]["tension_gauge_diameters"] = 1.0.into();
            },
            "failure.tension_gauge_diameters",
            "no gauge",
        );
    }

    #[test]
    fn projectile_fields_are_checked_and_name_themselves() {
        let fsp = |edit: &dyn Fn(&mut serde_json::Value)| {
            error_for(|v| {
                v["projectile"] = serde_json::json!({ "shape": "fsp", "mass_kg": 1.1e-3, "velocity_m_s": 300.0 });
                edit(v);
            })
        };
        let e = fsp(&|v| v["projectile"]["flat_width_m"] = 6e-3.into());
        assert_eq!(e.path, "projectile");
        assert!(e.message.contains("flat width"), "{e}");
        let e = fsp(&|v| v["projectile"]["bevel_angle_deg"] = (-5.0).into());
        assert_eq!(e.path, "projectile.bevel_angle_deg");
        let e = error_for(|v| {
            v["projectile"] = serde_json::json!({ "shape": "sphere", "diameter_m": 1e-3, "mesh_divisions": 4, "mass_kg": 1e-6, "velocity_m_s": 50.0,
                "deformable": { "youngs_modulus_pa": 2e9, "poisson_ratio": 0.3, "model": "rubbery" } });
        });
        assert_eq!(e.path, "projectile.deformable.model");
        let e = fsp(&|v| v["projectile"]["obliquity_deg"] = 85.0.into());
        assert_eq!(e.path, "projectile.obliquity_deg");
        let e = fsp(&|v| v["projectile"]["mesh_divisions"] = 1.into());
        assert_eq!(e.path, "projectile.mesh_divisions");
        let e = fsp(&|v| v["projectile"]["mesh_file"] = "body.stl".into());
        assert_eq!(e.path, "projectile.mesh_file");
        let e = fsp(&|v| v["projectile"]["shape"] = "file".into());
        assert_eq!((e.path.as_str(), e.message.as_str()), ("projectile.mesh_file", "is required here (in case.json)"));
        let e = fsp(&|v| v["projectile"].as_object_mut().unwrap().remove("mass_kg").map(drop).unwrap_or(()));
        assert_eq!(e.path, "projectile.mass_kg");
        // the FSP preset: 17 grains, meshed with the default divisions, the standard shape
        let case = default_case();
        let resolved = case.projectile().unwrap();
        assert!((resolved.mass - 1.1016e-3).abs() < 1e-7, "{}", resolved.mass);
        assert_eq!(
            resolved.body,
            ProjectileBody::Generated {
                solid: Solid::Fsp(FspDimensions::SEVENTEEN_GRAIN),
                divisions: DEFAULT_FSP_DIVISIONS
            }
        );
        // a sphere is analytic unless meshed
        let mut sphere = case.clone();
        sphere.projectile = ProjectileSpec {
            shape: Some("sphere".into()),
            diameter_m: Some(1e-3),
            mass_kg: Some(1e-6),
            velocity_m_s: 10.0,
            ..Default::default()
        };
        assert!(matches!(sphere.projectile().unwrap().body, ProjectileBody::Analytic(RigidShape::Sphere { .. })));
        sphere.projectile.mesh_divisions = Some(4);
        assert_eq!(
            sphere.projectile().unwrap().body,
            ProjectileBody::Generated { solid: Solid::Sphere { radius: 0.5e-3 }, divisions: 4 }
        );
    }

    #[test]
    fn three_d_weave_cells_name_their_bad_fields() {
        let weave = |edit: &dyn Fn(&mut serde_json::Value)| {
            error_for(|v| {
                v["target"] = serde_json::json!({ "kind": "three_d_weave_cell", "weave": { "pattern": "orthogonal", "filler_layers": 3, "pick_spacing_m": 1e-3,
                    "end_spacing_m": 1e-3, "filler": { "area_m2": 4.63e-8, "section_aspect": 3.0 }, "filler_fibres": 4 } });
                edit(v);
            })
        };
        // serde reads a tagged target whole; the error is placed at its field all the same
        let e = weave(&|v| v["target"]["weave"]["pattern"] = "satin".into());
        assert!(
            e.path == "target.weave.pattern" && e.message.contains("satin") && e.message.contains("layer_to_layer"),
            "{e}"
        );
        let e =
            weave(&|v| v["target"]["weave"]["columns"] = serde_json::json!([[{ "role": "binder", "gaps": [3, 0] }]]));
        assert_eq!(
            (e.path.as_str(), e.message.as_str()),
            ("target.weave.columns", "give a pattern or columns, not both (in case.json)")
        );
        let e = weave(&|v| v["target"]["weave"]["filler_layers"] = 1.into());
        assert_eq!(e.path, "target.weave.filler_layers");
        let e =
            weave(&|v| v["target"]["weave"]["binder"] = serde_json::json!({ "area_m2": 0.0, "section_aspect": 2.0 }));
        assert_eq!(e.path, "target.weave.binder.area_m2");
        let e = weave(&|v| v["target"]["weave"]["filler_fibres"] = 0.into());
        assert_eq!(e.path, "target.weave.filler_fibres");
        let e = weave(&|v| {
            v["target"]["weave"].as_object_mut().unwrap().remove("pattern");
            v["target"]["weave"]["columns"] =
                serde_json::json!([[{ "role": "stuffer", "gaps": [1, 1] }, { "role": "binder", "gaps": [3, 0] }]]);
        });
        assert_eq!(e.path, "target.weave");
        assert!(e.message.contains("columns[0][1]") && e.message.contains("cross"), "{e}");
        let e = weave(&|v| v["target"]["relaxation"] = serde_json::json!({ "tolerance": 0.5 }));
        assert_eq!(e.path, "target.relaxation.tolerance");
        // the same weave tiled into a panel
        let panel = |edit: &dyn Fn(&mut serde_json::Value)| {
            weave(&|v| {
                v["target"]["kind"] = "three_d_woven_panel".into();
                v["target"]["side_m"] = 6e-3.into();
                edit(v);
            })
        };
        let e = panel(&|v| v["target"]["cell_file"] = "cell.h5".into());
        assert_eq!(e.path, "target.weave");
        let e = panel(&|v| v["target"].as_object_mut().unwrap().remove("weave").map(drop).unwrap_or(()));
        assert_eq!(
            (e.path.as_str(), e.message.as_str()),
            ("target.weave", "is needed unless target.cell_file gives the relaxed cell (in case.json)")
        );
        let e = panel(&|v| v["target"]["side_m"] = 0.0.into());
        assert_eq!(e.path, "target.side_m");
        let e = panel(&|v| v["target"]["layers"] = 0.into());
        assert_eq!(e.path, "target.layers");
        let e = panel(&|v| v["target"]["layer_gap_m"] = (-1e-6).into());
        assert_eq!(e.path, "target.layer_gap_m");
        let e = panel(&|v| v["target"]["boundary"] = serde_json::json!({ "kind": "clamp", "opening_m": 7e-3 }));
        assert_eq!(e.path, "target.boundary.opening_m");
        let e = panel(&|v| v["target"]["weave"]["filler_fibres"] = 500.into());
        assert_eq!(e.path, "target.weave.filler_fibres");
    }

    #[test]
    fn woven_targets_name_their_bad_fields() {
        let e = error_for(|v| v["target"]["layers"] = 0.into());
        assert_eq!(e.path, "target.layers");
        let e = error_for(|v| v["target"]["weave"]["preset"] = "style_999".into());
        assert_eq!(e.path, "target.weave.preset");
        let e = error_for(|v| v["target"]["weave"]["section_aspect"] = 0.5.into());
        assert_eq!(e.path, "target.weave.section_aspect");
        let e = error_for(|v| v["target"]["weave"]["yarn_tension_n"] = (-1.0).into());
        assert_eq!(e.path, "target.weave.yarn_tension_n");
        let e = error_for(|v| v["target"]["boundary"] = serde_json::json!({ "kind": "clamp", "opening_m": 0.02 }));
        assert_eq!(e.path, "target.boundary.opening_m");
        assert!(e.message.contains("smaller than the panel"), "{e}");
        let e = error_for(|v| v["target"]["boundary"] = serde_json::json!({ "kind": "glued" }));
        assert!(e.path.starts_with("target") && e.message.contains("glued") && e.message.contains("clamp"), "{e}");
        let e = error_for(|v| v["target"]["relaxation"] = serde_json::json!({ "max_iterations": 0 }));
        assert_eq!(e.path, "target.relaxation.max_iterations");
        let e = error_for(|v| {
            v["target"]["cell_file"] = "cell.h5".into();
            v["target"]["weave"]["fibres_per_yarn"] = 7.into();
        });
        assert_eq!(e.path, "target.weave");
        let e = error_for(|v| v["target"]["layer_gap"] = 0.into());
        assert!(e.path.starts_with("target") && e.message.contains("unknown field"), "{e}");
    }

    #[test]
    fn hybrid_targets_and_settles_name_their_bad_fields() {
        let hybrid = |h: serde_json::Value| move |v: &mut serde_json::Value| v["target"]["hybrid"] = h.clone();
        let ok = |f: &dyn Fn(&mut serde_json::Value)| {
            let mut v = default_json();
            f(&mut v);
            parse_case(&v.to_string(), "case.json")
        };
        assert!(ok(&hybrid(serde_json::json!({ "fine_half_width_m": 0.002, "fibres_per_yarn": 1 }))).is_ok());
        let e = error_for(hybrid(serde_json::json!({ "fine_half_width_m": 0.002, "fibres_per_yarn": 4 })));
        assert_eq!(e.path, "target.hybrid.fibres_per_yarn");
        assert!(e.message.contains("fewer than the fine yarns' 4"), "{e}");
        let e = error_for(hybrid(serde_json::json!({ "fine_half_width_m": 0.002 })));
        assert_eq!(e.path, "target.hybrid.fibres_per_yarn");
        let e = error_for(hybrid(serde_json::json!({ "fine_half_width_m": 0.005, "fibres_per_yarn": 1 })));
        assert_eq!(e.path, "target.hybrid.fine_half_width_m");
        let e = error_for(hybrid(
            serde_json::json!({ "fine_half_width_m": 0.002, "fibres_per_yarn": 1, "element_length_ratio": 9.0 }),
        ));
        assert_eq!(e.path, "target.hybrid.element_length_ratio");
        let e = error_for(hybrid(
            serde_json::json!({ "fine_half_width_m": 0.002, "fibres_per_yarn": 1, "cell_file": "coarse.h5" }),
        ));
        assert_eq!(e.path, "target.hybrid.cell_file");
        let e = error_for(|v| {
            v["target"].as_object_mut().unwrap().remove("weave");
            v["target"]["cell_file"] = "cell.h5".into();
            v["target"]["hybrid"] = serde_json::json!({ "fine_half_width_m": 0.002, "fibres_per_yarn": 1 });
        });
        assert_eq!(e.path, "target.hybrid.cell_file");
        let e = error_for(hybrid(
            serde_json::json!({ "fine_half_width_m": 0.002, "fine_radius_m": 0.002, "fibres_per_yarn": 1 }),
        ));
        assert_eq!(e.path, "target.hybrid");
        let e = error_for(hybrid(serde_json::json!({ "fibres_per_yarn": 1 })));
        assert_eq!(e.path, "target.hybrid");
        assert!(ok(&hybrid(serde_json::json!({ "fine_radius_m": 0.004, "fibres_per_yarn": 1 }))).is_ok());
        let e = error_for(hybrid(serde_json::json!({ "fine_radius_m": 0.01, "fibres_per_yarn": 1 })));
        assert_eq!(e.path, "target.hybrid.fine_radius_m");
        let e = error_for(hybrid(serde_json::json!({ "fine_radius_m": -1.0, "fibres_per_yarn": 1 })));
        assert_eq!(e.path, "target.hybrid.fine_radius_m");
        let e = error_for(hybrid(serde_json::json!({ "fine_half_width_m": 0.002, "fibres": 1 })));
        assert!(e.path.starts_with("target") && e.message.contains("unknown field"), "{e}");
        let e = error_for(|v| v["run"]["settle"] = serde_json::json!({ "time_s": -1e-6 }));
        assert_eq!(e.path, "run.settle.time_s");
        let e = error_for(|v| v["run"]["settle"] = serde_json::json!({ "time_s": 1e-6, "damping_per_s": 0.0 }));
        assert_eq!(e.path, "run.settle.damping_per_s");
        let settle = SettleSpec { time_s: 2e-6, damping_per_s: None };
        assert_eq!(settle.damping(), 5e6);
    }

    #[test]
    fn the_rest_angle_law_is_named_and_needs_springs_bent_at_rest() {
        use dea_core::bending::RestAngleLaw;
        let with = |law: &'static str| move |v: &mut serde_json::Value| v["target"]["rest_angle_law"] = law.into();
        let law_of = |f: &dyn Fn(&mut serde_json::Value)| {
            let mut v = default_json();
            f(&mut v);
            parse_case(&v.to_string(), "case.json").unwrap().resolve().unwrap().rest_angle_law
        };
        assert_eq!(law_of(&|_| {}), RestAngleLaw::Smooth);
        assert_eq!(law_of(&with("cone")), RestAngleLaw::Cone);
        assert_eq!(law_of(&with("smooth")), RestAngleLaw::Smooth);
        let e = error_for(with("quartic"));
        assert_eq!(e.path, "target.rest_angle_law");
        assert!(e.message.contains("\"smooth\" or \"cone\", got \"quartic\""), "{e}");
        // where every spring rests straight the laws coincide: nothing to default, nothing named
        let straight = |v: &mut serde_json::Value| v["target"]["weave"]["bending_at_rest"] = "straight".into();
        assert_eq!(law_of(&straight), RestAngleLaw::Cone);
        let mut v = default_json();
        straight(&mut v);
        let case = parse_case(&v.to_string(), "case.json").unwrap();
        assert!(!case.takes_rest_angle_law());
        assert_eq!(serde_json::to_value(case.with_named_choices()).unwrap()["target"].get("rest_angle_law"), None);
        let e = error_for(|v| {
            with("smooth")(v);
            v["target"]["weave"]["bending_at_rest"] = "straight".into();
        });
        assert_eq!(e.path, "target.rest_angle_law");
        assert!(e.message.contains("every spring rests straight"), "{e}");
        // a cell file carries its rest angles; the law is the solver's and goes with it
        let from_file = |v: &mut serde_json::Value| {
            v["target"].as_object_mut().unwrap().remove("weave");
            v["target"]["cell_file"] = "relaxed/cell.h5".into();
            v["target"]["rest_angle_law"] = "smooth".into();
        };
        assert_eq!(law_of(&from_file), RestAngleLaw::Smooth);
    }

    #[test]
    fn a_relative_cell_file_is_found_beside_the_case() {
        let dir = std::env::temp_dir().join(format!("dea-case-cell-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut value = default_json();
        value["target"].as_object_mut().unwrap().remove("weave");
        value["target"]["cell_file"] = "relaxed/cell.h5".into();
        std::fs::write(dir.join("case.json"), value.to_string()).unwrap();
        let case = load_case(&dir.join("case.json")).unwrap();
        let TargetSpec::WovenPanel { cell_file: Some(file), .. } = case.target else {
            panic!("a woven target with a cell file")
        };
        assert!(file.is_absolute() && file.ends_with("relaxed/cell.h5"), "{}", file.display());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_relative_mesh_file_is_found_beside_the_case() {
        let dir = std::env::temp_dir().join(format!("dea-case-mesh-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut value = default_json();
        value["projectile"] =
            serde_json::json!({ "shape": "file", "mesh_file": "body.stl", "mass_kg": 1e-3, "velocity_m_s": 100.0 });
        std::fs::write(dir.join("case.json"), value.to_string()).unwrap();
        let case = load_case(&dir.join("case.json")).unwrap();
        let file = case.projectile.mesh_file.unwrap();
        assert!(
            file.is_absolute()
                && file.ends_with("body.stl")
                && file.parent().unwrap().ends_with(dir.file_name().unwrap()),
            "{}",
            file.display()
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn yarn_preset_is_600_denier() {
        // 600 denier = 600 g / 9000 m; at 1440 kg/m^3 that is 4.63e-8 m^2 (PHYSICS.md §8)
        assert!((KM2_600_DENIER_AREA - 4.63e-8).abs() < 0.01e-8);
    }
}
