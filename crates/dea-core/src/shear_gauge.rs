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
use crate::measure::Measure;
use crate::nodes::{Elements, Nodes};
use crate::{FibreSection, Vec3};

/// How the failure criterion measures an element's shear force: the seed's (5-4) from the
/// springs at the element's two ends ([`Measure::Element`]), or the jump of the moment
/// averaged over the gauge ([`Measure::Gauge`], the default of a case).
pub type ShearMeasure = Measure;

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
    scratch: &mut GaugeScratch,
    ranges: &[std::ops::Range<usize>],
) {
    let GaugeScratch { windows, measure: windows_of, gauge_moment } = scratch;
    gauge_moment.resize(nodes.len(), Vec3::zeros());
    // each section's gauge, reach and hat scale: taken once for a domain's sections and
    // measure (both fixed for its life), not in the step loop
    if windows.len() != sections.len() || *windows_of != Some(measure) {
        windows.clear();
        windows.extend(sections.iter().map(|section| Window::of(measure, section)));
        *windows_of = Some(measure);
    }
    let windows: &[Window] = windows;
    for range in ranges {
        let mut i = range.start;
        if let Some(done) =
            crate::in_avx2_lanes!(gauge_in_lanes(nodes, elements, moment, windows, gauge_moment, range.clone()))
        {
            i = done;
        }
        for i in i..range.end {
            gauge_moment[i] = node_gauge_moment(nodes, elements, moment, windows, i);
        }
    }
}

/// What [`gauge_moments`] keeps between steps: each section's hat (taken on the first call
/// for the sections and measure it is given) and the gauge moments [N m] of the local nodes.
#[derive(Clone, Debug, Default)]
pub struct GaugeScratch {
    windows: Vec<Window>,
    /// the measure `windows` were taken for
    measure: Option<ShearMeasure>,
    /// `M̄` of each local node [N m]
    pub gauge_moment: Vec<Vec3>,
}

/// The hat of one section: its gauge length `L` [m], the nodes it reaches each way, and
/// `l0 / L` [-].
#[derive(Clone, Copy, Debug)]
struct Window {
    gauge: f64,
    reach: u32,
    scale: f64,
}

impl Window {
    fn of(measure: ShearMeasure, section: &FibreSection) -> Self {
        let gauge = measure.gauge_length(section);
        Self { gauge, reach: measure.reach(section), scale: section.element_length / gauge }
    }
}

/// The gauge moment of local node `i` [N m] ([`gauge_moments`]).
#[inline]
fn node_gauge_moment(nodes: &Nodes, elements: &Elements, moment: &[Vec3], windows: &[Window], i: usize) -> Vec3 {
    let Window { gauge, reach, scale } = windows[nodes.section[i] as usize];
    if gauge <= 0.0 {
        return moment[i];
    }
    // l0 M_j / L, the hat's height at j's distance applied below
    let mut sum = moment[i] * scale;
    // towards lower positions, then higher ones
    let hat = Hat { nodes, elements, moment, from: i, reach, gauge, scale };
    hat.add_side(&mut sum, |j| (nodes.prev[j] != NONE).then(|| (nodes.prev[j] as usize, nodes.prev[j] as usize)));
    hat.add_side(&mut sum, |j| (nodes.next[j] != NONE).then(|| (nodes.next[j] as usize, j)));
    sum
}

