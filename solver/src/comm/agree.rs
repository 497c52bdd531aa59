//! Collective agreement: what every rank must decide alike. A rank's numerical failure
//! becomes every rank's ([`agree`]), a flag any rank raises is every rank's ([`any`]), and
//! rank 0's values are everyone's ([`from_rank0`]). No rank returns while others wait.

use dea_core::{DomainError, GlobalNodeId};

use super::Comm;

/// Makes a rank's error everyone's: every rank returns the error of the lowest node id any
/// rank reported (the kind first), with the same message; `step` and `time_step` [s] are the
/// step's, which every rank knows alike.
pub fn agree<C: Comm>(comm: &C, local: Result<(), DomainError>, step: u64, time_step: f64) -> Result<(), DomainError> {
    agree_and_any(comm, local, false, step, time_step).map(|_| ())
}

/// [`agree`], and whether any rank says `flag`, in the same reduction: the force stages'
/// agreement carries whether any rank broke an element (the unloading at the break then
/// needs every rank, theory I7).
pub fn agree_and_any<C: Comm>(
    comm: &C,
    local: Result<(), DomainError>,
    flag: bool,
    step: u64,
    time_step: f64,
) -> Result<bool, DomainError> {
    let code = match &local {
        Ok(()) => u64::MAX,
        Err(DomainError::NonFinite { gid, .. }) => (1 << 60) | gid.0,
        Err(DomainError::MissingGhost { gid, .. }) => (2 << 60) | gid.0,
        Err(DomainError::TimeStep { gid, .. }) => (3 << 60) | gid.0,
        Err(DomainError::ProjectileInverted { element, .. }) => (4 << 60) | *element as u64,
        Err(DomainError::MissingTiePartner { gid, .. }) => (5 << 60) | gid.0,
        // found from sums every rank holds alike, so usually agreed already
        Err(DomainError::NonFiniteEnergy { .. }) => 6 << 60,
    };
    let mut agreed = [code, u64::from(!flag)];
    comm.min_u64(&mut agreed);
    let [agreed, no_flag] = agreed;
    if agreed == u64::MAX {
        return Ok(no_flag == 0);
    }
    let gid = GlobalNodeId(agreed & ((1 << 60) - 1));
    // the detail only the reporting rank knows travels in a second reduction
    let mut detail = [match &local {
        Err(DomainError::MissingGhost { along, .. }) if code == agreed => *along as u64,
        Err(DomainError::TimeStep { limit, .. }) if code == agreed => limit.to_bits(),
        Err(DomainError::MissingTiePartner { partner, .. }) if code == agreed => partner.0,
        _ => u64::MAX,
    }];
    comm.min_u64(&mut detail);
    match agreed >> 60 {
        1 => Err(DomainError::NonFinite { step, gid }),
        2 => Err(DomainError::MissingGhost { gid, along: detail[0] as u32 }),
        4 => Err(DomainError::ProjectileInverted { step, element: gid.0 as usize }),
        5 => Err(DomainError::MissingTiePartner { gid, partner: GlobalNodeId(detail[0]) }),
        6 => Err(DomainError::NonFiniteEnergy {
            step,
            kinds: match local {
                Err(DomainError::NonFiniteEnergy { kinds, .. }) => kinds,
                _ => "found on another rank".into(),
            },
        }),
        _ => Err(DomainError::TimeStep { step, gid, time_step, limit: f64::from_bits(detail[0]) }),
    }
}

/// True on every rank when any rank says so.
pub fn any<C: Comm>(comm: &C, local: bool) -> bool {
    let mut flag = [if local { 1.0 } else { 0.0 }];
    comm.max_f64(&mut flag);
    flag[0] > 0.0
}

/// Rank 0's values on every rank.
pub fn from_rank0<C: Comm, const N: usize>(comm: &C, mut values: [f64; N]) -> [f64; N] {
    comm.broadcast_f64(&mut values);
    values
}
