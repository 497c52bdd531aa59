//! Ties: springs that join the end node of a fine digital fibre to the end of a coarse one,
//! where a hybrid yarn changes its number of digital fibres along its length (docs/theory.md
//! F12).
//!
//! Several fine fibres end at one coarse fibre, each beside its axis. A plain rod from each
//! fine end to the coarse end node would pull the fine ends towards the axis under tension
//! and turn a pulse along the yarn into a lateral whip (a third or more of its energy in
//! tests). A tie instead measures the fine end's place in the frame of the coarse fibre's
//! end element: an axial spring on its distance along that element's axis (seed 4-2 with
//! the fine fibre's area, so the ties of a transition carry the yarn's whole area `A_yarn`),
//! and a radial spring of the same stiffness on its distance from the axis. Both depend only
//! on distances, so the forces sum to zero and turn with the body. Turning about the axis
//! is left to the fibres' contacts. A tie has no bending spring and does not fail: a hybrid
//! mesh puts its transitions where the fibres stay far below their strength.

use crate::ids::{FibreId, GlobalNodeId, NONE};
use crate::nodes::Nodes;
use crate::rod::{axial_energy, axial_force};
use crate::{FibreMaterial, Vec3};

/// One end of a tie: a node named by its global id, fibre and position along the fibre.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct TieEnd {
    /// the node's global id
    pub gid: GlobalNodeId,
    /// its fibre
    pub fibre: FibreId,
    /// its position along the fibre
    pub along: u32,
}

/// A tie from the end node of a fine fibre to a coarse fibre's end node `coarse`, in the
/// frame of the coarse fibre's end element (`coarse` and its chain neighbour `coarse_next`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tie {
    /// the fine fibre's end node
    pub fine: TieEnd,
    /// the coarse fibre's end node it is tied to
    pub coarse: TieEnd,
    /// the coarse end node's chain neighbour, which with it sets the tie's frame
    pub coarse_next: TieEnd,
    /// distance of the fine end from the coarse end node along the end element's axis (away
    /// from `coarse_next`) as built: the axial spring's rest length [m]
    pub axial_length: f64,
    /// distance of the fine end from that axis as built [m]
    pub radial_offset: f64,
    /// cross-section area: the fine fibre's [m^2]
    pub area: f64,
    /// length of the fine fibre the tie stands for (its elements left out between its end
    /// and the coarse node's station), which sets the tie's mass [m]
    pub fibre_length: f64,
}

/// Where a fine end sits in the frame of a coarse end element.
struct Frame {
    /// unit axis from `coarse_next` to `coarse`
    axis: Vec3,
    /// 1 / length of the end element [1/m]
    inverse_length: f64,
    /// fine end relative to the coarse end node [m]
    relative: Vec3,
    /// its distance along the axis [m]
    axial: f64,
    /// its part across the axis [m]
    across: Vec3,
}

impl Frame {
    fn new(fine: &Vec3, coarse: &Vec3, coarse_next: &Vec3) -> Self {
        let element = coarse - coarse_next;
        let inverse_length = 1.0 / element.norm();
        let axis = element * inverse_length;
        let relative = fine - coarse;
        let axial = relative.dot(&axis);
        Self { axis, inverse_length, relative, axial, across: relative - axis * axial }
    }
}

impl Tie {
    /// Stiffness `E A / l_axial` of each of the two springs [N/m].
    pub fn stiffness(&self, material: &FibreMaterial) -> f64 {
        material.longitudinal_modulus * self.area / self.axial_length
    }

    /// Mass of the fine fibre the tie stands for, `rho A l_fibre`, which its fine end and
    /// coarse end node share equally [kg].
    pub fn mass(&self, material: &FibreMaterial) -> f64 {
        material.density * self.area * self.fibre_length
    }

    /// The tie's rest geometry for a fine end at `fine` and a coarse end element from
    /// `coarse_next` to `coarse`: (axial length, radial offset) [m].
    pub fn rest_geometry(fine: &Vec3, coarse: &Vec3, coarse_next: &Vec3) -> (f64, f64) {
        let frame = Frame::new(fine, coarse, coarse_next);
        (frame.axial, frame.across.norm())
    }

    /// Where a fine end at `fine` lies across the axis of the coarse end element from
    /// `coarse_next` to `coarse`: its offset from the axis [m].
    pub fn offset_across(fine: &Vec3, coarse: &Vec3, coarse_next: &Vec3) -> Vec3 {
        Frame::new(fine, coarse, coarse_next).across
    }

