//! The shear measure of the failure criterion (5-6): the seed's element form (5-4) or the
//! moment taken over a gauge of physical length (docs/theory.md, I9b).
//!
//! With `K_t = E I / l0` (5-3) a turn of angle `theta` at one node is a moment `E I theta / l0`
//! and (5-4) divides its jump by `l0` again: a kink of fixed angle (an edge sharper than the
//! elements, the front of a transverse wave) has a shear force `E I theta / l0^2` that grows
//! fourfold each time the elements halve, while the moments of a smoothly bent fibre converge.
//! Beam theory describes a section's moment and shear only as resultants over a slice at least
//! about one section deep (Saint-Venant); the gauge measure takes them so. The moment at node
//! `i` is averaged over the fibre with a hat of half-width `L` (the gauge length),
//! `M̄_i = Σ_j l0 M_j (1 - |s_j - s_i| / L) / L` over the nodes `j` of the same unbroken piece
//! with `|s_j - s_i| < L` (`s` the rest arc length, `l0 M_j = E I theta_j`), and an element's
//! shear force is the jump of `M̄` along it, `|M̄_i - M̄_j| / l0`. A kink of angle `theta`
//! then gives `E I theta / L^2` on every element within `L` of it, whatever `l0` is (the hat's
//! slope), and a fibre bent smoothly on lengths longer than `L` keeps `E I kappa'` (the hat
//! keeps linear fields).

use crate::ids::NONE;
use crate::nodes::{Elements, Nodes};
use crate::{FibreSection, Vec3};

/// How the failure criterion measures an element's shear force.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ShearMeasure {
    /// the seed's (5-4) as written: `Q = |M_i - M_j| / l0` from the springs at the element's
    /// two ends (does not converge at a kink; kept to reproduce the seed and earlier results)
    Element,
    /// the moment averaged over a hat of half-width `diameters` digital fibre diameters, its
    /// jump along the element (converges as `l0` shrinks)
    Gauge {
        /// the gauge length in digital fibre diameters of the element's section [-]
        diameters: f64,
    },
}

impl ShearMeasure {
    /// How many nodes beyond its own a node's gauge reaches along its fibre in `section`:
    /// `ceil(L / l0)` (0 for the element measure). The walk stops there even when rest
    /// lengths shorter than the nominal one would let it go on, so the reach is a count of
    /// nodes and every rank that holds the chain stencil sees the same window.
    pub fn reach_in_nodes(&self, section: &FibreSection) -> u32 {
        match *self {
            ShearMeasure::Element => 0,
            ShearMeasure::Gauge { diameters } => (diameters * section.diameter / section.element_length).ceil() as u32,
        }
    }

    /// The gauge length `L` of `section` [m] (0 for the element measure).
    pub fn gauge_length(&self, section: &FibreSection) -> f64 {
        match *self {
            ShearMeasure::Element => 0.0,
            ShearMeasure::Gauge { diameters } => diameters * section.diameter,
        }
    }
}

/// The gauge moments `M̄` [N m] of the local nodes in `ranges` (every node, or at a
/// multi-rate instant those of the sections whose terms fire, [`crate::multi_rate`]: the
/// others keep what they held, which no element of a firing section reads, a gauge staying on
/// its fibre) into `gauge_moment` from the spring moments `moment` of
/// [`crate::bending::compute_bending`]. A node's window ends at a broken element, a
/// chain end or a node not held here; only the nodes whose window the chain stencil holds
/// (those within the stencil less the reach of an owned node) are right, which are all the
/// failure stage reads. Each sum runs from the node outwards, the lower positions first, so a
/// node's value has the same bits on every rank that holds its window.
pub fn gauge_moments(
    nodes: &Nodes,
    elements: &Elements,
    moment: &[Vec3],
    sections: &[FibreSection],
    measure: ShearMeasure,
    gauge_moment: &mut Vec<Vec3>,
    ranges: &[std::ops::Range<usize>],
) {
    gauge_moment.resize(nodes.len(), Vec3::zeros());
    for i in ranges.iter().flat_map(|r| r.clone()) {
        let section = &sections[nodes.section[i] as usize];
        let gauge = measure.gauge_length(section);
        let reach = measure.reach_in_nodes(section);
        if gauge <= 0.0 {
            gauge_moment[i] = moment[i];
            continue;
        }
        // l0 M_j / L, the hat's height at j's distance applied below
        let scale = section.element_length / gauge;
        let mut sum = moment[i] * scale;
        // towards lower positions, then higher ones
        let hat = Hat { nodes, elements, moment, from: i, reach, gauge, scale };
        hat.add_side(&mut sum, |j| (nodes.prev[j] != NONE).then(|| (nodes.prev[j] as usize, nodes.prev[j] as usize)));
        hat.add_side(&mut sum, |j| (nodes.next[j] != NONE).then(|| (nodes.next[j] as usize, j)));
        gauge_moment[i] = sum;
    }
}

