//! Fabric geometry at near-fibre level: digital fibres packed in a yarn section and laid out
//! as straight chains (single fibres, straight yarns, crossing layers of straight yarns), or
//! woven: a plain-weave unit cell ([`weave`]) relaxed with periodic boundaries ([`relax`]) and
//! tiled into panels of stacked layers ([`panel`]).

pub mod cell;
pub mod panel;
pub mod relax;
pub mod tiled;
pub mod transition;
pub mod weave;
pub mod weave3d;

use panel::Tiling;

use dea_core::material::SectionInertia;
use dea_core::nodes::FailureMode;
use dea_core::{Elements, FibreId, FibreMaterial, FibreSection, GlobalNodeId, Nodes, Vec3};

/// Direction of a straight yarn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Axis {
    /// along x
    X,
    /// along y
    Y,
}

/// One straight yarn: digital fibres packed hexagonally around an axis.
#[derive(Clone, Debug, PartialEq)]
pub struct YarnLine {
    /// centre of the yarn's axis [m]
    pub centre: Vec3,
    /// the direction the yarn runs along
    pub axis: Axis,
    /// digital fibres in the yarn
    pub fibres: usize,
    /// layer of the panel the yarn lies in (0 on top)
    pub layer: u32,
}

/// A fabric of straight yarns of equal length: a single fibre, a yarn, or crossing layers
/// of yarns. Every node is a pure function of (yarn, fibre, position along the fibre), so a
/// rank can generate exactly the nodes it owns without building the rest.
#[derive(Clone, Debug, PartialEq)]
pub struct StraightFabric {
    /// the yarns, each a straight bundle of digital fibres
    pub yarns: Vec<YarnLine>,
    /// length of every yarn [m]
    pub length: f64,
    /// cross-section area of one digital fibre [m^2]
    pub fibre_area: f64,
    /// target element length / digital fibre diameter [-] (seed §6.1: 0.5 converges)
    pub element_length_ratio: f64,
    /// bending model of (5-7)…(5-10), its friction weight applied
    pub inertia: SectionInertia,
    /// tensile strength given to every element before any Weibull sampling [Pa]
    pub tensile_strength: f64,
    /// clamp both ends of every fibre
    pub clamp_ends: bool,
    /// how the fibres sit in each yarn's section
    pub packing: SectionPacking,
    /// mass added at each end of every yarn, shared equally by its fibres' end nodes: the
    /// single-yarn fixture's sliding masses (seed §5.3) [kg]
    pub end_mass: f64,
}

/// How a straight yarn's digital fibres sit in its section.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum SectionPacking {
    /// rings around the axis ([`hexagonal_packing`])
    #[default]
    Hexagonal,
    /// rows on a square lattice with this many times as many fibres across the yarn as
    /// through it ([`rectangular_packing`])
    Rectangular {
        /// fibres across the yarn per fibre through it
        across_per_through: usize,
    },
}

/// Centres of `count` circles of diameter `pitch` on a square lattice, `across_per_through`
/// times as many across (the first coordinate) as through (the second), centred; row by
/// row from the top. `count` must be `across_per_through` times a square (the case checks)
/// [m, m].
pub fn rectangular_packing(count: usize, across_per_through: usize, pitch: f64) -> Vec<[f64; 2]> {
    let through = ((count as f64 / across_per_through as f64).sqrt().round() as usize).max(1);
    let across = count / through;
    let centre = |i: usize, n: usize| (i as f64 - 0.5 * (n as f64 - 1.0)) * pitch;
    (0..through).rev().flat_map(|t| (0..across).map(move |a| [centre(a, across), centre(t, through)])).collect()
}

/// Built geometry, ready for a [`dea_core::Domain`].
pub struct Built {
    /// the fibre sections the nodes refer to
    pub sections: Vec<FibreSection>,
    /// the nodes, ascending global id
    pub nodes: Nodes,
    /// the element starting at each node
    pub elements: Elements,
    /// the ties with a built end (docs/theory.md F12)
    pub ties: Vec<dea_core::tie::Tie>,
}