    /// Radial spring force along the outward radial direction times that direction, over
    /// the radius: `k (r - r0) / r` (0 on the axis) [N/m].
    fn radial_force_per_radius(&self, material: &FibreMaterial, radius: f64) -> f64 {
        if radius > 0.0 {
            self.stiffness(material) * (radius - self.radial_offset) / radius
        } else {
            0.0
        }
    }

    /// Forces on (fine end, coarse end node, its neighbour) [N]: minus the gradient of
    /// `U = E A l_a eps^2 / 2 + k (r - r0)^2 / 2` with `eps = (a - l_a) / l_a`, `a` and `r`
    /// the fine end's axial and radial place in the end element's frame.
    fn forces(&self, material: &FibreMaterial, fine: &Vec3, coarse: &Vec3, coarse_next: &Vec3) -> [Vec3; 3] {
        let f = Frame::new(fine, coarse, coarse_next);
        let axial = axial_force(material, self.area, (f.axial - self.axial_length) / self.axial_length);
        let radial = f.across * self.radial_force_per_radius(material, f.across.norm());
        // dU/d(relative), and dU/d(axis) projected across the axis over the element length
        let on_relative = f.axis * axial + radial;
        let on_axis = (f.across * axial - radial * f.axial) * f.inverse_length;
        debug_assert!(f.relative.norm() > 0.0);
        [-on_relative, on_relative - on_axis, on_axis]
    }

    /// Strain energy of the two springs [J].
    fn energy(&self, material: &FibreMaterial, fine: &Vec3, coarse: &Vec3, coarse_next: &Vec3) -> f64 {
        let f = Frame::new(fine, coarse, coarse_next);
        let radial = f.across.norm() - self.radial_offset;
        axial_energy(material, self.area, self.axial_length, (f.axial - self.axial_length) / self.axial_length) + 0.5 * self.stiffness(material) * radial * radial
    }
}

/// The ties of one domain: every tie with an owned end.
#[derive(Clone, Debug, Default)]
pub struct Ties {
    /// ascending (coarse gid, fine gid): a node sums its ties in this order, so the sum does
    /// not depend on the partition
    list: Vec<Tie>,
    /// local indices [fine, coarse, coarse_next] of each tie's ends (`NONE` while a ghost is
    /// missing)
    local: Vec<[u32; 3]>,
}

impl Ties {
    /// The ties of `list` with an end among the owned nodes of `nodes` (ascending gid).
    pub fn new(mut list: Vec<Tie>, nodes: &Nodes) -> Self {
        let owned = &nodes.gid[..nodes.n_owned];
        list.retain(|t| [t.fine, t.coarse, t.coarse_next].iter().any(|e| owned.binary_search(&e.gid).is_ok()));
        list.sort_by_key(|t| (t.coarse.gid, t.fine.gid));
        let mut ties = Self { local: vec![[NONE; 3]; list.len()], list };
        ties.link(nodes);
        ties
    }

    /// Every tie of the domain.
    pub fn list(&self) -> &[Tie] {
        &self.list
    }

    /// No tie.
    pub fn is_empty(&self) -> bool {
        self.list.is_empty()
    }

    /// Finds each tie's ends among the local nodes (owned nodes ascending gid, ghosts in any
    /// order). Call after every change of the ghosts.
    pub fn link(&mut self, nodes: &Nodes) {
        if self.list.is_empty() {
            return;
        }
        let owned = &nodes.gid[..nodes.n_owned];
        let mut ghosts: Vec<(GlobalNodeId, u32)> = (nodes.n_owned..nodes.len()).map(|i| (nodes.gid[i], i as u32)).collect();
        ghosts.sort_unstable();
        let find = |end: &TieEnd| match owned.binary_search(&end.gid) {
            Ok(i) => i as u32,
            Err(_) => ghosts.binary_search_by_key(&end.gid, |g| g.0).map_or(NONE, |k| ghosts[k].1),
        };
        for (tie, local) in self.list.iter().zip(&mut self.local) {
            *local = [find(&tie.fine), find(&tie.coarse), find(&tie.coarse_next)];
        }
    }

    /// The first tie (in list order) one of whose ends is not local: (an owned end, the
    /// missing end).
    pub fn missing_end(&self, n_owned: usize) -> Option<(GlobalNodeId, GlobalNodeId)> {
        self.list.iter().zip(&self.local).find_map(|(t, l)| {
            let ends = [t.fine.gid, t.coarse.gid, t.coarse_next.gid];
            let missing = l.iter().position(|&i| i == NONE)?;
            let owned = l.iter().position(|&i| (i as usize) < n_owned).expect("a tie with an owned end");
            Some((ends[owned], ends[missing]))
        })
    }

