//! This rank's part of a field snapshot: its owned nodes and elements, and the ghosts its
//! elements reach (written per rank, joined by one XDMF file; docs/output.md).

use dea_io::snapshot::SnapshotPart;

use crate::comm::Comm;
use crate::distributed::Distributed;

impl<C: Comm> Distributed<C> {
    /// This rank's part of a field snapshot (collective: ghost velocities are refreshed).
    // nodes, elements and stresses are indexed alike: a range loop reads plainest
    #[allow(clippy::needless_range_loop)]
    pub fn snapshot_part(&mut self) -> SnapshotPart {
        self.refresh_ghost_velocities();
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
            part.connectivity.push([i as u32, point]);
            part.element_gid.push(nodes.gid[i].0);
            part.strain.push(d.elements.strain[i]);
            part.stress.push(stress[i]);
            part.failure.push(d.elements.failure[i] as u8);
        }
        part
    }
}
