//! Fabric geometry at near-fibre level: digital fibres packed in a yarn section and laid out
//! as straight chains (single fibres and straight yarns). Woven topologies, relaxation and
//! panels build on these pieces.

use dea_core::material::InertiaModel;
use dea_core::{Elements, FibreId, FibreMaterial, FibreSection, GlobalNodeId, Nodes, Vec3};

/// A straight bundle of digital fibres along x, centred on the origin.
#[derive(Clone, Debug, PartialEq)]
pub struct StraightBundle {
    /// length of every fibre [m]
    pub length: f64,
    /// digital fibres in the bundle
    pub fibres: usize,
    /// cross-section area of one digital fibre [m^2]
    pub fibre_area: f64,
    /// target element length / digital fibre diameter [-] (seed §6.1: 0.5 converges)
    pub element_length_ratio: f64,
    /// bending model of (5-7)…(5-10)
    pub inertia: InertiaModel,
    /// inter-fibre friction coefficient used by (5-10) [-]
    pub friction_coefficient: f64,
    /// tensile strength given to every element before any Weibull sampling [Pa]
    pub tensile_strength: f64,
    /// clamp both ends of every fibre
    pub clamp_ends: bool,
}

/// Built geometry, ready for a [`dea_core::Domain`].
pub struct Built {
    pub sections: Vec<FibreSection>,
    pub nodes: Nodes,
    pub elements: Elements,
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

impl StraightBundle {
    /// Builds the nodes: fibre f, node k has global id `f * nodes_per_fibre + k`; interior
    /// nodes carry `rho A l0`, chain ends half of it.
    pub fn build(&self, material: &FibreMaterial) -> Built {
        let diameter = (4.0 * self.fibre_area / std::f64::consts::PI).sqrt();
        let elements_per_fibre = ((self.length / (self.element_length_ratio * diameter)).round() as usize).max(1);
        let element_length = self.length / elements_per_fibre as f64;
        let section = FibreSection::new(material, self.fibre_area, element_length, self.inertia, self.friction_coefficient);
        let nodes_per_fibre = elements_per_fibre + 1;
        let interior_mass = section.node_mass(material);
        let centres = hexagonal_packing(self.fibres, section.contact_diameter);
        let mut nodes = Nodes::default();
        for (f, [y, z]) in centres.iter().enumerate() {
            for k in 0..nodes_per_fibre {
                let end = k == 0 || k == elements_per_fibre;
                let x = -0.5 * self.length + k as f64 * element_length;
                nodes.push(
                    GlobalNodeId((f * nodes_per_fibre + k) as u64),
                    Vec3::new(x, *y, *z),
                    Vec3::zeros(),
                    if end { 0.5 * interior_mass } else { interior_mass },
                    FibreId(f as u32),
                    k as u32,
                    0,
                    end && self.clamp_ends,
                );
            }
        }
        nodes.n_owned = nodes.len();
        nodes.link_chains();
        let elements = Elements::from_geometry(&nodes, self.tensile_strength);
        Built { sections: vec![section], nodes, elements }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let bundle = StraightBundle {
            length: 0.01,
            fibres: 7,
            fibre_area: 4.63e-8 / 7.0,
            element_length_ratio: 0.5,
            inertia: InertiaModel::Effective { k1: 0.8, k2: 1.0 },
            friction_coefficient: 0.3,
            tensile_strength: 3.8e9,
            clamp_ends: true,
        };
        let built = bundle.build(&material);
        let total_mass: f64 = built.nodes.mass.iter().sum();
        let expected = material.density * 4.63e-8 * 0.01;
        assert!((total_mass - expected).abs() < 1e-12 * expected);
        let span = built.nodes.position.iter().map(|p| p.x).fold(f64::NEG_INFINITY, f64::max) - built.nodes.position.iter().map(|p| p.x).fold(f64::INFINITY, f64::min);
        assert!((span - 0.01).abs() < 1e-15);
        assert_eq!(built.nodes.clamped.iter().filter(|&&c| c).count(), 14);
        let section = &built.sections[0];
        assert!((section.element_length / section.diameter - 0.5).abs() < 0.01);
    }
}