/// [`gauge_moments`] four nodes at a time over `range`, with the scalar code's bits, where
/// the four share a section and their windows lie on one chain stored in order (almost
/// everywhere; the other groups take [`node_gauge_moment`]). Each lane walks its own window
/// as the scalar code does, a lane stopping at a broken element or the gauge's end while the
/// others go on. Returns where the scalar code takes over (the last group's end).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn gauge_in_lanes(
    nodes: &Nodes,
    elements: &Elements,
    moment: &[Vec3],
    windows: &[Window],
    gauge_moment: &mut [Vec3],
    range: std::ops::Range<usize>,
) -> usize {
    use crate::lanes::{F4, V4};
    use crate::nodes::FailureMode;
    let n = nodes.len();
    let intact = |k: usize| if elements.failure[k] == FailureMode::Intact { 1.0 } else { 0.0 };
    let mut i = range.start;
    while i + 4 <= range.end {
        let section = nodes.section[i];
        let Window { gauge, reach, scale } = windows[section as usize];
        let r = reach as usize;
        // the window's nodes i - r ..= i + 3 + r on one chain in memory order
        let in_order = gauge > 0.0
            && i >= r
            && i + 3 + r < n
            && (i..i + 4).all(|k| nodes.section[k] == section)
            && (i - r..i + 3 + r).all(|k| nodes.next[k] == k as u32 + 1);
        if !in_order {
            for k in i..i + 4 {
                gauge_moment[k] = node_gauge_moment(nodes, elements, moment, windows, k);
            }
            i += 4;
            continue;
        }
        let (one, zero) = (F4::splat(1.0), F4::splat(0.0));
        let (gauge_lanes, scale_lanes) = (F4::splat(gauge), F4::splat(scale));
        let mut sum = V4::load(moment, i).scale(scale_lanes);
        // lower positions: node i + l - s, across element i + l - s; then higher ones: node
        // i + l + s, across element i + l + s - 1
        for side in [-1isize, 1] {
            let mut distance = zero;
            let mut walking = one.eq(one);
            for step in 1..=r {
                let (node, element) = if side < 0 { (i - step, i - step) } else { (i + step, i + step - 1) };
                walking = walking.and(F4::gather(element, intact).eq(one));
                distance = F4::select(walking, distance.add(F4::load(&elements.rest_length, element)), distance);
                walking = walking.and(distance.lt(gauge_lanes));
                if walking.bits() == 0 {
                    break;
                }
                let weight = scale_lanes.mul(one.sub(distance.div(gauge_lanes)));
                sum = V4::select(walking, sum.add(V4::load(moment, node).scale(weight)), sum);
            }
        }
        sum.store(gauge_moment, i);
        i += 4;
    }
    i
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
    use crate::fixtures::fibre_along;
    use crate::material::FibreMaterial;
    use crate::rod::compute_element_tension;

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
        let mut scratch = GaugeScratch::default();
        gauge_moments(nodes, elements, &bending.moment, sections, measure, &mut scratch, &[0..nodes.len()]);
        let gauge = scratch.gauge_moment;
        let area = sections[0].area;
        (0..nodes.len() - 1)
            .map(|i| max_shear_stress(element_shear_force(nodes, elements, &gauge, i), area))
            .fold(0.0, f64::max)
    }

    #[test]
    fn the_lanes_give_the_gauge_moments_of_the_scalar_walk_with_its_bits() {
        use crate::bending::tests::{assert_same_bits, fibres_on_every_path};
        let (nodes, mut elements, sections) = fibres_on_every_path();
        compute_element_tension(&nodes, &mut elements, &sections, &FibreMaterial::kevlar_km2());
        let mut bending = BendingScratch::default();
        bending.resize(nodes.len());
        compute_bending(&nodes, &elements, &sections, &mut bending);
        // two reaches per section (the fixture's sections differ in diameter), and ranges that
        // split the nodes where a group of four would not
        for diameters in [1.0, 2.5] {
            let measure = ShearMeasure::Gauge { diameters };
            let windows: Vec<Window> = sections.iter().map(|section| Window::of(measure, section)).collect();
            let walked: Vec<Vec3> =
                (0..nodes.len()).map(|i| node_gauge_moment(&nodes, &elements, &bending.moment, &windows, i)).collect();
            for ranges in [vec![0..nodes.len()], vec![0..7, 9..nodes.len() - 3]] {
                let mut scratch = GaugeScratch { gauge_moment: vec![Vec3::zeros(); nodes.len()], ..Default::default() };
                gauge_moments(&nodes, &elements, &bending.moment, &sections, measure, &mut scratch, &ranges);
                let lanes = &scratch.gauge_moment;
                for range in &ranges {
                    assert_same_bits("gauge moment", &lanes[range.clone()], &walked[range.clone()]);
                }
            }
            // the lanes' paths were taken: a window cut short by a broken element, and one
            // across two sections or off the chain's memory order
            let reach = |i: usize| windows[nodes.section[i] as usize].reach as usize;
            let in_order = |i: usize| {
                i >= reach(i)
                    && i + 3 + reach(i) < nodes.len()
                    && (i..i + 4).all(|k| nodes.section[k] == nodes.section[i])
                    && (i - reach(i)..i + 3 + reach(i)).all(|k| nodes.next[k] == k as u32 + 1)
            };
            let groups: Vec<usize> = (0..nodes.len() / 4).map(|g| 4 * g).collect();
            assert!(groups
                .iter()
                .any(|&i| in_order(i) && (i - reach(i)..i + 3 + reach(i)).any(|k| !elements.is_intact(&nodes, k))));
            assert!(groups.iter().any(|&i| !in_order(i)));
            assert!(walked.iter().any(|m| m.norm() > 0.0));
        }
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
