//! The communication layer. [`Comm`] is everything the distributed step needs from a
//! communicator; [`mpi::MpiComm`] implements it over MPI (the only MPI code of the
//! project), [`local::LocalComm`] over threads of one process, so multi-rank runs are plain
//! `cargo test`s. On top of it, in LAMMPS's vocabulary: [`halo`] (the plan, `borders` and
//! `forward`), [`codec`] (how every message is encoded) and [`agree`] (collective decisions).

pub mod agree;
pub mod codec;
pub mod halo;
pub mod local;
pub mod mpi;

use dea_core::Rank;

/// A communicator: collectives over every rank, and point-to-point exchange with partners.
/// Every rank must call the collectives in the same order.
pub trait Comm {
    /// This process's rank.
    fn rank(&self) -> Rank;
    /// Ranks of the communicator.
    fn size(&self) -> usize;
    /// Ranks on this rank's host (sharing its memory) that run this job, this one included:
    /// this communicator's, or, for a group split from a larger one, the larger one's,
    /// because its other groups run their shots of the same target at the same time.
    /// Collective.
    fn ranks_on_host(&self) -> usize;
    /// Element-wise maximum over ranks, in place.
    fn max_f64(&self, values: &mut [f64]);
    /// Element-wise minimum over ranks, in place.
    fn min_u64(&self, values: &mut [u64]);
    /// Element-wise sum over ranks, in place (integer sums are exact in any order).
    fn sum_i64(&self, values: &mut [i64]);
    /// Element-wise bitwise or over ranks, in place.
    fn or_u64(&self, values: &mut [u64]);
    /// Every rank's `mine` (equal lengths on every rank), concatenated in rank order.
    fn all_gather_f64(&self, mine: &[f64]) -> Vec<f64>;
    /// Rank 0's `values` on every rank (equal lengths on every rank).
    fn broadcast_f64(&self, values: &mut [f64]);
    /// Rank 0's bytes on every rank (the others' vectors are replaced).
    fn broadcast_bytes(&self, bytes: &mut Vec<u8>);
    /// Every rank's `mine` on rank 0, in rank order; `None` on the other ranks.
    fn gather_f64(&self, mine: &[f64]) -> Option<Vec<Vec<f64>>>;
    /// Sends `sends[k]` to `partners[k]` and fills `receives[k]`, already sized to the
    /// message, from it. Both sides list each other. Receives are posted before sends.
    fn exchange(&self, partners: &[Rank], sends: &[Vec<f64>], receives: &mut [Vec<f64>]);

    /// [`Comm::exchange`] when the receiver does not know the sizes: lengths travel first.
    fn exchange_sized(&self, partners: &[Rank], sends: &[Vec<f64>], receives: &mut [Vec<f64>]) {
        let lengths: Vec<Vec<f64>> = sends.iter().map(|s| vec![f64::from_bits(s.len() as u64)]).collect();
        let mut incoming: Vec<Vec<f64>> = vec![vec![0.0]; partners.len()];
        self.exchange(partners, &lengths, &mut incoming);
        for (receive, length) in receives.iter_mut().zip(&incoming) {
            receive.clear();
            receive.resize(length[0].to_bits() as usize, 0.0);
        }
        self.exchange(partners, sends, receives);
    }
}