    /// Adds the forces of every tie to its owned ends, each end's sum in list order whatever
    /// the partition.
    pub fn add_forces(&self, nodes: &mut Nodes, material: &FibreMaterial) {
        self.add_scaled_forces(nodes, material, |_, _| 1.0);
    }

    /// [`Self::add_forces`] at a multi-rate instant ([`crate::multi_rate`]): each tie's forces
    /// times `scale(fine section, coarse section)`, none where that is 0.
    pub fn add_scaled_forces(&self, nodes: &mut Nodes, material: &FibreMaterial, scale: impl Fn(u16, u16) -> f64) {
        for (tie, local) in self.list.iter().zip(&self.local) {
            let [fine, coarse, next] = local.map(|i| i as usize);
            let factor = scale(nodes.section[fine], nodes.section[coarse]);
            if factor == 0.0 {
                continue;
            }
            let forces = tie.forces(material, &nodes.position[fine], &nodes.position[coarse], &nodes.position[next]);
            for (i, force) in [fine, coarse, next].into_iter().zip(forces) {
                if i < nodes.n_owned {
                    nodes.force[i] += force * factor;
                }
            }
        }
    }

    /// Strain energy of every tie whose fine end is owned, with that end's local index (each
    /// tie counted once over all ranks) [J].
    pub fn energies<'a>(&'a self, nodes: &'a Nodes, material: &'a FibreMaterial) -> impl Iterator<Item = (usize, f64)> + 'a {
        self.list.iter().zip(&self.local).filter(|(_, l)| (l[0] as usize) < nodes.n_owned).map(|(tie, local)| {
            let [fine, coarse, next] = local.map(|i| i as usize);
            (fine, tie.energy(material, &nodes.position[fine], &nodes.position[coarse], &nodes.position[next]))
        })
    }

    /// Stiffness the ties add to each of the `n_owned` owned nodes, both springs counted at
    /// every end (an upper bound for the stability check) [N/m].
    pub fn stiffness_on_owned(&self, n_owned: usize, material: &FibreMaterial) -> Vec<f64> {
        let mut stiffness = vec![0.0; n_owned];
        for (tie, local) in self.list.iter().zip(&self.local) {
            for &i in local {
                if (i as usize) < n_owned {
                    stiffness[i as usize] += 2.0 * tie.stiffness(material);
                }
            }
        }
        stiffness
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;

    const A: f64 = 1e-9;

    fn end(gid: u64) -> TieEnd {
        TieEnd { gid: GlobalNodeId(gid), fibre: FibreId(gid as u32), along: 0 }
    }

    /// A tie from a fine end at `fine` to the coarse end element (`coarse_next`, `coarse`),
    /// at rest as placed.
    fn tie(fine: Vec3, coarse: Vec3, coarse_next: Vec3) -> Tie {
        let (axial_length, radial_offset) = Tie::rest_geometry(&fine, &coarse, &coarse_next);
        Tie { fine: end(0), coarse: end(10), coarse_next: end(11), axial_length, radial_offset, area: A, fibre_length: axial_length }
    }

    #[test]
    fn a_tie_pulls_its_fine_end_along_the_coarse_axis_with_e_a_strain() {
        let material = FibreMaterial::kevlar_km2();
        let (coarse, next) = (Vec3::zeros(), Vec3::new(-1e-4, 0.0, 0.0));
        // a fine end beside the axis, stretched 1 % along it: pulled straight back
        let t = tie(Vec3::new(2e-4, 5e-5, 0.0), coarse, next);
        assert_eq!((t.axial_length, t.radial_offset), (2e-4, 5e-5));
        let [on_fine, on_coarse, on_next] = t.forces(&material, &Vec3::new(2.02e-4, 5e-5, 0.0), &coarse, &next);
        let expected = material.longitudinal_modulus * A * 0.01;
        assert!((on_fine.x + expected).abs() < 1e-12 * expected && on_fine.y == 0.0 && on_fine.z == 0.0, "{on_fine:?}");
        // the coarse element takes the force and the moment of its offset
        assert!((on_coarse + on_next + on_fine).norm() < 1e-12 * expected);
        let moment = |x: Vec3, f: Vec3| x.cross(&f);
        let total = moment(Vec3::new(2.02e-4, 5e-5, 0.0), on_fine) + moment(coarse, on_coarse) + moment(next, on_next);
        assert!(total.norm() < 1e-12 * expected * 1e-4, "{total:?}");
        // moved out from the axis: pushed back across it by k (r - r0)
        let [on_fine, ..] = t.forces(&material, &Vec3::new(2e-4, 6e-5, 0.0), &coarse, &next);
        let radial = t.stiffness(&material) * 1e-5;
        assert!((on_fine.y + radial).abs() < 1e-9 * radial && on_fine.x.abs() < 1e-9 * radial, "{on_fine:?}");
    }

    #[test]
    fn tie_forces_are_the_energy_gradient_sum_to_zero_and_turn_with_the_body() {
        let material = FibreMaterial::kevlar_km2();
        let rest = [Vec3::new(1.9e-4, 3e-5, -4e-5), Vec3::zeros(), Vec3::new(-1.2e-4, 1e-5, 0.0)];
        let t = tie(rest[0], rest[1], rest[2]);
        let moved = [Vec3::new(2.1e-4, 5e-5, -2e-5), Vec3::new(1e-6, -2e-6, 3e-6), Vec3::new(-1.19e-4, 1.3e-5, 4e-6)];
        let forces = t.forces(&material, &moved[0], &moved[1], &moved[2]);
        let scale = forces.iter().map(|f| f.norm()).fold(0.0, f64::max);
        assert!(scale > 0.0);
        assert!(forces.iter().sum::<Vec3>().norm() < 1e-12 * scale);
        let h = 1e-10;
        for node in 0..3 {
            for k in 0..3 {
                let energy_at = |d: f64| {
                    let mut x = moved;
                    x[node][k] += d;
                    t.energy(&material, &x[0], &x[1], &x[2])
                };
                let gradient = (energy_at(h) - energy_at(-h)) / (2.0 * h);
                assert!((forces[node][k] + gradient).abs() < 1e-6 * scale, "node {node} axis {k}: {} vs {}", forces[node][k], -gradient);
            }
        }
        let turn = Rotation3::from_euler_angles(0.3, -1.1, 0.7);
        let turned = t.forces(&material, &(turn * moved[0]), &(turn * moved[1]), &(turn * moved[2]));
        for (a, b) in forces.iter().zip(&turned) {
            assert!((turn * a - b).norm() < 1e-12 * scale);
        }
    }

    /// Node ids: fine ends 0, 1, 2 at x = 0; the coarse end 10 at x = 1e-4 m, its neighbour
    /// 11 at x = 2e-4 m.
    fn fan(n_owned: usize, order: &[u64]) -> Nodes {
        let mut nodes = Nodes::default();
        for &g in order {
            let x = match g {
                10 => Vec3::new(1e-4, 0.0, 0.0),
                11 => Vec3::new(2e-4, 0.0, 0.0),
                _ => Vec3::new(0.0, (g as f64 - 1.0) * 2e-5, 0.0),
            };
            nodes.push(GlobalNodeId(g), x, Vec3::zeros(), 1e-9, FibreId(g as u32), 0, 0, false, true);
        }
        nodes.n_owned = n_owned;
        nodes
    }

    fn fan_ties() -> Vec<Tie> {
        let whole = fan(5, &[0, 1, 2, 10, 11]);
        (0..3).map(|g| Tie { fine: end(g), ..tie(whole.position[g as usize], whole.position[3], whole.position[4]) }).collect()
    }

    #[test]
    fn ties_sum_the_same_whatever_the_owner_and_report_a_missing_end() {
        let material = FibreMaterial::kevlar_km2();
        let stretch = |nodes: &mut Nodes| {
            for i in 0..nodes.len() {
                if nodes.gid[i] == GlobalNodeId(10) {
                    nodes.position[i] += Vec3::new(3e-6, 1e-6, -2e-6);
                }
            }
        };
        let list = fan_ties();
        let mut whole = fan(5, &[0, 1, 2, 10, 11]);
        let all = Ties::new(list.clone(), &whole);
        stretch(&mut whole);
        all.add_forces(&mut whole, &material);
        assert!(whole.force.iter().sum::<Vec3>().norm() < 1e-12 * whole.force[3].norm());
        // the coarse end owned alone, the other ends ghosts in scrambled order
        let mut part = fan(1, &[10, 2, 11, 0, 1]);
        let some = Ties::new(list.clone(), &part);
        assert_eq!(some.list().len(), 3);
        stretch(&mut part);
        some.add_forces(&mut part, &material);
        assert_eq!(part.force[0], whole.force[3]);
        // a fine end owned alone without its ghosts
        let lonely = fan(1, &[1]);
        let one = Ties::new(list, &lonely);
        assert_eq!(one.missing_end(1), Some((GlobalNodeId(1), GlobalNodeId(10))));
        assert_eq!(some.missing_end(1), None);
        let energy: f64 = all.energies(&whole, &material).map(|(_, e)| e).sum();
        assert!(energy > 0.0);
    }
}
