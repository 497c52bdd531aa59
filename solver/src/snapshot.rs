//! This rank's part of a field snapshot: its owned nodes and elements, and the ghosts its
//! elements reach (written per rank, joined by one XDMF file; docs/output.md).

use dea_core::nodes::FailureMode;
use dea_io::snapshot::SnapshotPart;

use crate::comm::Comm;
use crate::distributed::Distributed;

impl<C: Comm> Distributed<C> {
    /// This rank's part of a field snapshot (collective: ghost velocities are refreshed).
    // nodes, elements and stresses are indexed alike: a range loop reads plainest
    #[allow(clippy::needless_range_loop)]
    pub fn snapshot_part(&mut self) -> SnapshotPart {
        self.refresh_ghost_velocities();
        let ghost_displacements = self.halo.forward_vectors(&self.comm, |i| self.displacement(i));
        let me = self.comm.rank().0;
        let d = &self.domain;
        let nodes = &d.nodes;
        let n = nodes.n_owned;
        let stress = d.element_stress();
        let mut part = SnapshotPart::default();
        let mut point_of_ghost = std::collections::HashMap::new();
        let add_point = |part: &mut SnapshotPart, i: usize, rank: u32| {
            part.position.push(nodes.position[i]);
            part.velocity.push(d.velocity(i));
            part.displacement.push(if i < n { self.displacement(i) } else { ghost_displacements[i - n] });
            part.gid.push(nodes.gid[i].0);
            part.layer.push(self.layer_of(nodes.fibre[i]));
            part.yarn.push(self.partition.yarn_of(nodes.fibre[i]) as u32);
            part.rank.push(rank);
        };
        for i in 0..n {
            add_point(&mut part, i, me);
        }
        for i in 0..n {
            let next = nodes.next[i];
            if next == dea_core::NONE {
                continue;
            }
            let j = next as usize;
            let point = if j < n {
                j as u32
            } else {
                *point_of_ghost.entry(j).or_insert_with(|| {
                    let owner = self.partition.rank_of(nodes.fibre[j], nodes.along[j]).0;
                    add_point(&mut part, j, owner);
                    (part.gid.len() - 1) as u32
                })
            };
            let failure = d.elements.failure[i];
            let cells = if failure == FailureMode::Intact { &mut part.intact } else { &mut part.broken };
            cells.push([i as u32, point], nodes.gid[i].0, d.elements.strain[i], stress[i], failure as u8);
        }
        part
    }
}
