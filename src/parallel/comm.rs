//! The communication the decomposed step needs, behind one trait: [`Serial`] (one rank),
//! [`ThreadComm`] (ranks as threads of one process, for tests and for checking a
//! decomposition without MPI) and, with the `mpi` feature, MPI.
//!
//! Every operation is called by every rank, in the same order: collectives (results the
//! same bits on every rank, or every rank's on rank 0 for the gather to it) and one
//! neighbour exchange, where each rank sends to and
//! receives from the ranks it names, with message sizes both sides computed alike.

use std::ops::Range;
use std::sync::{Arc, Condvar, Mutex};

/// Collective communication between the ranks of one model.
pub trait Comm: Send + Sync {
    /// This process's rank, 0-based.
    fn rank(&self) -> usize;
    /// Number of ranks.
    fn size(&self) -> usize;
    /// Element-wise sum over the ranks, in place. Used where it is exact in any summation
    /// order: each element non-zero on at most one rank (a unit's partial sum on its
    /// designated rank), or integers whose sum stays below 2⁵³ (the digits of
    /// [`crate::math::ExactSum`]).
    fn sum_f64(&self, data: &mut [f64]);
    /// Element-wise maximum over the ranks, in place (exact in any order).
    fn max_f64(&self, data: &mut [f64]);
    /// Every rank's bytes, indexed by rank.
    fn allgather_bytes(&self, mine: &[u8]) -> Vec<Vec<u8>>;
    /// Every rank's bytes, indexed by rank, on rank 0 only (empty on the others): for what
    /// only rank 0 reads (whole frames). The default gathers to every rank and drops them.
    fn gather_bytes_to_root(&self, mine: &[u8]) -> Vec<Vec<u8>> {
        let all = self.allgather_bytes(mine);
        if self.rank() == 0 {
            all
        } else {
            Vec::new()
        }
    }
    /// Fill `data[ranges[r]]` on every rank from rank r's copy (`ranges` is the same on every
    /// rank; ranges are disjoint).
    fn allgather_ranges_f64(&self, data: &mut [f64], ranges: &[Range<usize>]);
    /// Neighbour exchange: send each `(rank, data)` of `sends` to that rank and fill each
    /// `(rank, buffer)` of `recvs` from it. Every rank calls it (possibly with nothing to
    /// send or receive); a rank appears at most once in each list, never this rank, and the
    /// two sides agree on every message's length (empty messages are not sent).
    fn exchange_f64(&self, sends: &[(usize, &[f64])], recvs: &mut [(usize, &mut [f64])]);
    /// One count from every rank to every rank: `send[q]` is what this rank tells rank q;
    /// returns what each rank told this one, indexed by rank (a collective; how the two
    /// sides of a neighbour exchange agree on lengths that only the sender knows).
    fn alltoall_counts(&self, send: &[u64]) -> Vec<u64> {
        let bytes: Vec<u8> = send.iter().flat_map(|c| c.to_le_bytes()).collect();
        let at = 8 * self.rank();
        (self.allgather_bytes(&bytes).iter())
            .map(|b| u64::from_le_bytes(b[at..at + 8].try_into().expect("8 bytes")))
            .collect()
    }
}

/// One rank: every collective is the identity.
#[derive(Debug, Default)]
pub struct Serial;

impl Comm for Serial {
    fn rank(&self) -> usize {
        0
    }
    fn size(&self) -> usize {
        1
    }
    fn sum_f64(&self, _data: &mut [f64]) {}
    fn max_f64(&self, _data: &mut [f64]) {}
    fn allgather_bytes(&self, mine: &[u8]) -> Vec<Vec<u8>> {
        vec![mine.to_vec()]
    }
    fn allgather_ranges_f64(&self, _data: &mut [f64], _ranges: &[Range<usize>]) {}
    fn exchange_f64(&self, sends: &[(usize, &[f64])], recvs: &mut [(usize, &mut [f64])]) {
        assert!(
            sends.is_empty() && recvs.is_empty(),
            "one rank has no neighbours"
        );
    }
}

/// Ranks as threads of one process, exchanging through shared slots between barriers. Slow
/// (every collective copies), but the same decomposition and the same arithmetic as MPI:
/// what tests use to check that N ranks reproduce one, without an MPI installation.
pub struct ThreadComm {
    rank: usize,
    shared: Arc<Shared>,
}