/// Centres of `count` circles of diameter `pitch` in a hexagonal close packing, filled ring by
/// ring from the centre (1, 7, 19, 37 … fill complete rings) [m, m].
pub fn hexagonal_packing(count: usize, pitch: f64) -> Vec<[f64; 2]> {
    let rings = (0..).find(|&r: &i64| (3 * r * (r + 1) + 1) as usize >= count).unwrap_or(0) + 1;
    let mut points = Vec::new();
    for a in -rings..=rings {
        for b in -rings..=rings {
            let (x, y) = (a as f64 + 0.5 * b as f64, b as f64 * 3f64.sqrt() / 2.0);
            points.push((a, b, x * pitch, y * pitch));
        }
    }
    // ring order, then angle, then lattice indices: a total, platform-independent order
    points.sort_by(|p, q| {
        let (rp, rq) = (p.2.hypot(p.3), q.2.hypot(q.3));
        (rp / pitch)
            .round()
            .total_cmp(&(rq / pitch).round())
            .then(rp.total_cmp(&rq))
            .then(p.3.atan2(p.2).total_cmp(&q.3.atan2(q.2)))
            .then((p.0, p.1).cmp(&(q.0, q.1)))
    });
    points.truncate(count);
    points.into_iter().map(|p| [p.2, p.3]).collect()
}

impl StraightFabric {
    /// One yarn of `fibres` digital fibres along x, centred on the origin.
    pub fn single_yarn(
        length: f64,
        fibres: usize,
        fibre_area: f64,
        element_length_ratio: f64,
        inertia: SectionInertia,
        tensile_strength: f64,
    ) -> Self {
        Self {
            yarns: vec![YarnLine { centre: Vec3::zeros(), axis: Axis::X, fibres, layer: 0 }],
            length,
            fibre_area,
            element_length_ratio,
            inertia,
            tensile_strength,
            clamp_ends: true,
            packing: SectionPacking::Hexagonal,
            end_mass: 0.0,
        }
    }

    /// `layers` layers of `yarns_per_layer` touching parallel yarns, along x in even layers
    /// and y in odd ones, layers touching; the top of layer 0 at the origin's height less
    /// half a yarn. Yarns sit at the pitch of their envelope (packing radius plus half a
    /// contact diameter, on both sides).
    #[allow(clippy::too_many_arguments)]
    pub fn cross_ply(
        layers: usize,
        yarns_per_layer: usize,
        fibres: usize,
        length: f64,
        fibre_area: f64,
        element_length_ratio: f64,
        inertia: SectionInertia,
        tensile_strength: f64,
        material: &FibreMaterial,
    ) -> Self {
        let mut fabric = Self::single_yarn(length, fibres, fibre_area, element_length_ratio, inertia, tensile_strength);
        let pitch = fabric.yarn_envelope_diameter(material);
        fabric.yarns = (0..layers)
            .flat_map(|l| {
                (0..yarns_per_layer).map(move |j| {
                    let across = (j as f64 - 0.5 * (yarns_per_layer as f64 - 1.0)) * pitch;
                    let z = -(l as f64) * pitch;
                    let (centre, axis) = if l % 2 == 0 {
                        (Vec3::new(0.0, across, z), Axis::X)
                    } else {
                        (Vec3::new(across, 0.0, z), Axis::Y)
                    };
                    YarnLine { centre, axis, fibres, layer: l as u32 }
                })
            })
            .collect();
        fabric
    }

    /// Elements per fibre.
    pub fn elements_per_fibre(&self) -> usize {
        (self.fibre_length_in_elements().round() as usize).max(1)
    }

    /// The fibre length over the element length the ratio asks for (unrounded; a size check
    /// reads it before anything is numbered).
    pub fn fibre_length_in_elements(&self) -> f64 {
        let diameter = (4.0 * self.fibre_area / std::f64::consts::PI).sqrt();
        self.length / (self.element_length_ratio * diameter)
    }

    /// Fibres of every yarn.
    pub fn fibre_total(&self) -> usize {
        self.yarns.iter().map(|y| y.fibres).sum()
    }

    /// Nodes per fibre (the same on every fibre).
    pub fn nodes_per_fibre(&self) -> u32 {
        self.elements_per_fibre() as u32 + 1
    }

    /// The one section every fibre has.
    pub fn section(&self, material: &FibreMaterial) -> FibreSection {
        FibreSection::new(material, self.fibre_area, self.length / self.elements_per_fibre() as f64, self.inertia)
    }

    /// Diameter of the circle enclosing a yarn's fibres (contact diameter included) [m].
    pub fn yarn_envelope_diameter(&self, material: &FibreMaterial) -> f64 {
        let contact = self.section(material).contact_diameter;
        let Some(yarn) = self.yarns.first() else { return contact };
        let radius = self.packing(yarn, material).iter().map(|p| p[0].hypot(p[1])).fold(0.0, f64::max);
        2.0 * radius + contact
    }

