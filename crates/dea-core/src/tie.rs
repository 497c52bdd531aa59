//! Ties: rods that join the end node of a fine digital fibre to a node of a coarse one, where
//! a hybrid yarn changes its number of digital fibres along its length (docs/theory.md F12).
//!
//! A tie is an axial rod (seed 4-2) with the fine fibre's area, so the ties of a transition
//! carry the yarn's whole area `A_yarn` across it. It has no bending spring (both of its
//! nodes are fibre ends, whose springs are absent anyway) and does not fail: a hybrid mesh
//! puts its transitions where the fibres stay far below their strength.

use crate::ids::{FibreId, GlobalNodeId, NONE};
use crate::nodes::Nodes;
use crate::rod::{axial_energy, axial_force};
use crate::FibreMaterial;

/// One end of a tie: a node named by its global id, fibre and position along the fibre.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct TieEnd {
    pub gid: GlobalNodeId,
    pub fibre: FibreId,
    pub along: u32,
}

/// A rod from the end node of a fine fibre to a coarse fibre's node.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tie {
    pub fine: TieEnd,
    pub coarse: TieEnd,
    /// rest length: the distance of the two nodes as built [m]
    pub rest_length: f64,
    /// cross-section area: the fine fibre's [m^2]
    pub area: f64,
    /// length of the fine fibre the tie stands for (its elements left out between its end
    /// and the coarse node's station), which sets the tie's mass [m]
    pub fibre_length: f64,
}

impl Tie {
    /// Axial stiffness `E A / l0` in tension, the larger of its two [N/m].
    pub fn stiffness(&self, material: &FibreMaterial) -> f64 {
        material.longitudinal_modulus * self.area / self.rest_length
    }

    /// Mass of the fine fibre the tie stands for, `rho A l_fibre`, which its two nodes share
    /// equally [kg].
    pub fn mass(&self, material: &FibreMaterial) -> f64 {
        material.density * self.area * self.fibre_length
    }
}

/// The ties of one domain: every tie with an owned end.
#[derive(Clone, Debug, Default)]
pub struct Ties {
    /// ascending (coarse gid, fine gid): a coarse node sums its ties in this order, so the
    /// sum does not depend on the partition
    list: Vec<Tie>,
    /// local indices [fine, coarse] of each tie's ends (`NONE` while a ghost is missing)
    local: Vec<[u32; 2]>,
}

impl Ties {
    /// The ties of `list` with an end among the owned nodes of `nodes` (ascending gid).
    pub fn new(mut list: Vec<Tie>, nodes: &Nodes) -> Self {
        let owned = &nodes.gid[..nodes.n_owned];
        list.retain(|t| {
            owned.binary_search(&t.fine.gid).is_ok() || owned.binary_search(&t.coarse.gid).is_ok()
        });
        list.sort_by_key(|t| (t.coarse.gid, t.fine.gid));
        let mut ties = Self {
            local: vec![[NONE; 2]; list.len()],
            list,
        };
        ties.link(nodes);
        ties
    }