struct Shared {
    barrier: RankBarrier,
    slots: Vec<Mutex<Vec<u8>>>,
    /// Neighbour messages, `from * size + to`.
    messages: Vec<Mutex<Vec<f64>>>,
}

impl ThreadComm {
    /// Run `f` on `size` ranks, each on its own thread with its own communicator; the
    /// results in rank order. A panic on one rank is re-raised here (the other ranks may
    /// then wait forever at their next collective, so tests keep ranks in lockstep).
    pub fn run<T: Send>(size: usize, f: impl Fn(Arc<dyn Comm>) -> T + Sync) -> Vec<T> {
        assert!(size >= 1);
        let shared = Arc::new(Shared {
            barrier: RankBarrier::new(size),
            slots: (0..size).map(|_| Mutex::new(Vec::new())).collect(),
            messages: (0..size * size).map(|_| Mutex::new(Vec::new())).collect(),
        });
        std::thread::scope(|s| {
            let handles: Vec<_> = (0..size)
                .map(|rank| {
                    let comm: Arc<dyn Comm> = Arc::new(ThreadComm {
                        rank,
                        shared: shared.clone(),
                    });
                    let (f, shared) = (&f, shared.clone());
                    std::thread::Builder::new()
                        .name(format!("rank {rank}"))
                        .stack_size(64 << 20)
                        .spawn_scoped(s, move || {
                            // A rank that panics releases the others from their next
                            // collective (they panic there) instead of leaving them waiting.
                            let _release = ReleaseOnPanic(&shared.barrier);
                            f(comm)
                        })
                        .expect("spawn a rank thread")
                })
                .collect();
            let results: Vec<_> = handles.into_iter().map(|h| h.join()).collect();
            // Re-raise the panic that started it, not the other ranks' release.
            let released =
                |e: &Box<dyn std::any::Any + Send>| e.downcast_ref::<&str>() == Some(&RELEASED);
            if let Some(i) = (results
                .iter()
                .position(|r| r.as_ref().is_err_and(|e| !released(e))))
            .or_else(|| results.iter().position(Result::is_err))
            {
                let mut results = results;
                std::panic::resume_unwind(results.swap_remove(i).err().expect("a panic"));
            }
            results.into_iter().map(|r| r.expect("no panic")).collect()
        })
    }
}

/// What a rank panics with when another rank panicked (ThreadComm).
const RELEASED: &str = "another rank panicked";

/// The ranks' meeting point (ThreadComm): like `std::sync::Barrier`, but a rank that panics
/// releases the others, which then panic at the collective they wait in, so that a test
/// fails instead of hanging.
struct RankBarrier {
    size: usize,
    /// Ranks arrived in this round, the round, a rank panicked.
    state: Mutex<(usize, u64, bool)>,
    turn: Condvar,
}

impl RankBarrier {
    fn new(size: usize) -> Self {
        RankBarrier {
            size,
            state: Mutex::new((0, 0, false)),
            turn: Condvar::new(),
        }
    }

    fn wait(&self) {
        let mut s = self.state.lock().unwrap_or_else(|e| e.into_inner());
        let round = s.1;
        if !s.2 {
            s.0 += 1;
            if s.0 == self.size {
                (s.0, s.1) = (0, round + 1);
                self.turn.notify_all();
                return;
            }
            while s.1 == round && !s.2 {
                s = self.turn.wait(s).unwrap_or_else(|e| e.into_inner());
            }
            if s.1 != round {
                return;
            }
        }
        drop(s);
        std::panic::panic_any(RELEASED);
    }

    fn release(&self) {
        self.state.lock().unwrap_or_else(|e| e.into_inner()).2 = true;
        self.turn.notify_all();
    }
}

/// Releases the other ranks when its rank's thread unwinds.
struct ReleaseOnPanic<'a>(&'a RankBarrier);

impl Drop for ReleaseOnPanic<'_> {
    fn drop(&mut self) {
        if std::thread::panicking() {
            self.0.release();
        }
    }
}