    /// Global fibre id of each yarn's first fibre, plus the total at the end.
    pub fn first_fibres(&self) -> Vec<u32> {
        std::iter::once(0)
            .chain(self.yarns.iter().scan(0u32, |total, y| {
                *total += y.fibres as u32;
                Some(*total)
            }))
            .collect()
    }

    /// Centres of a yarn's fibres in its cross-section: (across, z) offsets [m].
    pub fn packing(&self, yarn: &YarnLine, material: &FibreMaterial) -> Vec<[f64; 2]> {
        let pitch = self.section(material).contact_diameter;
        match self.packing {
            SectionPacking::Hexagonal => hexagonal_packing(yarn.fibres, pitch),
            SectionPacking::Rectangular { across_per_through } => {
                rectangular_packing(yarn.fibres, across_per_through, pitch)
            }
        }
    }

    /// Position of node `k` of fibre `fibre` of yarn `yarn` [m].
    fn position(&self, yarn: &YarnLine, offset: [f64; 2], k: u32, element_length: f64) -> Vec3 {
        let along = -0.5 * self.length + k as f64 * element_length;
        match yarn.axis {
            Axis::X => yarn.centre + Vec3::new(along, offset[0], offset[1]),
            Axis::Y => yarn.centre + Vec3::new(-offset[0], along, offset[1]),
        }
    }

    /// Highest node centre of the fabric [m].
    pub fn top(&self, material: &FibreMaterial) -> f64 {
        self.yarns
            .iter()
            .map(|y| y.centre.z + self.packing(y, material).iter().map(|p| p[1]).fold(f64::NEG_INFINITY, f64::max))
            .fold(f64::NEG_INFINITY, f64::max)
    }

    /// Lowest node centre of the fabric [m].
    pub fn bottom(&self, material: &FibreMaterial) -> f64 {
        self.yarns
            .iter()
            .map(|y| y.centre.z + self.packing(y, material).iter().map(|p| p[1]).fold(f64::INFINITY, f64::min))
            .fold(f64::INFINITY, f64::min)
    }

    /// Axis-aligned box of the node centres of yarn `yarn` between positions `first` and
    /// `last` (inclusive) along its fibres [m].
    pub fn segment_box(&self, yarn: usize, first: u32, last: u32, material: &FibreMaterial) -> (Vec3, Vec3) {
        let y = &self.yarns[yarn];
        let element_length = self.length / self.elements_per_fibre() as f64;
        let (mut low, mut high) = (Vec3::repeat(f64::INFINITY), Vec3::repeat(f64::NEG_INFINITY));
        for offset in self.packing(y, material) {
            for k in [first, last] {
                let p = self.position(y, offset, k, element_length);
                low = low.inf(&p);
                high = high.sup(&p);
            }
        }
        (low, high)
    }

    /// Builds the nodes `keep(yarn, k)` selects (position `k` along every fibre of the
    /// yarn), ascending global id: fibre f, node k has global id `f * nodes_per_fibre + k`.
    /// Interior nodes carry `rho A l0`, chain ends half of it; every element has the rest
    /// length l0.
    pub fn build(&self, material: &FibreMaterial, keep: impl Fn(usize, u32) -> bool) -> Built {
        let section = self.section(material);
        let nodes_per_fibre = self.nodes_per_fibre();
        let last = nodes_per_fibre - 1;
        let interior_mass = section.node_mass(material);
        // an end node's share of its yarn end's mass
        let end_share = |yarn: &YarnLine| self.end_mass / yarn.fibres as f64;
        let first_fibres = self.first_fibres();
        let mut nodes = Nodes::default();
        let mut elements = Elements::default();
        for (y, yarn) in self.yarns.iter().enumerate() {
            let kept: Vec<u32> = (0..nodes_per_fibre).filter(|&k| keep(y, k)).collect();
            if kept.is_empty() {
                continue;
            }
            for (f, offset) in self.packing(yarn, material).into_iter().enumerate() {
                let fibre = first_fibres[y] + f as u32;
                for &k in &kept {
                    let end = k == 0 || k == last;
                    nodes.push(
                        GlobalNodeId(fibre as u64 * nodes_per_fibre as u64 + k as u64),
                        self.position(yarn, offset, k, section.element_length),
                        Vec3::zeros(),
                        if end { 0.5 * interior_mass + end_share(yarn) } else { interior_mass },
                        FibreId(fibre),
                        k,
                        0,
                        end && self.clamp_ends,
                        k == last,
                    );
                    elements.push(
                        if k == last { 0.0 } else { section.element_length },
                        self.tensile_strength,
                        FailureMode::Intact,
                    );
                }
            }
        }
        nodes.n_owned = nodes.len();
        nodes.link_chains();
        Built { sections: vec![section], nodes, elements, ties: Vec::new() }
    }

