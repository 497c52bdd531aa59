//! [`Comm`] over MPI (rsmpi on Open MPI): the only code of the project that calls MPI.

use dea_core::Rank;
use mpi::collective::SystemOperation;
use mpi::datatype::PartitionMut;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use mpi::Count;

use super::Comm;

/// The world communicator of an MPI job (a singleton when started without mpirun), or a
/// group split from it.
pub struct MpiComm {
    world: SimpleCommunicator,
    /// for a group split from a larger communicator: the larger one's ranks on this host,
    /// whose groups fire their shots at the same time
    host_ranks_of_parent: Option<usize>,
}

/// MPI itself: initialised by [`MpiComm::initialize`], finalised when dropped. It outlives
/// the communicator handed to the solver, so that ranks can still line up after an error.
pub struct MpiSession {
    _universe: mpi::environment::Universe,
}

impl MpiSession {
    /// Waits for every rank (after rank 0 printed an error, before anyone exits: mpirun
    /// kills the job at the first non-zero exit).
    pub fn barrier(&self) {
        SimpleCommunicator::world().barrier();
    }

    /// This process's rank in the communicator.
    pub fn rank(&self) -> Rank {
        Rank(SimpleCommunicator::world().rank() as u32)
    }
}

impl MpiComm {
    /// Initialises MPI. When the job has more than one rank, a panic on any rank aborts the
    /// whole job at once instead of leaving the others waiting in a collective.
    pub fn initialize() -> anyhow::Result<(MpiSession, Self)> {
        let universe = mpi::initialize().ok_or_else(|| anyhow::anyhow!("MPI was already initialised"))?;
        let world = universe.world();
        if world.size() > 1 {
            let default_hook = std::panic::take_hook();
            std::panic::set_hook(Box::new(move |info| {
                default_hook(info);
                eprintln!("error: rank {} panicked; aborting every rank", SimpleCommunicator::world().rank());
                SimpleCommunicator::world().abort(70);
            }));
        }
        Ok((MpiSession { _universe: universe }, Self { world, host_ranks_of_parent: None }))
    }
}

impl MpiComm {
    /// The ranks of this communicator that give the same `color`, in rank order
    /// (`MPI_Comm_split`): a campaign's groups of ranks, one per concurrent shot. Collective.
    pub fn split(&self, color: u32) -> Self {
        let host_ranks = self.ranks_on_host();
        let group = self.world.split_by_color(mpi::topology::Color::with_value(color as i32)).expect("every rank names a group");
        Self { world: group, host_ranks_of_parent: Some(host_ranks) }
    }
}

/// Values an in-place reduction copies on the stack: the per-step reductions are this small.
const STACK_VALUES: usize = 8;

impl MpiComm {
    /// In-place all-reduce: MPI wants separate buffers, so the input is copied first (on the
    /// stack for the few values of the per-step reductions, no allocation in the step).
    fn all_reduce<T: Equivalence + Copy + Default>(&self, values: &mut [T], op: SystemOperation) {
        if values.len() <= STACK_VALUES {
            let mut mine = [T::default(); STACK_VALUES];
            mine[..values.len()].copy_from_slice(values);
            self.world.all_reduce_into(&mine[..values.len()], values, op);
        } else {
            let mine = values.to_vec();
            self.world.all_reduce_into(&mine[..], values, op);
        }
    }
}

impl Comm for MpiComm {
    fn rank(&self) -> Rank {
        Rank(self.world.rank() as u32)
    }

    fn size(&self) -> usize {
        self.world.size() as usize
    }

    fn ranks_on_host(&self) -> usize {
        self.host_ranks_of_parent.unwrap_or_else(|| self.world.split_shared(0).size() as usize)
    }

    fn max_f64(&self, values: &mut [f64]) {
        self.all_reduce(values, SystemOperation::max());
    }

    fn min_u64(&self, values: &mut [u64]) {
        self.all_reduce(values, SystemOperation::min());
    }

    fn sum_i64(&self, values: &mut [i64]) {
        self.all_reduce(values, SystemOperation::sum());
    }

    fn or_u64(&self, values: &mut [u64]) {
        self.all_reduce(values, SystemOperation::bitwise_or());
    }

    fn all_gather_f64(&self, mine: &[f64]) -> Vec<f64> {
        let mut all = vec![0.0; mine.len() * self.size()];
        self.world.all_gather_into(mine, &mut all[..]);
        all
    }

    fn broadcast_f64(&self, values: &mut [f64]) {
        self.world.process_at_rank(0).broadcast_into(values);
    }

    fn broadcast_bytes(&self, bytes: &mut Vec<u8>) {
        let root = self.world.process_at_rank(0);
        let mut length = bytes.len() as u64;
        root.broadcast_into(&mut length);
        bytes.resize(length as usize, 0);
        root.broadcast_into(&mut bytes[..]);
    }

    fn gather_f64(&self, mine: &[f64]) -> Option<Vec<Vec<f64>>> {
        let root = self.world.process_at_rank(0);
        let count = mine.len() as Count;
        if self.world.rank() != 0 {
            root.gather_into(&count);
            root.gather_varcount_into(mine);
            return None;
        }
        let mut counts = vec![0 as Count; self.size()];
        root.gather_into_root(&count, &mut counts[..]);
        let displacements: Vec<Count> = counts.iter().scan(0, |offset, &c| {
            let start = *offset;
            *offset += c;
            Some(start)
        }).collect();
        let mut all = vec![0.0; counts.iter().map(|&c| c as usize).sum()];
        {
            let mut partition = PartitionMut::new(&mut all[..], &counts[..], &displacements[..]);
            root.gather_varcount_into_root(mine, &mut partition);
        }
        Some(counts.iter().zip(&displacements).map(|(&c, &d)| all[d as usize..(d + c) as usize].to_vec()).collect())
    }

    fn exchange(&self, partners: &[Rank], sends: &[Vec<f64>], receives: &mut [Vec<f64>]) {
        mpi::request::multiple_scope(2 * partners.len(), |scope, requests| {
            for (partner, receive) in partners.iter().zip(receives.iter_mut()) {
                requests.add(self.world.process_at_rank(partner.0 as i32).immediate_receive_into(scope, &mut receive[..]));
            }
            for (partner, send) in partners.iter().zip(sends) {
                requests.add(self.world.process_at_rank(partner.0 as i32).immediate_send(scope, &send[..]));
            }
            let mut done = Vec::with_capacity(2 * partners.len());
            requests.wait_all(&mut done);
        });
    }
}