impl Comm for ThreadComm {
    fn rank(&self) -> usize {
        self.rank
    }
    fn size(&self) -> usize {
        self.shared.slots.len()
    }
    fn sum_f64(&self, data: &mut [f64]) {
        let all = self.allgather_bytes(as_bytes(data));
        // −0 is the additive identity (0 + −0 = 0 would lose a −0 some rank sent).
        data.fill(-0.0);
        for bytes in &all {
            for (d, b) in data.iter_mut().zip(bytes.chunks_exact(8)) {
                *d += f64::from_le_bytes(b.try_into().expect("8 bytes"));
            }
        }
    }
    fn max_f64(&self, data: &mut [f64]) {
        let all = self.allgather_bytes(as_bytes(data));
        data.fill(f64::NEG_INFINITY);
        for bytes in &all {
            for (d, b) in data.iter_mut().zip(bytes.chunks_exact(8)) {
                *d = d.max(f64::from_le_bytes(b.try_into().expect("8 bytes")));
            }
        }
    }
    fn allgather_bytes(&self, mine: &[u8]) -> Vec<Vec<u8>> {
        *self.shared.slots[self.rank].lock().expect("slot") = mine.to_vec();
        self.shared.barrier.wait();
        let all = self
            .shared
            .slots
            .iter()
            .map(|s| s.lock().expect("slot").clone())
            .collect();
        // Nobody writes a slot again until everybody has read them all.
        self.shared.barrier.wait();
        all
    }
    fn allgather_ranges_f64(&self, data: &mut [f64], ranges: &[Range<usize>]) {
        let mine = as_bytes(&data[ranges[self.rank].clone()]).to_vec();
        let all = self.allgather_bytes(&mine);
        for (r, bytes) in all.iter().enumerate() {
            if r == self.rank {
                continue;
            }
            for (d, b) in data[ranges[r].clone()]
                .iter_mut()
                .zip(bytes.chunks_exact(8))
            {
                *d = f64::from_le_bytes(b.try_into().expect("8 bytes"));
            }
        }
    }
    fn exchange_f64(&self, sends: &[(usize, &[f64])], recvs: &mut [(usize, &mut [f64])]) {
        let size = self.size();
        for &(to, data) in sends {
            *self.shared.messages[self.rank * size + to]
                .lock()
                .expect("message") = data.to_vec();
        }
        self.shared.barrier.wait();
        for (from, buf) in recvs.iter_mut() {
            let message = std::mem::take(
                &mut *self.shared.messages[*from * size + self.rank]
                    .lock()
                    .expect("message"),
            );
            assert_eq!(message.len(), buf.len(), "rank {from} to {}", self.rank);
            buf.copy_from_slice(&message);
        }
        // Nobody writes a message again until everybody has read theirs.
        self.shared.barrier.wait();
    }
}

/// MPI ranks (feature `mpi`): the world communicator of the processes `mpirun` started.
#[cfg(feature = "mpi")]
pub struct MpiComm {
    world: mpi::topology::SimpleCommunicator,
}

// SAFETY: fdem calls MPI only from the thread that steps the model (MPI initialised with
// `Threading::Single`; rayon's workers never touch the communicator), so the handle is
// never used from two threads at once.
#[cfg(feature = "mpi")]
unsafe impl Send for MpiComm {}
// SAFETY: as for Send.
#[cfg(feature = "mpi")]
unsafe impl Sync for MpiComm {}

#[cfg(feature = "mpi")]
impl MpiComm {
    /// The world communicator of an initialised MPI `universe` (which must outlive it).
    pub fn world(universe: &mpi::environment::Universe) -> Self {
        MpiComm {
            world: universe.world(),
        }
    }
}