    /// Builds every node (a whole domain, for single-domain use and tests).
    pub fn build_all(&self, material: &FibreMaterial) -> Built {
        self.build(material, |_, _| true)
    }
}

/// The target of a run: straight fibres and yarns, or a woven panel. Everything the
/// partitioner and the set-up need, with no node built.
#[derive(Clone, Debug, PartialEq)]
pub enum Fabric {
    /// straight yarns (the single-yarn fixture and the bench)
    Straight(StraightFabric),
    /// a plain-woven panel, whole or hybrid
    Woven(panel::WovenPanel),
    /// a panel tiled from any periodic cell (a 3-D weave's)
    Tiled(tiled::TiledPanel),
}

impl Fabric {
    /// Yarns of the target.
    pub fn yarn_count(&self) -> usize {
        match self {
            Fabric::Straight(f) => f.yarns.len(),
            Fabric::Woven(p) => p.yarn_count(),
            Fabric::Tiled(p) => p.yarn_count(),
        }
    }

    /// Digital fibres of yarn `yarn`.
    pub fn yarn_fibres(&self, yarn: usize) -> usize {
        match self {
            Fabric::Straight(f) => f.yarns[yarn].fibres,
            Fabric::Woven(p) => p.yarn_fibres(yarn),
            Fabric::Tiled(p) => p.yarn_fibres(yarn),
        }
    }

    /// Layer of yarn `yarn` (0 on top).
    pub fn yarn_layer(&self, yarn: usize) -> u32 {
        match self {
            Fabric::Straight(f) => f.yarns[yarn].layer,
            Fabric::Woven(p) => p.place(yarn).layer,
            Fabric::Tiled(p) => p.layer(yarn),
        }
    }

    /// Global fibre id of each yarn's first fibre, plus the total at the end.
    pub fn first_fibres(&self) -> Vec<u32> {
        match self {
            Fabric::Straight(f) => f.first_fibres(),
            Fabric::Woven(p) => p.first_fibres().to_vec(),
            Fabric::Tiled(p) => p.first_fibres().to_vec(),
        }
    }

    /// Nodes of every fibre of yarn `yarn`.
    pub fn nodes_per_fibre(&self, yarn: usize) -> u32 {
        match self {
            Fabric::Straight(f) => f.nodes_per_fibre(),
            Fabric::Woven(p) => p.nodes_per_fibre(yarn),
            Fabric::Tiled(p) => p.nodes_per_fibre(yarn),
        }
    }

    /// Nodes of every fibre, yarn by yarn.
    pub fn nodes_per_yarn_fibre(&self) -> Vec<u32> {
        (0..self.yarn_count()).map(|y| self.nodes_per_fibre(y)).collect()
    }

    /// Node `k` of fibre `f` has global id `f * gid_stride + k`.
    pub fn gid_stride(&self) -> u32 {
        match self {
            Fabric::Straight(f) => f.nodes_per_fibre(),
            Fabric::Woven(p) => p.gid_stride(),
            Fabric::Tiled(p) => p.gid_stride(),
        }
    }

    /// Nodes of the whole target.
    pub fn node_count(&self) -> u64 {
        (0..self.yarn_count()).map(|y| self.yarn_fibres(y) as u64 * self.nodes_per_fibre(y) as u64).sum()
    }

    /// The sections of the target's fibres; the first is the finest (a hybrid panel's fine
    /// yarns), which the projectile meets first.
    pub fn sections(&self, material: &FibreMaterial) -> Vec<FibreSection> {
        match self {
            Fabric::Straight(f) => vec![f.section(material)],
            Fabric::Woven(p) => p.sections(),
            Fabric::Tiled(p) => vec![p.cell.section.clone()],
        }
    }

    /// Index of yarn `yarn`'s section in [`Self::sections`].
    pub fn yarn_section(&self, yarn: usize) -> usize {
        match self {
            Fabric::Straight(_) => 0,
            Fabric::Woven(p) => p.yarn_section(yarn),
            Fabric::Tiled(_) => 0,
        }
    }

