//! Checkpoints of a rank's state keyed by global ids, and the restart from one on any rank
//! count with the same bits (docs/theory.md D11, docs/output.md).

use dea_core::nodes::FailureMode;
use dea_core::{Domain, DomainError, GlobalNodeId, Vec3};
use dea_io::checkpoint::NodeState;
use dea_partition::Partition;

use crate::comm::codec::{
    projectile_words, reaction_from_words, reaction_words, set_projectile_words, PROJECTILE_WORDS, REACTION_WORDS,
};
use crate::comm::Comm;
use crate::deformable::DeformableProjectile;
use crate::distributed::Distributed;

impl<C: Comm> Distributed<C> {
    /// The projectile's state for a checkpoint (rank 0): the rigid words, and a deformable
    /// body's nodes and element rotations after them, then the fibres' last reactions (a
    /// subcycling body holds them over the next step).
    pub fn projectile_state(&self) -> Vec<f64> {
        let mut words = self.domain.projectile.as_ref().map(|p| projectile_words(p).to_vec()).unwrap_or_default();
        if let Some(body) = &self.deformable {
            words.extend(body.body.state_words());
            words.extend(self.reactions.iter().flat_map(reaction_words));
        }
        words
    }

    /// The state of the owned nodes for a checkpoint, ascending gid.
    pub fn checkpoint_part(&self) -> NodeState {
        let d = &self.domain;
        let n = d.nodes.n_owned;
        let contacts = &d.projectile_contacts;
        let pairs = &d.pairs;
        // every entry's history as its node sees it (a pair of two owned nodes keeps one)
        let histories: Vec<_> = (0..n).flat_map(|i| pairs.row(i).map(move |k| pairs.history(i, k))).collect();
        let (retired_length, retired_gid, retired_max_overlap) = pairs.retired_as_full_rows();
        NodeState {
            gid: d.nodes.gid[..n].iter().map(|g| g.0).collect(),
            position: d.nodes.position[..n].to_vec(),
            velocity: (0..n).map(|i| d.velocity(i)).collect(),
            force: d.nodes.force[..n].to_vec(),
            reference_position: pairs.reference_position[..n].to_vec(),
            failure: d.elements.failure[..n].iter().map(|&m| m as u8).collect(),
            tensile_strength: d.elements.tensile_strength[..n].to_vec(),
            friction_dissipated: d.ledger.friction_dissipated.clone(),
            plastic_dissipated: d.ledger.plastic_dissipated.clone(),
            fracture_released: d.ledger.fracture_released.clone(),
            projectile_anchor: contacts.anchor.clone(),
            projectile_stretch: contacts.stretch.clone(),
            projectile_spring_stiffness: contacts.spring_stiffness.clone(),
            projectile_touching: contacts.touching.iter().map(|&t| t as u8).collect(),
            projectile_max_overlap: contacts.max_overlap.clone(),
            projectile_anchor_triangle: contacts.anchor_triangle.clone(),
            projectile_anchor_weights: contacts.anchor_weights.iter().map(|&w| Vec3::from(w)).collect(),
            row_length: (0..n).map(|i| pairs.row(i).len() as u32).collect(),
            partner_gid: pairs.partner_gid.iter().map(|g| g.0).collect(),
            anchor: histories.iter().map(|h| h.anchor).collect(),
            spring_stiffness: histories.iter().map(|h| h.spring_stiffness).collect(),
            touching: histories.iter().map(|h| h.touching as u8).collect(),
            max_overlap: histories.iter().map(|h| h.max_overlap).collect(),
            retired_length,
            retired_gid: retired_gid.iter().map(|g| g.0).collect(),
            retired_max_overlap,
        }
    }