#[cfg(feature = "mpi")]
impl Comm for MpiComm {
    fn rank(&self) -> usize {
        use mpi::traits::Communicator;
        self.world.rank() as usize
    }
    fn size(&self) -> usize {
        use mpi::traits::Communicator;
        self.world.size() as usize
    }
    fn sum_f64(&self, data: &mut [f64]) {
        use mpi::collective::SystemOperation;
        use mpi::traits::CommunicatorCollectives;
        let send = data.to_vec();
        self.world
            .all_reduce_into(&send[..], data, SystemOperation::sum());
    }
    fn max_f64(&self, data: &mut [f64]) {
        use mpi::collective::SystemOperation;
        use mpi::traits::CommunicatorCollectives;
        let send = data.to_vec();
        self.world
            .all_reduce_into(&send[..], data, SystemOperation::max());
    }
    fn allgather_bytes(&self, mine: &[u8]) -> Vec<Vec<u8>> {
        use mpi::datatype::PartitionMut;
        use mpi::traits::CommunicatorCollectives;
        let n = self.size();
        let mut counts = vec![0 as mpi::Count; n];
        self.world
            .all_gather_into(&(mine.len() as mpi::Count), &mut counts[..]);
        let displs = displacements(&counts);
        let total = counts.iter().sum::<mpi::Count>() as usize;
        if total == 0 {
            return vec![Vec::new(); n];
        }
        // An empty slice's pointer is dangling, 1 for bytes: Open MPI's MPI_IN_PLACE. So
        // an empty send goes from a real (zero-length) place, and nothing empty is received.
        let pad = [0u8; 1];
        let send = if mine.is_empty() { &pad[..0] } else { mine };
        let mut all = vec![0u8; total];
        {
            let mut part = PartitionMut::new(&mut all[..], &counts[..], &displs[..]);
            self.world.all_gather_varcount_into(send, &mut part);
        }
        split_at_displacements(&all, &counts, &displs)
    }
    fn gather_bytes_to_root(&self, mine: &[u8]) -> Vec<Vec<u8>> {
        use mpi::datatype::PartitionMut;
        use mpi::traits::{Communicator, Root};
        let n = self.size();
        let root = self.world.process_at_rank(0);
        let count = mine.len() as mpi::Count;
        if self.rank() != 0 {
            root.gather_into(&count);
            let pad = [0u8; 1];
            root.gather_varcount_into(if mine.is_empty() { &pad[..0] } else { mine });
            return Vec::new();
        }
        let mut counts = vec![0 as mpi::Count; n];
        root.gather_into_root(&count, &mut counts[..]);
        let displs = displacements(&counts);
        let total = counts.iter().sum::<mpi::Count>() as usize;
        // (As in allgather_bytes: nothing empty is sent from a dangling pointer, and the
        // receive buffer has at least one byte.)
        let pad = [0u8; 1];
        let send = if mine.is_empty() { &pad[..0] } else { mine };
        let mut all = vec![0u8; total.max(1)];
        {
            let mut part = PartitionMut::new(&mut all[..], &counts[..], &displs[..]);
            root.gather_varcount_into_root(send, &mut part);
        }
        split_at_displacements(&all, &counts, &displs)
    }
    fn allgather_ranges_f64(&self, data: &mut [f64], ranges: &[Range<usize>]) {
        use mpi::datatype::PartitionMut;
        use mpi::traits::CommunicatorCollectives;
        let counts: Vec<mpi::Count> = ranges.iter().map(|r| r.len() as mpi::Count).collect();
        let displs: Vec<mpi::Count> = ranges.iter().map(|r| r.start as mpi::Count).collect();
        let mine = data[ranges[self.rank()].clone()].to_vec();
        let mut part = PartitionMut::new(data, &counts[..], &displs[..]);
        self.world.all_gather_varcount_into(&mine[..], &mut part);
    }
    fn alltoall_counts(&self, send: &[u64]) -> Vec<u64> {
        use mpi::traits::CommunicatorCollectives;
        let mut recv = vec![0u64; self.size()];
        self.world.all_to_all_into(send, &mut recv[..]);
        recv
    }
    fn exchange_f64(&self, sends: &[(usize, &[f64])], recvs: &mut [(usize, &mut [f64])]) {
        use mpi::traits::{Communicator, Destination, Source};
        // One tag for the neighbour exchange: messages between two ranks arrive in the
        // order sent, and each call completes before the next.
        const TAG: mpi::Tag = 17;
        mpi::request::scope(|scope| {
            let received: Vec<_> = recvs
                .iter_mut()
                .filter(|(_, buf)| !buf.is_empty())
                .map(|(from, buf)| {
                    self.world
                        .process_at_rank(*from as mpi::Rank)
                        .immediate_receive_into_with_tag(scope, &mut buf[..], TAG)
                })
                .collect();
            let sent: Vec<_> = sends
                .iter()
                .filter(|(_, data)| !data.is_empty())
                .map(|&(to, data)| {
                    self.world
                        .process_at_rank(to as mpi::Rank)
                        .immediate_send_with_tag(scope, data, TAG)
                })
                .collect();
            for r in received {
                r.wait();
            }
            for s in sent {
                s.wait();
            }
        });
    }
}