    /// Centres of yarn `yarn`'s fibres in its cross-section, (across, up) [m].
    pub fn section_packing(&self, yarn: usize, material: &FibreMaterial) -> Vec<[f64; 2]> {
        match self {
            Fabric::Straight(f) => f.packing(&f.yarns[yarn], material),
            Fabric::Woven(p) => p.yarn_cell(yarn).packing.clone(),
            Fabric::Tiled(p) => p.packing(yarn),
        }
    }

    /// Box of the node centres of yarn `yarn` between positions `first` and `last` [m].
    pub fn segment_box(&self, yarn: usize, first: u32, last: u32, material: &FibreMaterial) -> (Vec3, Vec3) {
        match self {
            Fabric::Straight(f) => f.segment_box(yarn, first, last, material),
            Fabric::Woven(p) => p.segment_box(yarn, first, last),
            Fabric::Tiled(p) => p.segment_box(yarn, first, last),
        }
    }

    /// Highest node centre [m].
    pub fn top(&self, material: &FibreMaterial) -> f64 {
        match self {
            Fabric::Straight(f) => f.top(material),
            Fabric::Woven(p) => p.top(),
            Fabric::Tiled(p) => p.top(),
        }
    }

    /// Lowest node centre [m].
    pub fn bottom(&self, material: &FibreMaterial) -> f64 {
        match self {
            Fabric::Straight(f) => f.bottom(material),
            Fabric::Woven(p) => p.bottom(),
            Fabric::Tiled(p) => p.bottom(),
        }
    }

    /// Builds the nodes `keep(yarn, k)` selects, ascending global id.
    pub fn build(&self, material: &FibreMaterial, keep: impl Fn(usize, u32) -> bool) -> Built {
        match self {
            Fabric::Straight(f) => f.build(material, keep),
            Fabric::Woven(p) => p.build(material, keep),
            Fabric::Tiled(p) => p.build(material, keep),
        }
    }