    pub fn list(&self) -> &[Tie] {
        &self.list
    }

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
        let mut ghosts: Vec<(GlobalNodeId, u32)> = (nodes.n_owned..nodes.len())
            .map(|i| (nodes.gid[i], i as u32))
            .collect();
        ghosts.sort_unstable();
        let find = |gid: GlobalNodeId| match owned.binary_search(&gid) {
            Ok(i) => i as u32,
            Err(_) => ghosts
                .binary_search_by_key(&gid, |g| g.0)
                .map_or(NONE, |k| ghosts[k].1),
        };
        for (tie, local) in self.list.iter().zip(&mut self.local) {
            *local = [find(tie.fine.gid), find(tie.coarse.gid)];
        }
    }

    /// The first tie (in list order) one of whose ends is not local: (owned end, missing end).
    pub fn missing_end(&self) -> Option<(GlobalNodeId, GlobalNodeId)> {
        self.list
            .iter()
            .zip(&self.local)
            .find_map(|(t, l)| match *l {
                [NONE, _] => Some((t.coarse.gid, t.fine.gid)),
                [_, NONE] => Some((t.fine.gid, t.coarse.gid)),
                _ => None,
            })
    }

    /// Adds the axial force of every tie (4-2, scaled in compression like any element) to
    /// its owned ends. Every end's sum runs in list order, whatever the partition.
    pub fn add_forces(&self, nodes: &mut Nodes, material: &FibreMaterial) {
        for (tie, &[fine, coarse]) in self.list.iter().zip(&self.local) {
            let (fine, coarse) = (fine as usize, coarse as usize);
            let axis = nodes.position[coarse] - nodes.position[fine];
            let length = axis.norm();
            let strain = (length - tie.rest_length) / tie.rest_length;
            // on the fine end, along the tie when stretched
            let force = axis * (axial_force(material, tie.area, strain) / length);
            if fine < nodes.n_owned {
                nodes.force[fine] += force;
            }
            if coarse < nodes.n_owned {
                nodes.force[coarse] -= force;
            }
        }
    }

    /// Strain energy `E A l0 eps^2 / 2` of every tie whose fine end is owned, with that end's
    /// local index (each tie counted once over all ranks) [J].
    pub fn energies<'a>(
        &'a self,
        nodes: &'a Nodes,
        material: &'a FibreMaterial,
    ) -> impl Iterator<Item = (usize, f64)> + 'a {
        self.list
            .iter()
            .zip(&self.local)
            .filter(|(_, l)| (l[0] as usize) < nodes.n_owned)
            .map(|(tie, &[fine, coarse])| {
                let length =
                    (nodes.position[coarse as usize] - nodes.position[fine as usize]).norm();
                (
                    fine as usize,
                    axial_energy(
                        material,
                        tie.area,
                        tie.rest_length,
                        (length - tie.rest_length) / tie.rest_length,
                    ),
                )
            })
    }

    /// Axial stiffness the ties add to each of the `n_owned` owned nodes [N/m].
    pub fn stiffness_on_owned(&self, n_owned: usize, material: &FibreMaterial) -> Vec<f64> {
        let mut stiffness = vec![0.0; n_owned];
        for (tie, local) in self.list.iter().zip(&self.local) {
            for &i in local {
                if (i as usize) < n_owned {
                    stiffness[i as usize] += tie.stiffness(material);
                }
            }
        }
        stiffness
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Vec3;

    /// Node ids: fine ends 0, 1, 2 at x = 0; coarse node 10 at x = 1e-4 m.
    fn fan(n_owned: usize, order: &[u64]) -> Nodes {
        let mut nodes = Nodes::default();
        for &g in order {
            let x = if g == 10 {
                Vec3::new(1e-4, 0.0, 0.0)
            } else {
                Vec3::new(0.0, (g as f64 - 1.0) * 2e-5, 0.0)
            };
            nodes.push(
                GlobalNodeId(g),
                x,
                Vec3::zeros(),
                1e-9,
                FibreId(g as u32),
                0,
                0,
                false,
                true,
            );
        }
        nodes.n_owned = n_owned;
        nodes
    }

    fn ties(nodes: &Nodes) -> Vec<Tie> {
        let coarse = TieEnd {
            gid: GlobalNodeId(10),
            fibre: FibreId(10),
            along: 0,
        };
        (0..3)
            .map(|g| {
                let x = nodes.position[nodes
                    .gid
                    .iter()
                    .position(|&n| n == GlobalNodeId(g))
                    .unwrap()];
                Tie {
                    fine: TieEnd {
                        gid: GlobalNodeId(g),
                        fibre: FibreId(g as u32),
                        along: 0,
                    },
                    coarse,
                    rest_length: (Vec3::new(1e-4, 0.0, 0.0) - x).norm(),
                    area: 1e-9,
                    fibre_length: 1e-4,
                }
            })
            .collect()
    }

    #[test]
    fn a_tie_pulls_with_e_a_strain_and_its_forces_cancel() {
        let material = FibreMaterial::kevlar_km2();
        let mut nodes = fan(4, &[0, 1, 2, 10]);
        let list = ties(&nodes);
        let ties = Ties::new(list.clone(), &nodes);
        assert_eq!(
            ties.stiffness_on_owned(4, &material)[3],
            list.iter().map(|t| t.stiffness(&material)).sum::<f64>()
        );
        // stretch: move the coarse node by 1 um along x
        nodes.position[3].x += 1e-6;
        ties.add_forces(&mut nodes, &material);
        // the middle tie lies along x: E A eps, eps = 1e-6 / 1e-4
        let expected = material.longitudinal_modulus * 1e-9 * 1e-2;
        assert!(
            (nodes.force[1].x - expected).abs() < 1e-9 * expected,
            "{} vs {expected}",
            nodes.force[1].x
        );
        assert!(nodes.force[1].y.abs() < 1e-12 * expected);
        let total: Vec3 = nodes.force.iter().sum();
        assert!(
            total.norm() < 1e-12 * expected,
            "the ties' forces sum to {total:?}"
        );
        let energy: f64 = ties.energies(&nodes, &material).map(|(_, e)| e).sum();
        let tension = list.iter().map(|t| {
            let l = (nodes.position[3] - nodes.position[t.fine.gid.0 as usize]).norm();
            axial_energy(
                &material,
                t.area,
                t.rest_length,
                (l - t.rest_length) / t.rest_length,
            )
        });
        assert_eq!(energy, tension.sum::<f64>());
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
        let mut whole = fan(4, &[0, 1, 2, 10]);
        let list = ties(&whole);
        let all = Ties::new(list.clone(), &whole);
        stretch(&mut whole);
        all.add_forces(&mut whole, &material);
        // the coarse node owned alone, its fine partners ghosts in scrambled order
        let mut part = fan(1, &[10, 2, 0, 1]);
        let mut some = Ties::new(list.clone(), &part);
        assert_eq!(some.list().len(), 3);
        stretch(&mut part);
        some.add_forces(&mut part, &material);
        assert_eq!(part.force[0], whole.force[3]);
        // a fine end owned alone without its ghost
        let lonely = fan(1, &[1]);
        let one = Ties::new(list, &lonely);
        assert_eq!(one.missing_end(), Some((GlobalNodeId(1), GlobalNodeId(10))));
        some.link(&part);
        assert_eq!(some.missing_end(), None);
    }
}