/// Where each rank's part starts in a gathered buffer of parts of `counts` bytes, in rank
/// order.
#[cfg(feature = "mpi")]
fn displacements(counts: &[mpi::Count]) -> Vec<mpi::Count> {
    (counts.iter())
        .scan(0, |acc, &c| {
            let d = *acc;
            *acc += c;
            Some(d)
        })
        .collect()
}

/// Each rank's part of a gathered buffer, in rank order.
#[cfg(feature = "mpi")]
fn split_at_displacements(
    all: &[u8],
    counts: &[mpi::Count],
    displs: &[mpi::Count],
) -> Vec<Vec<u8>> {
    (counts.iter().zip(displs))
        .map(|(&c, &d)| all[d as usize..(d + c) as usize].to_vec())
        .collect()
}

/// The bytes of an f64 slice in little-endian order.
fn as_bytes(data: &[f64]) -> &[u8] {
    // SAFETY: f64 has no padding and any byte pattern is a valid u8; the length is exact.
    // (Every target fdem builds for is little-endian; `from_le_bytes` reads them back.)
    unsafe { std::slice::from_raw_parts(data.as_ptr().cast::<u8>(), std::mem::size_of_val(data)) }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A rank that panics makes the run panic with its message; the ranks waiting in a
    /// collective are released, not left to hang.
    #[test]
    #[should_panic(expected = "rank 1 fails")]
    fn a_panicking_rank_fails_the_run_instead_of_hanging() {
        ThreadComm::run(3, |c| {
            if c.rank() == 1 {
                panic!("rank 1 fails");
            }
            let mut v = [1.0];
            c.sum_f64(&mut v);
            c.sum_f64(&mut v);
        });
    }

    /// Each collective gives every rank the same answer: the designated-rank sum is exact,
    /// the range gather fills every range from its rank, bytes come back in rank order.
    #[test]
    fn thread_collectives_agree_on_every_rank() {
        let out = ThreadComm::run(3, |c| {
            let r = c.rank();
            let mut s = [0.0; 3];
            s[r] = 0.1 * (r as f64 + 1.0);
            c.sum_f64(&mut s);
            let ranges = [0..2, 2..3, 3..6];
            let mut d = [f64::NAN; 6];
            for i in ranges[r].clone() {
                d[i] = i as f64;
            }
            c.allgather_ranges_f64(&mut d, &ranges);
            let b = c.allgather_bytes(&[r as u8; 2]);
            // A ring: each rank sends r + 1 values to the next and receives from the one
            // before; rank 1 sends nothing to rank 2 (an empty message is skipped alike).
            let (next, before) = ((r + 1) % 3, (r + 2) % 3);
            let out = vec![r as f64; if r == 1 { 0 } else { r + 1 }];
            let mut got = vec![f64::NAN; if before == 1 { 0 } else { before + 1 }];
            c.exchange_f64(&[(next, &out)], &mut [(before, &mut got)]);
            // Rank r tells rank q 10·r + q.
            let counts = c.alltoall_counts(&[10 * r as u64, 10 * r as u64 + 1, 10 * r as u64 + 2]);
            (s, d, b, got, counts)
        });
        for (r, (s, d, b, got, counts)) in out.into_iter().enumerate() {
            assert_eq!(counts, vec![r as u64, 10 + r as u64, 20 + r as u64]);
            assert_eq!(s, [0.1, 0.2, 0.30000000000000004]);
            assert_eq!(d, [0.0, 1.0, 2.0, 3.0, 4.0, 5.0]);
            assert_eq!(b, vec![vec![0, 0], vec![1, 1], vec![2, 2]]);
            let before = (r + 2) % 3;
            assert!(got.iter().all(|&g| g == before as f64), "rank {r}: {got:?}");
        }
    }
}