    /// Restarts from a checkpoint. `domain` holds this rank's owned nodes as generated, in
    /// the gid order of `state`; the projectile's state is `projectile`. The neighbour lists
    /// are rebuilt from the positions of their last build (so they are the lists of the
    /// interrupted run; later rebuilds may fall on other steps, which changes no result,
    /// theory D11), then every history, position, velocity and force is put back and the
    /// ghosts are refreshed.
    #[allow(clippy::too_many_arguments)]
    pub fn restore(
        comm: C,
        mut domain: Domain,
        partition: Partition,
        nodes_per_fibre: &[u32],
        reach: f64,
        state: &NodeState,
        projectile: &[f64],
        mut deformable: Option<DeformableProjectile>,
    ) -> Result<Self, RestoreError> {
        let mut reactions = Vec::new();
        if let Some(deformable) = &mut deformable {
            let words = projectile.get(PROJECTILE_WORDS..).unwrap_or_default();
            let (body, held) = words.split_at(deformable.body.state_words().len().min(words.len()));
            deformable.body.set_state_words(body).ok_or_else(|| {
                RestoreError::Mismatch(format!(
                    "the checkpoint holds {} words of the deformable projectile, not those of the case's mesh",
                    body.len()
                ))
            })?;
            if held.len() % REACTION_WORDS != 0 {
                return Err(RestoreError::Mismatch(format!(
                    "the checkpoint's {} words of projectile reactions are not whole records",
                    held.len()
                )));
            }
            reactions.extend(held.chunks_exact(REACTION_WORDS).map(reaction_from_words));
        }
        let n = domain.nodes.n_owned;
        if state.gid.len() != n || domain.nodes.gid[..n].iter().zip(&state.gid).any(|(a, &b)| a.0 != b) {
            return Err(RestoreError::Mismatch("the checkpoint's nodes are not those of the case".into()));
        }
        // displacements are measured from the positions as generated, which these are
        let as_built = domain.nodes.position[..n].to_vec();
        for i in 0..n {
            domain.nodes.position[i] = state.reference_position[i];
            domain.elements.failure[i] = FailureMode::from_code(state.failure[i]).ok_or_else(|| {
                RestoreError::Mismatch(format!("node {}: failure code {}", state.gid[i], state.failure[i]))
            })?;
            domain.elements.tensile_strength[i] = state.tensile_strength[i];
        }
        if let Some(p) = &mut domain.projectile {
            set_projectile_words(p, projectile);
        }
        let mut restored = Self::assemble(comm, domain, partition, nodes_per_fibre, reach, deformable)?;
        restored.reactions = reactions;
        restored.as_built = as_built;
        let d = &mut restored.domain;
        // the lists rebuilt from the same positions are the interrupted run's lists
        let mut entry = 0usize;
        let mut mismatch = None;
        for i in 0..n {
            let row = d.pairs.row(i);
            let length = state.row_length[i] as usize;
            let saved = &state.partner_gid[entry..entry + length];
            if row.len() != length || d.pairs.partner_gid[row.clone()].iter().zip(saved).any(|(a, &b)| a.0 != b) {
                mismatch.get_or_insert(state.gid[i]);
            } else {
                for (k, e) in row.zip(entry..entry + length) {
                    d.pairs.anchor[k] = state.anchor[e];
                    d.pairs.spring_stiffness[k] = state.spring_stiffness[e];
                    d.pairs.touching[k] = state.touching[e] != 0;
                    d.pairs.max_overlap[k] = state.max_overlap[e];
                }
            }
            entry += length;
        }
        let mismatched = restored.any(mismatch.is_some());
        if mismatched {
            return Err(RestoreError::Mismatch("the contact lists rebuilt at the checkpoint differ from the saved ones: the checkpoint does not belong to this build or case".into()));
        }
        let d = &mut restored.domain;
        // the retired contacts are the interrupted run's (the rebuild above knew no history)
        d.pairs.retired_start = std::iter::once(0)
            .chain(state.retired_length.iter().scan(0u32, |total, &l| {
                *total += l;
                Some(*total)
            }))
            .collect();
        d.pairs.retired_gid = state.retired_gid.iter().map(|&g| GlobalNodeId(g)).collect();
        d.pairs.retired_max_overlap.clone_from(&state.retired_max_overlap);
        let contacts = &mut d.projectile_contacts;
        for i in 0..n {
            d.nodes.position[i] = state.position[i];
            d.nodes.velocity[i] = state.velocity[i];
            d.nodes.force[i] = state.force[i];
            d.ledger.friction_dissipated[i] = state.friction_dissipated[i];
            d.ledger.plastic_dissipated[i] = state.plastic_dissipated[i];
            d.ledger.fracture_released[i] = state.fracture_released[i];
            contacts.anchor[i] = state.projectile_anchor[i];
            contacts.stretch[i] = state.projectile_stretch[i];
            contacts.spring_stiffness[i] = state.projectile_spring_stiffness[i];
            contacts.touching[i] = state.projectile_touching[i] != 0;
            contacts.max_overlap[i] = state.projectile_max_overlap[i];
            contacts.anchor_triangle[i] = state.projectile_anchor_triangle[i];
            contacts.anchor_weights[i] = state.projectile_anchor_weights[i].into();
        }
        if let Some(p) = &mut d.projectile {
            set_projectile_words(p, projectile);
        }
        restored.forward_halo();
        restored.halo_steps = 0;
        restored.halo_bytes = 0;
        Ok(restored)
    }
}

/// Why a restart failed.
#[derive(Debug, thiserror::Error)]
pub enum RestoreError {
    /// The restored state is not finite or not stable.
    #[error("{0}")]
    Numerical(#[from] DomainError),
    /// The checkpoint does not fit the case or the job.
    #[error("{0}")]
    Mismatch(String),
}
