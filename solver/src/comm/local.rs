//! A communicator of threads in one process: the ranks of a multi-rank test.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::Duration;

use dea_core::Rank;

use super::Comm;

/// How long a waiting rank sleeps before it looks again whether another rank panicked.
const POLL: Duration = Duration::from_millis(20);

struct Shared {
    size: usize,
    /// one contribution per rank for the collective in progress
    slots: Mutex<Vec<Vec<u64>>>,
    /// (ranks arrived, generation)
    barrier: Mutex<(usize, u64)>,
    barrier_signal: Condvar,
    /// FIFO of messages from rank s to rank d at `s * size + d`
    mailboxes: Vec<Mutex<VecDeque<Vec<u64>>>>,
    mail_signal: Condvar,
    mail_lock: Mutex<()>,
    poisoned: AtomicBool,
}

impl Shared {
    fn check(&self) {
        if self.poisoned.load(Ordering::SeqCst) {
            panic!("another rank panicked");
        }
    }

    fn barrier(&self) {
        let mut state = self.barrier.lock().unwrap_or_else(|e| e.into_inner());
        let generation = state.1;
        state.0 += 1;
        if state.0 == self.size {
            *state = (0, generation + 1);
            self.barrier_signal.notify_all();
            return;
        }
        while state.1 == generation {
            self.check();
            state = self.barrier_signal.wait_timeout(state, POLL).unwrap_or_else(|e| e.into_inner()).0;
        }
    }
}

/// One rank of a [`run_local`] group.
pub struct LocalComm {
    rank: usize,
    shared: Arc<Shared>,
}

/// Marks the group poisoned when its rank's thread unwinds, so no other rank waits forever.
struct PoisonOnPanic(Arc<Shared>);

impl Drop for PoisonOnPanic {
    fn drop(&mut self) {
        if std::thread::panicking() {
            self.0.poisoned.store(true, Ordering::SeqCst);
            self.0.barrier_signal.notify_all();
            self.0.mail_signal.notify_all();
        }
    }
}

/// The shared state of a group of `size` ranks.
fn group(size: usize) -> Arc<Shared> {
    Arc::new(Shared {
        size,
        slots: Mutex::new(vec![Vec::new(); size]),
        barrier: Mutex::new((0, 0)),
        barrier_signal: Condvar::new(),
        mailboxes: (0..size * size).map(|_| Mutex::new(VecDeque::new())).collect(),
        mail_signal: Condvar::new(),
        mail_lock: Mutex::new(()),
        poisoned: AtomicBool::new(false),
    })
}

impl LocalComm {
    /// The communicator of a run on one rank, in the calling thread.
    pub fn alone() -> Self {
        Self { rank: 0, shared: group(1) }
    }
}

/// Runs `body` on `size` ranks, one thread each, and returns their results in rank order.
/// A panic on any rank ends every rank and is raised again here.
pub fn run_local<R: Send>(size: usize, body: impl Fn(LocalComm) -> R + Sync) -> Vec<R> {
    assert!(size >= 1, "a group has at least one rank");
    let shared = group(size);
    let results = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..size)
            .map(|rank| {
                let shared = shared.clone();
                let body = &body;
                std::thread::Builder::new()
                    .name(format!("rank {rank}"))
                    .spawn_scoped(scope, move || {
                        let _guard = PoisonOnPanic(shared.clone());
                        body(LocalComm { rank, shared })
                    })
                    .expect("spawn a rank thread")
            })
            .collect();
        handles.into_iter().map(|h| h.join()).collect::<Vec<_>>()
    });
    // raise the first rank's own panic, not the "another rank panicked" of the others
    let mut results_ok = Vec::with_capacity(size);
    let mut first_panic = None;
    for result in results {
        match result {
            Ok(value) => results_ok.push(value),
            Err(payload) => {
                let secondary = payload.downcast_ref::<&str>().is_some_and(|m| *m == "another rank panicked");
                if first_panic.is_none() || (!secondary && first_panic.as_ref().is_some_and(|(s, _)| *s)) {
                    first_panic = Some((secondary, payload));
                }
            }
        }
    }
    if let Some((_, payload)) = first_panic {
        std::panic::resume_unwind(payload);
    }
    results_ok
}

impl LocalComm {
    /// Every rank's contribution, in rank order.
    fn collective(&self, mine: Vec<u64>) -> Vec<Vec<u64>> {
        self.shared.check();
        self.shared.slots.lock().unwrap_or_else(|e| e.into_inner())[self.rank] = mine;
        self.shared.barrier();
        let all = self.shared.slots.lock().unwrap_or_else(|e| e.into_inner()).clone();
        self.shared.barrier();
        all
    }

    fn reduce_u64(&self, values: &mut [u64], op: impl Fn(u64, u64) -> u64) {
        let all = self.collective(values.to_vec());
        for (k, v) in values.iter_mut().enumerate() {
            *v = all.iter().map(|c| c[k]).reduce(&op).expect("at least one rank");
        }
    }

    fn send(&self, to: usize, message: Vec<u64>) {
        let _lock = self.shared.mail_lock.lock().unwrap_or_else(|e| e.into_inner());
        self.shared.mailboxes[self.rank * self.shared.size + to]
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push_back(message);
        self.shared.mail_signal.notify_all();
    }

    fn receive(&self, from: usize) -> Vec<u64> {
        let mut lock = self.shared.mail_lock.lock().unwrap_or_else(|e| e.into_inner());
        loop {
            if let Some(message) = self.shared.mailboxes[from * self.shared.size + self.rank]
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .pop_front()
            {
                return message;
            }
            self.shared.check();
            lock = self.shared.mail_signal.wait_timeout(lock, POLL).unwrap_or_else(|e| e.into_inner()).0;
        }
    }
}