    /// Builds every node.
    pub fn build_all(&self, material: &FibreMaterial) -> Built {
        self.build(material, |_, _| true)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dea_core::material::InertiaModel;

    #[test]
    fn a_rectangular_packing_fills_rows_four_times_as_wide_as_deep_and_ends_carry_their_mass() {
        // seed Table 5-1: 16 digital fibres as 2 rows of 8
        let points = rectangular_packing(16, 4, 1.0);
        assert_eq!(points.len(), 16);
        let across: std::collections::BTreeSet<i64> = points.iter().map(|p| (2.0 * p[0]) as i64).collect();
        let through: std::collections::BTreeSet<i64> = points.iter().map(|p| (2.0 * p[1]) as i64).collect();
        assert_eq!(across.into_iter().collect::<Vec<_>>(), vec![-7, -5, -3, -1, 1, 3, 5, 7]);
        assert_eq!(through.into_iter().collect::<Vec<_>>(), vec![-1, 1]);
        assert_eq!(rectangular_packing(4, 4, 1.0), vec![[-1.5, 0.0], [-0.5, 0.0], [0.5, 0.0], [1.5, 0.0]]);
        let material = FibreMaterial::kevlar_km2();
        let yarn = StraightFabric {
            packing: SectionPacking::Rectangular { across_per_through: 4 },
            clamp_ends: false,
            end_mass: 1e-6,
            ..StraightFabric::single_yarn(
                2e-3,
                16,
                4.63e-8 / 16.0,
                0.5,
                InertiaModel::Free {}.with_friction(0.3),
                3.8e9,
            )
        };
        let built = yarn.build_all(&material);
        let interior = yarn.section(&material).node_mass(&material);
        let nodes = &built.nodes;
        let end_mass: f64 = (0..nodes.len()).filter(|&i| nodes.along[i] == 0).map(|i| nodes.mass[i]).sum();
        assert!((end_mass - (1e-6 + 16.0 * 0.5 * interior)).abs() < 1e-18, "{end_mass}");
        assert!(nodes.clamped.iter().all(|&c| !c));
        // the yarn's section is 8 contact diameters wide
        let contact = yarn.section(&material).contact_diameter;
        assert!((yarn.yarn_envelope_diameter(&material) - (7.0f64.hypot(1.0) + 1.0) * contact).abs() < 1e-15);
    }

    #[test]
    fn hexagonal_rings_are_complete_and_touching() {
        let pitch = 1.0;
        for count in [1, 7, 19, 37] {
            let points = hexagonal_packing(count, pitch);
            assert_eq!(points.len(), count);
            let max_radius = points.iter().map(|p| p[0].hypot(p[1])).fold(0.0, f64::max);
            let rings = [1, 7, 19, 37].iter().position(|&c| c == count).unwrap();
            assert!((max_radius - rings as f64).abs() < 1e-12, "{count}: {max_radius}");
            for (a, p) in points.iter().enumerate() {
                for q in &points[a + 1..] {
                    assert!((p[0] - q[0]).hypot(p[1] - q[1]) >= pitch * (1.0 - 1e-12), "no overlap");
                }
            }
        }
    }

    #[test]
    fn bundle_mass_and_length_are_exact() {
        let material = FibreMaterial::kevlar_km2();
        let bundle = StraightFabric::single_yarn(
            0.01,
            7,
            4.63e-8 / 7.0,
            0.5,
            InertiaModel::Effective { k1: 0.8, k2: 1.0 }.with_friction(0.3),
            3.8e9,
        );
        let built = bundle.build_all(&material);
        let total_mass: f64 = built.nodes.mass.iter().sum();
        let expected = material.density * 4.63e-8 * 0.01;
        assert!((total_mass - expected).abs() < 1e-12 * expected);
        let span = built.nodes.position.iter().map(|p| p.x).fold(f64::NEG_INFINITY, f64::max)
            - built.nodes.position.iter().map(|p| p.x).fold(f64::INFINITY, f64::min);
        assert!((span - 0.01).abs() < 1e-15);
        assert_eq!(built.nodes.clamped.iter().filter(|&&c| c).count(), 14);
        let section = &built.sections[0];
        assert!((section.element_length / section.diameter - 0.5).abs() < 0.01);
    }

    #[test]
    fn a_rank_builds_exactly_its_piece_of_the_whole() {
        let material = FibreMaterial::kevlar_km2();
        let fabric = StraightFabric::cross_ply(
            2,
            2,
            7,
            2e-3,
            4.63e-8 / 7.0,
            0.5,
            InertiaModel::None {}.with_friction(0.3),
            3.8e9,
            &material,
        );
        let whole = fabric.build_all(&material);
        let keep = |y: usize, k: u32| (y + k as usize / 5) % 3 == 1;
        let piece = fabric.build(&material, keep);
        let mut expected = whole.nodes.gid.iter().enumerate().filter(|(i, _)| {
            let fibre = whole.nodes.fibre[*i].0 as usize;
            keep(fibre / 7, whole.nodes.along[*i])
        });
        for i in 0..piece.nodes.len() {
            let (w, gid) = expected.next().expect("same count");
            assert_eq!(piece.nodes.gid[i], *gid);
            assert_eq!(piece.nodes.position[i], whole.nodes.position[w]);
            assert_eq!(piece.nodes.mass[i], whole.nodes.mass[w]);
            assert_eq!(piece.elements.rest_length[i], whole.elements.rest_length[w]);
        }
        assert!(expected.next().is_none());
        assert!(piece.nodes.gid.windows(2).all(|g| g[0] < g[1]));
    }

    #[test]
    fn cross_ply_yarns_touch_without_overlapping() {
        let material = FibreMaterial::kevlar_km2();
        let fabric = StraightFabric::cross_ply(
            3,
            2,
            7,
            1e-3,
            4.63e-8 / 7.0,
            0.5,
            InertiaModel::None {}.with_friction(0.3),
            3.8e9,
            &material,
        );
        let built = fabric.build_all(&material);
        let contact = built.sections[0].contact_diameter;
        let nodes = &built.nodes;
        let mut closest = f64::INFINITY;
        for i in 0..nodes.len() {
            for j in 0..nodes.len() {
                if nodes.fibre[i] != nodes.fibre[j] {
                    closest = closest.min((nodes.position[i] - nodes.position[j]).norm());
                }
            }
        }
        assert!((closest - contact).abs() < 1e-9 * contact, "{closest} vs {contact}");
        let thickness = fabric.top(&material) - fabric.bottom(&material);
        // three layers at a pitch of three contact diameters (7 fibres: envelope 3 d), plus
        // the packing's own height sqrt(3) d
        let pitch = fabric.yarn_envelope_diameter(&material);
        assert!((pitch - 3.0 * contact).abs() < 1e-12 * contact);
        assert!((thickness - (2.0 * pitch + 3f64.sqrt() * contact)).abs() < 1e-12 * contact, "{thickness}");
        assert_eq!(fabric.first_fibres(), vec![0, 7, 14, 21, 28, 35, 42]);
    }
}