/// The hat window of one node: what [`gauge_moments`] sums along each side of it.
struct Hat<'a> {
    nodes: &'a Nodes,
    elements: &'a Elements,
    moment: &'a [Vec3],
    /// the node the window is centred on
    from: usize,
    /// nodes reached at most each way
    reach: u32,
    /// half-width L [m]
    gauge: f64,
    /// l0 / L [-]
    scale: f64,
}

impl Hat<'_> {
    /// Adds to `sum` the hat-weighted moments one way along the fibre, up to the reach, the
    /// gauge or a broken element; `neighbour` gives the next node that way and the element
    /// between (a generic, so the step's hot loop calls it without dynamic dispatch).
    fn add_side(&self, sum: &mut Vec3, neighbour: impl Fn(usize) -> Option<(usize, usize)>) {
        let (mut j, mut distance) = (self.from, 0.0);
        for _ in 0..self.reach {
            let Some((next, element)) = neighbour(j).filter(|&(_, e)| self.elements.is_intact(self.nodes, e)) else {
                break;
            };
            distance += self.elements.rest_length[element];
            if distance >= self.gauge {
                break;
            }
            j = next;
            *sum += self.moment[j] * (self.scale * (1.0 - distance / self.gauge));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bending::{compute_bending, element_shear_force, max_shear_stress, BendingScratch};
    use crate::material::{FibreMaterial, InertiaModel};
    use crate::nodes::FailureMode;
    use crate::rod::compute_element_tension;
    use crate::{FibreId, GlobalNodeId};

    /// One fibre of digital fibre diameter `diameter` [m] and elements `l0` [m] laid along
    /// `shape` (arc length to position), from arc length `-half` to `half` [m].
    fn fibre_along(
        shape: impl Fn(f64) -> Vec3,
        half: f64,
        l0: f64,
        diameter: f64,
    ) -> (Nodes, Elements, Vec<FibreSection>) {
        let material = FibreMaterial::kevlar_km2();
        let area = std::f64::consts::PI * diameter * diameter / 4.0;
        let sections = vec![FibreSection::new(
            &material,
            area,
            l0,
            InertiaModel::Effective { k1: 0.8, k2: 1.0 }.with_friction(0.3),
        )];
        let count = (2.0 * half / l0).round() as u32 + 1;
        let (mut nodes, mut elements) = (Nodes::default(), Elements::default());
        for along in 0..count {
            let s = -half + along as f64 * l0;
            nodes.push(
                GlobalNodeId(along as u64),
                shape(s),
                Vec3::zeros(),
                1e-12,
                FibreId(0),
                along,
                0,
                false,
                along + 1 == count,
            );
            elements.push(l0, 3.8e9, FailureMode::Intact);
        }
        nodes.n_owned = nodes.len();
        nodes.link_chains();
        (nodes, elements, sections)
    }

    /// A fibre of unit arc-length speed turned by `angle` [rad] round an edge of radius
    /// `radius` [m] at arc length 0: straight, an arc of length `radius * angle`, straight.
    fn over_an_edge(radius: f64, angle: f64) -> impl Fn(f64) -> Vec3 {
        move |s: f64| {
            let arc = radius * angle;
            let (a, b) = (-arc / 2.0, arc / 2.0);
            // the arc turns the tangent from -angle/2 to +angle/2 about z
            let point_on_arc = |t: f64| {
                let phi = t / radius;
                Vec3::new(radius * phi.sin(), radius * (1.0 - phi.cos()), 0.0)
            };
            let tangent = |t: f64| {
                let phi = t / radius;
                Vec3::new(phi.cos(), phi.sin(), 0.0)
            };
            if s < a {
                point_on_arc(a) + tangent(a) * (s - a)
            } else if s > b {
                point_on_arc(b) + tangent(b) * (s - b)
            } else {
                point_on_arc(s)
            }
        }
    }

    /// The largest element shear stress (5-5) of the fibre under `measure` [Pa].
    fn largest_shear_stress(
        nodes: &Nodes,
        elements: &mut Elements,
        sections: &[FibreSection],
        measure: ShearMeasure,
    ) -> f64 {
        let material = FibreMaterial::kevlar_km2();
        compute_element_tension(nodes, elements, sections, &material);
        let mut bending = BendingScratch::default();
        bending.resize(nodes.len());
        compute_bending(nodes, elements, sections, &mut bending);
        let mut gauge = Vec::new();
        gauge_moments(nodes, elements, &bending.moment, sections, measure, &mut gauge, &[0..nodes.len()]);
        let area = sections[0].area;
        (0..nodes.len() - 1)
            .map(|i| max_shear_stress(element_shear_force(nodes, elements, &gauge, i), area))
            .fold(0.0, f64::max)
    }

    #[test]
    fn the_element_measure_is_the_seeds_and_the_gauge_of_a_kink_is_its_hat_slope() {
        let diameter = 120e-6;
        let l0 = diameter / 4.0;
        let angle = 0.3;
        // a kink at one node: the element measure is E I theta / l0^2 on the elements beside it
        let (nodes, mut elements, sections) = fibre_along(over_an_edge(1e-12, angle), 40.0 * l0, l0, diameter);
        let ei = FibreMaterial::kevlar_km2().longitudinal_modulus * sections[0].moment_of_inertia;
        let area = sections[0].area;
        let element = largest_shear_stress(&nodes, &mut elements, &sections, ShearMeasure::Element);
        let mut bending = BendingScratch::default();
        bending.resize(nodes.len());
        compute_bending(&nodes, &elements, &sections, &mut bending);
        let seed = (0..nodes.len() - 1)
            .map(|i| max_shear_stress(element_shear_force(&nodes, &elements, &bending.moment, i), area))
            .fold(0.0, f64::max);
        assert_eq!(element, seed, "the element measure is (5-4) as written");
        let kink = max_shear_stress(ei * angle / (l0 * l0), area);
        assert!((element / kink - 1.0).abs() < 1e-3, "{element} against {kink}");
        for diameters in [1.0, 2.0] {
            let gauge = diameters * diameter;
            let found = largest_shear_stress(&nodes, &mut elements, &sections, ShearMeasure::Gauge { diameters });
            let slope = max_shear_stress(ei * angle / (gauge * gauge), area);
            assert!((found / slope - 1.0).abs() < 1e-3, "{diameters} d: {found} against {slope}");
        }
    }

    #[test]
    fn at_an_edge_of_fixed_radius_the_gauge_shear_converges_as_the_elements_halve() {
        let diameter = 120e-6;
        let angle = 0.4;
        // the 17-grain FSP's 50 µm edge, sharper than a fibre diameter, and a blunt 2.7 mm nose
        for radius in [50e-6, 2.7e-3] {
            let mut gauge_stress = Vec::new();
            let mut element_stress = Vec::new();
            for ratio in [0.5, 0.25, 0.125, 0.0625] {
                let l0 = ratio * diameter;
                let (nodes, mut elements, sections) =
                    fibre_along(over_an_edge(radius, angle), radius * angle + 20.0 * diameter, l0, diameter);
                gauge_stress.push(largest_shear_stress(
                    &nodes,
                    &mut elements,
                    &sections,
                    ShearMeasure::Gauge { diameters: 1.0 },
                ));
                element_stress.push(largest_shear_stress(&nodes, &mut elements, &sections, ShearMeasure::Element));
            }
            let changes: Vec<f64> = gauge_stress.windows(2).map(|w| (w[1] / w[0] - 1.0).abs()).collect();
            // each halving changes the gauge stress less than the one before, and the last by under 5 %
            assert!(changes.windows(2).all(|c| c[1] <= c[0] + 1e-12), "r {radius}: {gauge_stress:?}");
            assert!(changes[changes.len() - 1] < 0.05, "r {radius}: {gauge_stress:?}");
            if radius < diameter {
                // the element measure of a sharp edge grows without bound as l0 shrinks
                assert!(element_stress.windows(2).all(|w| w[1] > 1.5 * w[0]), "r {radius}: {element_stress:?}");
            }
        }
    }
}