fn bits(values: &[f64]) -> Vec<u64> {
    values.iter().map(|v| v.to_bits()).collect()
}

impl Comm for LocalComm {
    fn rank(&self) -> Rank {
        Rank(self.rank as u32)
    }

    fn size(&self) -> usize {
        self.shared.size
    }

    /// Every rank is a thread of this process.
    fn ranks_on_host(&self) -> usize {
        self.shared.size
    }

    fn max_f64(&self, values: &mut [f64]) {
        let all = self.collective(bits(values));
        for (k, v) in values.iter_mut().enumerate() {
            *v = all.iter().map(|c| f64::from_bits(c[k])).fold(f64::NEG_INFINITY, f64::max);
        }
    }

    fn min_u64(&self, values: &mut [u64]) {
        self.reduce_u64(values, u64::min);
    }

    fn sum_i64(&self, values: &mut [i64]) {
        let mut words: Vec<u64> = values.iter().map(|&v| v as u64).collect();
        self.reduce_u64(&mut words, u64::wrapping_add);
        for (v, w) in values.iter_mut().zip(words) {
            *v = w as i64;
        }
    }

    fn or_u64(&self, values: &mut [u64]) {
        self.reduce_u64(values, |a, b| a | b);
    }

    fn all_gather_f64(&self, mine: &[f64]) -> Vec<f64> {
        self.collective(bits(mine)).into_iter().flatten().map(f64::from_bits).collect()
    }

    fn broadcast_f64(&self, values: &mut [f64]) {
        let all = self.collective(bits(values));
        for (v, &w) in values.iter_mut().zip(&all[0]) {
            *v = f64::from_bits(w);
        }
    }

    fn broadcast_bytes(&self, bytes: &mut Vec<u8>) {
        let all = self.collective(bytes.iter().map(|&b| b as u64).collect());
        *bytes = all[0].iter().map(|&b| b as u8).collect();
    }

    fn gather_f64(&self, mine: &[f64]) -> Option<Vec<Vec<f64>>> {
        let all = self.collective(bits(mine));
        (self.rank == 0).then(|| all.into_iter().map(|c| c.into_iter().map(f64::from_bits).collect()).collect())
    }

    fn exchange(&self, partners: &[Rank], sends: &[Vec<f64>], receives: &mut [Vec<f64>]) {
        self.shared.check();
        for (partner, message) in partners.iter().zip(sends) {
            self.send(partner.0 as usize, bits(message));
        }
        for (partner, receive) in partners.iter().zip(receives.iter_mut()) {
            let message = self.receive(partner.0 as usize);
            assert_eq!(
                message.len(),
                receive.len(),
                "rank {} expected {} values from rank {}, got {}",
                self.rank,
                receive.len(),
                partner.0,
                message.len()
            );
            for (r, m) in receive.iter_mut().zip(message) {
                *r = f64::from_bits(m);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn collectives_and_exchange_on_three_ranks() {
        let results = run_local(3, |comm| {
            let r = comm.rank().0 as usize;
            let mut max = [r as f64, -(r as f64)];
            comm.max_f64(&mut max);
            let mut sum = [r as i64 + 1, -1];
            comm.sum_i64(&mut sum);
            let mut min = [10 - r as u64];
            comm.min_u64(&mut min);
            let mut or = [1u64 << r];
            comm.or_u64(&mut or);
            let gathered = comm.all_gather_f64(&[r as f64]);
            let mut broadcast = [r as f64 + 0.5];
            comm.broadcast_f64(&mut broadcast);
            let mut text = if r == 0 { b"case".to_vec() } else { Vec::new() };
            comm.broadcast_bytes(&mut text);
            let at_root = comm.gather_f64(&vec![r as f64; r]);
            // a ring: send to the next rank, receive from the previous one, unknown sizes
            let (next, previous) = (Rank(((r + 1) % 3) as u32), Rank(((r + 2) % 3) as u32));
            let mut received = vec![Vec::new(), Vec::new()];
            comm.exchange_sized(&[next, previous], &[vec![r as f64; r + 1], vec![]], &mut received);
            (max, sum, min, or, gathered, broadcast, text, at_root, received)
        });
        for (r, (max, sum, min, or, gathered, broadcast, text, at_root, received)) in results.into_iter().enumerate() {
            assert_eq!(max, [2.0, 0.0]);
            assert_eq!(sum, [6, -3]);
            assert_eq!(min, [8]);
            assert_eq!(or, [7]);
            assert_eq!(gathered, vec![0.0, 1.0, 2.0]);
            assert_eq!(broadcast, [0.5]);
            assert_eq!(text, b"case");
            assert_eq!(at_root.is_some(), r == 0);
            if let Some(all) = at_root {
                assert_eq!(all, vec![vec![], vec![1.0], vec![2.0, 2.0]]);
            }
            let previous = (r + 2) % 3;
            assert_eq!(received[1], vec![previous as f64; previous + 1]);
            assert!(received[0].is_empty());
        }
    }

    #[test]
    fn a_panic_on_one_rank_ends_every_rank() {
        let outcome = std::panic::catch_unwind(|| {
            run_local(3, |comm| {
                if comm.rank() == Rank(1) {
                    panic!("rank 1 fails");
                }
                // the others wait in a collective that rank 1 never joins
                let mut v = [0.0];
                comm.max_f64(&mut v);
            })
        });
        let payload = outcome.expect_err("the group fails");
        assert_eq!(payload.downcast_ref::<&str>(), Some(&"rank 1 fails"));
    }
}
