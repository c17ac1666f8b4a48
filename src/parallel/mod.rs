//! Domain decomposition: one model on several ranks (processes under MPI, or threads for
//! tests), giving the same bits as one rank.
//!
//! **How the work is split.** Every rank builds the whole model (SPMD: each runs the script).
//! Stage 7's chunks of `integration::CHUNK` nodes (never splitting a rigid body) are given to
//! ranks by recursive bisection of their places, balanced by tet corners ([`Partition`]);
//! bodies larger than a chunk are stored in spatial order (`mesh::order`), so a chunk is a
//! compact piece of its body and a rank's chunks one region of the model. A rank *owns* the
//! nodes of its chunks: it alone integrates them (stage 7). After each step each rank sends
//! the x and v of its nodes that other ranks read while stepping (the nodes of work units
//! and contact pairs that span ranks, and of nodal force sets) to the ranks that read them,
//! a neighbour exchange ([`Halo`]); the rest of the model
//! (all nodes' x, v, reactions; every joint's history) is shared only when the script reads
//! it ([`Parallel::share_nodes`], [`Parallel::share_joint_histories`], called through
//! `Simulation::synchronize`), and to rank 0 alone for a whole frame
//! (`Simulation::gather_frame_to_root`).
//!
//! **Why the bits are the same.** A node's force is a sum of contributions in an order that
//! does not depend on threads: within each stage the stage fixes it (per body and tet order
//! in stage 1, block schedule and joint order in stage 2), and stages add in stage order. The
//! owner of a node computes every work unit (a stage's chunk of elements, a block of joints)
//! that touches one of its nodes, in full, so it adds the same contributions in the same
//! order as one rank would. Energies and other totals are exact sums
//! ([`crate::math::ExactSum`], the same bits in any order) of the units' partial sums: each
//! unit is *designated* to one of the ranks that compute it (the lowest rank owning one of
//! its nodes), each rank sums its designated units' partials exactly, and one sum over the
//! ranks of those exact sums' digits (a fixed size, whatever the number of units) gives every
//! rank the one-rank totals, at one of the step's two meetings: after stage 3 (stages 1
//! and 2, the break-event count, stage 4's skin test; [`Parallel::close_joint_stages`]) and
//! after stage 7 (stages 5 and 7; [`Parallel::close_contact_and_integration`]), before the
//! halo. Break events are exchanged after stage 3, only in a step where
//! some joint broke (each joint's by its designated rank), merged in joint order, and every
//! rank marks them broken, so the surfaces that contact detection derives from them agree.
//!
//! **Contact.** Every rank holds stage 4's surface and fragments (and the boxes of the
//! surface tets within its reach), but only the
//! candidate pairs it computes: those with a tet holding a node of its own, a choice fixed
//! by the pair's two tets, so a pair's history is current wherever it is computed. Each rank
//! searches only around those tets and keeps their pairs (the
//! [`crate::contact_detection::PairExchange`] impl), so its list is the single-process
//! list's sub-list of its pairs, in the same order, and no list is gathered. The nodes of the
//! pairs two ranks compute are exported ([`Parallel::follow_pairs`]: every owner of a node of
//! such a pair computes it, so both sides of each message know it); the skin test is each
//! rank's own nodes' and the answers combined; before a full detection each rank receives
//! the nodes within reach of its own ([`Parallel::share_nodes_near`]: the pairs of its tets
//! cannot reach further), and after an incremental one the nodes its added pairs read that
//! two ranks compute ([`Parallel::share_added_pairs_nodes`]). The pairs' totals are exact sums over each rank's designated pairs (the lowest
//! rank owning a node of the pair), summed over the ranks; the few pairs that hand a joint
//! over, start touching or see their friction law fail send a record, keyed by the pair's
//! two surface tets and merged in that order ([`Parallel::close_contact_and_integration`]).
//! The whole list with every pair's history is shared for a new split
//! ([`Parallel::share_contact_histories`]) and gathered to rank 0 for a checkpoint; the next step's stage 4 keeps each rank's own
//! pairs again. A whole frame gathers to rank 0 alone what it shows: the nodes' x and v,
//! the damaged joints' damage and the touching pairs' outputs
//! ([`Parallel::gather_nodes_to_root`], [`Parallel::gather_joint_damage_to_root`],
//! [`Parallel::gather_pair_outputs_to_root`]); the other ranks' state is left as it was. A
//! frame in pieces exchanges only the joints and pairs across pieces
//! ([`Parallel::joint_damage_for_piece`], [`Parallel::pair_outputs_for_piece`]).
//!
//! **Rebars and rigid bodies.** Every rank computes every bar, hinge and bond point (few
//! beside the host's tets), in the one-rank order, so their nodes and their host tets' are
//! exported. A rigid body's nodes are never split: the rank owning them gathers the body's
//! force and torque and shares them ([`Parallel::share_rigid_loads`]), and every rank
//! advances every rigid body alike, after the nodes' sums.
//!
//! **What this is not yet.** The model is replicated: memory per rank does not shrink,
//! except stage 5's pair state and stage 4's pair list. Stage 4's surface and fragment
//! lists are whole on every rank, and its grid is built over the surface tets within reach
//! (docs/cluster.md lists the next steps).

pub mod comm;

/// Set by [`check_halo`] (tests) or `FDEM_CHECK_HALO=1` (read once).
static CHECK_HALO: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Poison, after each step, every node a rank does not keep current (see
/// `Parallel::check_halo`) in the models split from now on: for tests, which cannot set the
/// environment safely once threads run.
pub fn check_halo(on: bool) {
    CHECK_HALO.store(on, std::sync::atomic::Ordering::Relaxed);
}

/// Whether splits poison the nodes a rank does not keep current: [`check_halo`], or
/// `FDEM_CHECK_HALO=1` in the environment.
fn halo_checked() -> bool {
    static FROM_ENV: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    CHECK_HALO.load(std::sync::atomic::Ordering::Relaxed)
        || *FROM_ENV.get_or_init(|| std::env::var_os("FDEM_CHECK_HALO").is_some_and(|v| v == "1"))
}

use crate::fracture::{BreakEvent, JointMask};
use crate::integration::IntegrationSums;
use crate::joints::{JointSums, Joints};
use crate::math::{Partial, Real, Vec3};
use crate::state::{Body, Layout, Tets};
pub use comm::{Comm, Serial, ThreadComm};
use std::ops::Range;
use std::sync::Arc;

/// The ranks this process belongs to, when it was started as one of several (`mpirun`):
/// set once at startup by the command line; models built by scripts are decomposed over it.
static WORLD: std::sync::OnceLock<Arc<dyn Comm>> = std::sync::OnceLock::new();

/// Make `comm` this process's world (once; a second call is ignored).
pub fn set_world(comm: Arc<dyn Comm>) {
    let _ = WORLD.set(comm);
}

/// This process's world, if it is one of several ranks.
pub fn world() -> Option<Arc<dyn Comm>> {
    WORLD.get().cloned()
}

/// Whether this process writes files and prints: the only process, or rank 0 of its world.
pub fn is_root() -> bool {
    WORLD.get().is_none_or(|w| w.rank() == 0)
}

/// An error only this rank met (writing its piece of a frame), for the console: prefixed
/// with "rank R of N: " on a decomposed run, unchanged on one process. Errors every rank
/// meets alike (the script's) are printed by rank 0 alone; these by the rank that met them
/// ([`names_this_rank`]).
pub fn on_this_rank(msg: String) -> String {
    match WORLD.get() {
        Some(w) if w.size() > 1 => format!("rank {} of {}: {msg}", w.rank(), w.size()),
        _ => msg,
    }
}

/// Whether `msg` is an error of this rank alone ([`on_this_rank`]).
pub fn names_this_rank(msg: &str) -> bool {
    WORLD
        .get()
        .is_some_and(|w| msg.contains(&format!("rank {} of {}: ", w.rank(), w.size())))
}

/// The split of one model's nodes and work between ranks, as seen from one rank.
///
/// **Ownership by place.** The nodes are cut into stage 7's chunks of
/// [`crate::integration::CHUNK`] consecutive nodes (chunks a rigid body spans stay
/// together: a *group*), and the groups are given to ranks by recursive coordinate
/// bisection of their centres, each cut at the weighted median along the widest extent, so
/// that every rank's nodes form one compact region of the model. A group weighs the tet
/// corners at its nodes (a node of no tet weighs one). A body larger than a chunk is stored
/// along a Z-order curve (`mesh::order`), so each of its chunks is a compact piece of it; a
/// large body is split between ranks by place, and many small bodies are grouped by where
/// they lie, not by when they were added. (Until 2026-11-29 each rank owned one contiguous
/// range of node indices: a body whose nodes came first, a slab or a container, went whole
/// to rank 0 with all its contact pairs.)
#[derive(Clone, Debug, Default)]
pub struct Partition {
    pub rank: usize,
    /// The number of ranks.
    pub ranks: usize,
    /// The rank owning each chunk of [`crate::integration::CHUNK`] nodes.
    pub chunk_owner: Vec<u32>,
    /// Each rank's chunks, in chunk order.
    pub rank_chunks: Vec<Vec<u32>>,
    /// The number of nodes each rank owns.
    pub nodes_per_rank: Vec<usize>,
    /// The number of nodes.
    pub n_nodes: usize,
    /// The lowest rank owning one of the tet's nodes.
    pub tet_min_rank: Vec<u32>,
    /// The tet has a node of this rank.
    pub tet_relevant: Vec<bool>,
}

impl Partition {
    /// Split `x.len()` nodes between `size` ranks by place: chunks of
    /// [`crate::integration::CHUNK`] nodes (never splitting a rigid body's nodes) given to
    /// ranks by recursive coordinate bisection of their weighted centres, balanced by the
    /// number of tet corners at each node (a node of no tet weighs one). Every rank computes
    /// the same split from the same model.
    pub fn new(rank: usize, size: usize, x: &[Vec3], tets: &Tets, bodies: &[Body]) -> Self {
        Self::keeping(rank, size, x, tets, bodies, &[], None)
    }

    /// [`Partition::new`], its parts numbered so that as many chunks as can keep their
    /// `previous` owner (the parts are the same, only which rank takes which changes).
    /// `work`: as for [`chunk_groups`].
    pub fn keeping(
        rank: usize,
        size: usize,
        x: &[Vec3],
        tets: &Tets,
        bodies: &[Body],
        work: &[u32],
        previous: Option<&[u32]>,
    ) -> Self {
        let groups = chunk_groups(x, tets, bodies, work);
        Self::from_groups(rank, size, x.len(), &groups, tets, previous)
    }

    /// The split of [`Partition::new`] from its groups of chunks (see [`chunk_groups`]).
    fn from_groups(
        rank: usize,
        size: usize,
        n_nodes: usize,
        groups: &[ChunkGroup],
        tets: &Tets,
        previous: Option<&[u32]>,
    ) -> Self {
        let chunk = crate::integration::CHUNK;
        let chunk_owner = owners_of_groups(groups, size, n_nodes.div_ceil(chunk), previous);
        let mut rank_chunks = vec![Vec::new(); size];

        let mut nodes_per_rank = vec![0usize; size];
        for (c, &r) in chunk_owner.iter().enumerate() {
            rank_chunks[r as usize].push(c as u32);
            nodes_per_rank[r as usize] += ((c + 1) * chunk).min(n_nodes) - c * chunk;
        }
        let mut p = Partition {
            rank,
            ranks: size,
            chunk_owner,
            rank_chunks,
            nodes_per_rank,
            n_nodes,
            tet_min_rank: Vec::new(),
            tet_relevant: Vec::new(),
        };
        p.tet_min_rank = tets
            .nodes
            .iter()
            .map(|t| {
                t.iter()
                    .map(|&n| p.owner(n as usize) as u32)
                    .min()
                    .expect("4 nodes")
            })
            .collect();
        p.tet_relevant = tets
            .nodes
            .iter()
            .map(|t| t.iter().any(|&n| p.owns(n as usize)))
            .collect();
        p
    }

    pub fn size(&self) -> usize {
        self.ranks
    }

    /// Whether the model has been split ([`Partition::new`]).
    pub fn is_split(&self) -> bool {
        self.ranks > 0
    }

    /// The rank owning node `n`.
    #[inline]
    pub fn owner(&self, n: usize) -> usize {
        self.chunk_owner[n / crate::integration::CHUNK] as usize
    }

    #[inline]
    pub fn owns(&self, n: usize) -> bool {
        self.owner(n) == self.rank
    }

    /// Whether this rank owns chunk `c` of [`crate::integration::CHUNK`] nodes.
    #[inline]
    pub fn owns_chunk(&self, c: usize) -> bool {
        self.chunk_owner[c] as usize == self.rank
    }

    /// Rank `r`'s nodes, chunk by chunk in chunk order.
    pub fn nodes_of(&self, r: usize) -> impl Iterator<Item = Range<usize>> + '_ {
        let chunk = crate::integration::CHUNK;
        self.rank_chunks[r]
            .iter()
            .map(move |&c| c as usize * chunk..((c as usize + 1) * chunk).min(self.n_nodes))
    }

    /// The joints at this rank's nodes, and those designated to it (the lowest rank owning
    /// one of the joint's six nodes). With `contact`, a joint is also at this rank's nodes
    /// when one of its two tets is: a contact pair of the two reads whether the broken joint
    /// still holds their faces, and the ranks computing the pair compute that. (For jointed
    /// bodies this adds nothing: a tet's four nodes are consecutive and ranges are aligned,
    /// so one rank owns the whole tet; it matters where a joint's tet shares nodes.)
    pub fn joint_mask(&self, joints: &Joints, contact: bool) -> JointMask {
        let (relevant, designated) = joints
            .faces
            .iter()
            .zip(&joints.tets)
            .map(|(f, t)| {
                let nodes = f.iter().flatten().map(|&n| n as usize);
                let relevant = nodes.clone().any(|n| self.owns(n))
                    || (contact && t.iter().any(|&e| self.tet_relevant[e as usize]));
                let lowest = nodes.map(|n| self.owner(n)).min().expect("6 nodes");
                (relevant, lowest == self.rank)
            })
            .unzip();
        JointMask {
            relevant,
            designated,
        }
    }

    /// Compute and designation flags of work units, each a list of items with (lowest rank,
    /// relevant to this rank): a unit is computed when one item is relevant, and designated
    /// to the lowest rank of its items (which computes it, owning a node of that item).
    pub fn unit_flags<I>(&self, units: impl Iterator<Item = I>) -> UnitFlags
    where
        I: Iterator<Item = (u32, bool)>,
    {
        let mut flags = UnitFlags::default();
        for items in units {
            let (lowest, relevant) =
                items.fold((u32::MAX, false), |(l, r), (il, ir)| (l.min(il), r || ir));
            flags.compute.push(relevant);
            flags.designated.push(lowest == self.rank as u32);
        }
        flags
    }
}

/// Recursive coordinate bisection: give the groups `order` (indices into `groups`: chunk
/// range, weight, centre) to `ranks`. The groups are sorted along the widest extent of
/// their centres (ties by index: the same on every rank) and cut where the weight before
/// the cut is nearest to the first half's share of the ranks (⌊n/2⌋ of n), leaving each
/// side a group per rank where there are enough; each side is bisected on.
/// A group of consecutive chunks that one rank owns (a chunk, or the chunks of a rigid
/// body): its chunk range, weight (tet corners at its nodes, a node of no tet counting one)
/// and weighted centre.
pub type ChunkGroup = (Range<usize>, u64, Vec3);

/// The groups of chunks of a model at the positions `x` ([`Partition::new`]).
///
/// `work` (empty, or one number per node): the modelled work at each node besides its tets,
/// in quarters of a tet corner ([`crate::pipeline::Simulation::modelled_work`]); given, a
/// node weighs 4 per tet corner plus its work.
pub fn chunk_groups(x: &[Vec3], tets: &Tets, bodies: &[Body], work: &[u32]) -> Vec<ChunkGroup> {
    let chunk = crate::integration::CHUNK;
    let n_nodes = x.len();
    let n_chunks = n_nodes.div_ceil(chunk);
    let mut weight = vec![0u32; n_nodes];
    for t in &tets.nodes {
        for &n in t {
            weight[n as usize] += 1;
        }
    }
    if !work.is_empty() {
        for (w, &extra) in weight.iter_mut().zip(work) {
            *w = 4 * (*w).max(1) + extra;
        }
    }
    // Chunk c joins chunk c − 1 when a rigid body spans both.
    let mut joins_previous = vec![false; n_chunks];
    for b in bodies.iter().filter(|b| b.layout == Layout::Rigid) {
        if b.nodes.is_empty() {
            continue;
        }
        let (first, last) = (b.nodes.start / chunk, (b.nodes.end - 1) / chunk);
        for j in joins_previous.iter_mut().take(last + 1).skip(first + 1) {
            *j = true;
        }
    }
    let mut groups: Vec<ChunkGroup> = Vec::new();
    for (c, &joins) in joins_previous.iter().enumerate() {
        if !joins || groups.is_empty() {
            groups.push((c..c + 1, 0, Vec3::zeros()));
        }
        let g = groups.last_mut().expect("a group");
        g.0.end = c + 1;
        for n in c * chunk..((c + 1) * chunk).min(n_nodes) {
            let w = u64::from(weight[n].max(1));
            g.1 += w;
            g.2 += x[n] * w as Real;
        }
    }
    for g in &mut groups {
        g.2 /= g.1.max(1) as Real;
    }
    groups
}

/// The rank of each of `n_chunks` chunks: recursive bisection of the groups' centres.
fn owners_of_groups(
    groups: &[ChunkGroup],
    size: usize,
    n_chunks: usize,
    previous: Option<&[u32]>,
) -> Vec<u32> {
    let mut group_rank = vec![0u32; groups.len()];
    let mut order: Vec<usize> = (0..groups.len()).collect();
    bisect(groups, &mut order, 0..size, &mut group_rank);
    let mut chunk_owner = vec![0u32; n_chunks];
    for (g, &r) in groups.iter().zip(&group_rank) {
        chunk_owner[g.0.clone()].fill(r);
    }
    if let Some(previous) = previous.filter(|p| p.len() == n_chunks) {
        let rank_of_part = matching_ranks(&chunk_owner, previous, size);
        chunk_owner
            .iter_mut()
            .for_each(|o| *o = rank_of_part[*o as usize]);
    }
    chunk_owner
}

/// Which rank takes each part of a new split (`parts`: a part per chunk) so that many
/// chunks keep their `previous` owner: greedily, the largest overlap of a part and a rank
/// first (ties: lower part, then lower rank); parts left take the ranks left in order.
/// The same on every rank.
fn matching_ranks(parts: &[u32], previous: &[u32], size: usize) -> Vec<u32> {
    let mut overlap = vec![0u64; size * size];
    for (&p, &r) in parts.iter().zip(previous) {
        if (p as usize) < size && (r as usize) < size {
            overlap[p as usize * size + r as usize] += 1;
        }
    }
    let mut pairs: Vec<(u64, usize, usize)> = (0..size * size)
        .filter(|&k| overlap[k] > 0)
        .map(|k| (overlap[k], k / size, k % size))
        .collect();
    pairs.sort_by(|a, b| b.0.cmp(&a.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    let (mut rank_of, mut taken) = (vec![u32::MAX; size], vec![false; size]);
    for (_, part, rank) in pairs {
        if rank_of[part] == u32::MAX && !taken[rank] {
            rank_of[part] = rank as u32;
            taken[rank] = true;
        }
    }
    let mut free = (0..size).filter(|&r| !taken[r]);
    for r in rank_of.iter_mut().filter(|r| **r == u32::MAX) {
        *r = free.next().expect("as many ranks as parts") as u32;
    }
    rank_of
}

fn bisect(groups: &[ChunkGroup], order: &mut [usize], ranks: Range<usize>, group_rank: &mut [u32]) {
    if ranks.len() <= 1 || order.len() <= 1 {
        for &g in order.iter() {
            group_rank[g] = ranks.start as u32;
        }
        return;
    }
    let (mut lo, mut hi) = (
        Vec3::repeat(Real::INFINITY),
        Vec3::repeat(Real::NEG_INFINITY),
    );
    for &g in order.iter() {
        lo = lo.inf(&groups[g].2);
        hi = hi.sup(&groups[g].2);
    }
    let axis = (hi - lo).imax();
    order.sort_by(|&a, &b| {
        groups[a].2[axis]
            .total_cmp(&groups[b].2[axis])
            .then(a.cmp(&b))
    });
    let left_ranks = ranks.len() / 2;
    let total: u64 = order.iter().map(|&g| groups[g].1).sum();
    let target = total as f64 * left_ranks as f64 / ranks.len() as f64;
    // The cut i (groups 0..i to the left) whose weight before it is nearest the target,
    // with at least one group on each side (more where there are groups enough).
    let min_left = left_ranks.min(order.len() - 1).max(1);
    let min_right = (ranks.len() - left_ranks)
        .min(order.len() - min_left)
        .max(1);
    let (mut best, mut best_off) = (min_left, f64::INFINITY);
    let mut before = 0u64;
    for i in 1..order.len() {
        before += groups[order[i - 1]].1;
        if i < min_left || order.len() - i < min_right {
            continue;
        }
        let off = (before as f64 - target).abs();
        if off < best_off {
            (best, best_off) = (i, off);
        }
    }
    let (left, right) = order.split_at_mut(best);
    let mid = ranks.start + left_ranks;
    bisect(groups, left, ranks.start..mid, group_rank);
    bisect(groups, right, mid..ranks.end, group_rank);
}

/// What [`Parallel::split`] reads of a model.
pub struct ModelToSplit<'a> {
    /// The nodes' positions (where the model is when it is split).
    pub x: &'a [Vec3],
    pub tets: &'a Tets,
    pub bodies: &'a [Body],
    /// Stage 1's units (see `ElementsWorkspace::units`).
    pub element_units: &'a [Range<usize>],
    pub joints: &'a Joints,
    /// Nodes every rank reads while stepping: the nodal force sets' (stage 6), the rebars'
    /// and their host tets' (every rank computes every bar and bond point).
    pub loaded: &'a [u32],
    /// The model has contact: stages 4 and 5 read every node.
    pub contact: bool,
    /// Modelled work per node for the split (empty: tet corners alone; [`chunk_groups`]).
    pub work: &'a [u32],
}

/// Per work unit: computed by this rank, designated to it.
#[derive(Clone, Debug, Default)]
pub struct UnitFlags {
    pub compute: Vec<bool>,
    pub designated: Vec<bool>,
}

/// A rank's part of a decomposed model: its communicator, partition and work masks.
#[derive(Clone)]
pub struct Parallel {
    pub comm: Arc<dyn Comm>,
    pub partition: Partition,
    /// Stage 1's units (see `ElementsWorkspace::units`).
    pub elements: UnitFlags,
    /// Stage 2's blocks (see `Joints::blocks`).
    pub joint_blocks: UnitFlags,
    /// Stage 3's joints.
    pub joints: JointMask,
    /// Per chunk of [`crate::integration::CHUNK`] nodes: this rank owns it (advances its
    /// nodes in stage 7).
    pub owned_chunks: Vec<bool>,
    /// The nodes this rank sends after each step to each rank that reads them, and those it
    /// receives ([`Halo`]).
    pub halo: Halo,
    /// Who reads which node besides its owner whatever the contact surface (work units that
    /// span ranks, force sets, rebars); with contact, the readers of the nodes of the pairs
    /// two ranks compute are added ([`Parallel::follow_pairs`]).
    base_readers: Readers,
    /// The detections (full, incremental) the halo was last made for (None: every node is
    /// shared, until stage 4 first reports its pairs).
    pairs_exported: Option<(u64, u64)>,
    /// The readers with contact (base readers and those of pairs two ranks compute), kept
    /// to grow after incremental detections.
    contact_readers: Readers,
    /// After an incremental detection, until stage 5: the exchange of the nodes its added
    /// pairs read ([`Parallel::share_added_pairs_nodes`]).
    added_halo: Option<Halo>,
    /// Every node is shared after each step (a contact model until stage 4 first reports).
    share_every_node: bool,
    /// With `FDEM_CHECK_HALO=1`: the nodes current on this rank after each step besides the
    /// halo's (its own, and rigid bodies', which every rank advances). Every other node's
    /// x, v and reaction is set to NaN after each step, so that anything read outside the
    /// halo before the next synchronization shows (a check for tests, O(nodes) a step).
    check_halo: Option<Vec<bool>>,
    /// Exchange buffer (reused).
    buffer: Vec<f64>,
    /// Wall time spent in exchanges [s].
    pub seconds: f64,
    /// Bytes this rank received in exchanges (the whole array of each collective, less its
    /// own part).
    pub bytes: u64,
    /// Of [`Parallel::bytes`], those received in the halo after each step.
    pub halo_bytes: u64,
    /// Of [`Parallel::bytes`], those received before full contact detections: the nodes
    /// within reach of each rank's own ([`Parallel::share_nodes_near`]).
    pub near_bytes: u64,
    /// Of [`Parallel::bytes`], those received for output and whole-model reads: every node
    /// for a whole-model query, the end of a run or a new split; every joint's and pair's
    /// history and every node's position at the last detection for a new split; what rank 0
    /// gathers for a whole frame or a checkpoint; what a frame in pieces exchanges. Not
    /// every step.
    pub whole_bytes: u64,
    /// The steps at which all nodes, and all joint histories, were last shared.
    pub nodes_shared_at: Option<u64>,
    pub joints_shared_at: Option<u64>,
    pub contact_shared_at: Option<u64>,
    /// Every rank's seconds per stage and in exchanges, as of the last
    /// [`Parallel::gather_timings`] (empty before): the load balance the summary reports.
    pub rank_seconds: Vec<RankSeconds>,
    /// This rank's stage seconds when [`Parallel::imbalance_since_last_check`] last ran.
    stage_seconds_at_check: f64,
    /// This step's answer to stage 4's skin test (some rank's surface node moved more than
    /// skin/2), settled at the meeting after stage 3 ([`Parallel::close_joint_stages`]);
    /// None outside a step.
    skin_moved: Option<bool>,
    /// The most candidate pairs this rank held at once while stepping (its own: those it
    /// computes), for the summary.
    pub pairs_held: usize,
}

/// One rank's wall time: per stage (in [`crate::pipeline::Stage::ALL`] order) and in
/// exchanges [s]; and the most candidate contact pairs it held at once.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RankSeconds {
    pub stages: [f64; 7],
    pub exchange: f64,
    pub pairs_held: f64,
    /// The rank's peak resident memory so far [B] (0: not known on this system).
    pub peak_memory: f64,
}

impl std::fmt::Debug for Parallel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "Parallel {{ rank {} of {}, nodes per rank {:?} }}",
            self.comm.rank(),
            self.comm.size(),
            self.partition.nodes_per_rank
        )
    }
}

/// A rank's halo: per rank it exchanges with, the nodes it sends after each step (its own
/// nodes that rank reads) and those it receives (that rank's nodes it reads), each list in
/// node order, with their buffers (x and v, 6 numbers a node). Every rank derives its lists
/// from the same model and split, so the two sides of each message agree without asking.
#[derive(Clone, Debug, Default)]
pub struct Halo {
    pub send: Vec<(usize, Vec<u32>)>,
    pub recv: Vec<(usize, Vec<u32>)>,
    send_buf: Vec<Vec<f64>>,
    recv_buf: Vec<Vec<f64>>,
}

impl Halo {
    /// From the (reader, node) keys of [`Readers`] (sorted: by reader, then node).
    fn new(p: &Partition, me: usize, keys: &[u64]) -> Self {
        let mut send: Vec<Vec<u32>> = vec![Vec::new(); p.size()];
        let mut recv: Vec<Vec<u32>> = vec![Vec::new(); p.size()];
        for &k in keys {
            let (reader, n) = ((k >> 32) as usize, k as u32);
            let owner = p.owner(n as usize);
            if owner == me {
                send[reader].push(n);
            } else if reader == me {
                recv[owner].push(n);
            }
        }
        let listed = |lists: Vec<Vec<u32>>| -> Vec<(usize, Vec<u32>)> {
            (lists.into_iter().enumerate())
                .filter(|(_, l)| !l.is_empty())
                .collect()
        };
        let (send, recv) = (listed(send), listed(recv));
        let buffers = |lists: &[(usize, Vec<u32>)]| {
            lists.iter().map(|(_, l)| vec![0.0; 6 * l.len()]).collect()
        };
        Halo {
            send_buf: buffers(&send),
            recv_buf: buffers(&recv),
            send,
            recv,
        }
    }

    /// Nodes received after each step.
    pub fn received(&self) -> usize {
        self.recv.iter().map(|(_, l)| l.len()).sum()
    }

    /// Nodes sent after each step (a node read by two ranks counts twice).
    pub fn sent(&self) -> usize {
        self.send.iter().map(|(_, l)| l.len()).sum()
    }
}

/// Which rank reads which node it does not own, while stepping: the keys
/// `reader << 32 | node`, sorted, for the pairs where this rank is the reader or the
/// owner (what its halo needs), and every node some rank reads besides its owner.
#[derive(Clone, Debug, Default)]
struct Readers {
    keys: Vec<u64>,
    shared: Vec<bool>,
}

impl Readers {
    fn new(n_nodes: usize) -> Self {
        Readers {
            keys: Vec::new(),
            shared: vec![false; n_nodes],
        }
    }

    /// A piece of work that reads the nodes `read` and is computed by every rank owning one
    /// of the nodes `deciders` (a unit: a rank computes it when one of its items has a node
    /// of that rank): each of those ranks reads each node of `read` it does not own.
    fn add(&mut self, p: &Partition, me: usize, read: &[u32], deciders: &[u32]) {
        let first = deciders.first().map(|&n| p.owner(n as usize));
        if deciders.iter().all(|&n| Some(p.owner(n as usize)) == first) {
            return;
        }
        let mut ranks: Vec<usize> = deciders.iter().map(|&n| p.owner(n as usize)).collect();
        ranks.sort_unstable();
        ranks.dedup();
        for &n in read {
            self.read_by(p, me, n, ranks.iter().copied());
        }
    }

    /// Nodes every rank reads (force sets, rebars and their hosts).
    fn add_read_by_all(&mut self, p: &Partition, me: usize, nodes: &[u32]) {
        for &n in nodes {
            self.read_by(p, me, n, 0..p.size());
        }
    }

    /// Node `n` is read by the ranks `readers` (its owner among them or not).
    fn read_by(&mut self, p: &Partition, me: usize, n: u32, readers: impl Iterator<Item = usize>) {
        let owner = p.owner(n as usize);
        for r in readers.filter(|&r| r != owner) {
            self.shared[n as usize] = true;
            if r == me || owner == me {
                self.keys.push(((r as u64) << 32) | n as u64);
            }
        }
    }

    /// Sort and deduplicate the keys.
    fn finish(&mut self) {
        self.keys.sort_unstable();
        self.keys.dedup();
    }
}

impl Parallel {
    /// A rank not split yet ([`Parallel::split`] does it once the model is complete).
    pub fn pending(comm: Arc<dyn Comm>) -> Self {
        Parallel {
            comm,
            partition: Partition::default(),
            elements: UnitFlags::default(),
            joint_blocks: UnitFlags::default(),
            joints: JointMask::default(),
            owned_chunks: Vec::new(),
            halo: Halo::default(),
            base_readers: Readers::default(),
            pairs_exported: None,
            contact_readers: Readers::default(),
            added_halo: None,
            share_every_node: false,
            check_halo: None,
            buffer: Vec::new(),
            seconds: 0.0,
            bytes: 0,
            halo_bytes: 0,
            whole_bytes: 0,
            nodes_shared_at: None,
            joints_shared_at: None,
            contact_shared_at: None,
            rank_seconds: Vec::new(),
            stage_seconds_at_check: 0.0,
            skin_moved: None,
            pairs_held: 0,
            near_bytes: 0,
        }
    }

    /// Split the model for this rank: partition, the work masks of stages 1 to 3, and the
    /// halo.
    pub fn split(&mut self, model: ModelToSplit) {
        let ModelToSplit {
            x,
            tets,
            bodies,
            element_units,
            joints,
            loaded,
            contact,
            work,
        } = model;
        let comm = &self.comm;
        let n_nodes = x.len();
        // (A re-split keeps as many chunks with their owner as it can.)
        let previous = std::mem::take(&mut self.partition.chunk_owner);
        let previous = (!previous.is_empty()).then_some(previous.as_slice());
        let partition =
            Partition::keeping(comm.rank(), comm.size(), x, tets, bodies, work, previous);
        let p = &partition;
        let elements = p.unit_flags(
            element_units
                .iter()
                .map(|u| u.clone().map(|e| (p.tet_min_rank[e], p.tet_relevant[e]))),
        );
        let joint_mask = p.joint_mask(joints, contact);
        let joint_blocks = p.unit_flags(joints.units().map(|b| {
            b.map(|j| {
                let lowest = joints.faces[j]
                    .iter()
                    .flatten()
                    .map(|&n| p.owner(n as usize) as u32)
                    .min()
                    .expect("6 nodes");
                (lowest, joint_mask.relevant[j])
            })
        }));
        // A unit whose items have nodes of two ranks is computed by both, and each reads the
        // unit's nodes the other owns.
        let me = comm.rank();
        let mut readers = Readers::new(n_nodes);
        let (mut read, mut deciders) = (Vec::new(), Vec::new());
        for u in element_units {
            read.clear();
            read.extend(u.clone().flat_map(|e| tets.nodes[e]));
            readers.add(p, me, &read, &read);
        }
        for b in joints.units() {
            read.clear();
            deciders.clear();
            for j in b {
                read.extend(joints.faces[j].into_iter().flatten());
                if contact {
                    deciders.extend(joints.tets[j].iter().flat_map(|&e| tets.nodes[e as usize]));
                }
            }
            deciders.extend_from_slice(&read);
            readers.add(p, me, &read, &deciders);
        }
        readers.add_read_by_all(p, me, loaded);
        readers.finish();
        self.elements = elements;
        self.joint_blocks = joint_blocks;
        self.joints = joint_mask;
        self.owned_chunks = (0..partition.chunk_owner.len())
            .map(|c| partition.owns_chunk(c))
            .collect();
        self.partition = partition;
        self.pairs_exported = None;
        // Until stage 4 first reports its pairs, every node is shared
        // ([`Parallel::follow_pairs`]).
        self.share_every_node = contact;
        self.halo = Halo::new(&self.partition, me, &readers.keys);
        self.base_readers = readers;
        self.check_halo = halo_checked().then(|| {
            let mut current: Vec<bool> = (0..n_nodes).map(|n| self.partition.owns(n)).collect();
            for b in bodies.iter().filter(|b| b.layout == Layout::Rigid) {
                current[b.nodes.clone()].iter_mut().for_each(|c| *c = true);
            }
            current
        });
    }

    /// After stage 4: add to the halo the nodes of the tets of every candidate pair that two
    /// ranks compute. A pair is computed by every rank owning a node of one of its tets
    /// ([`Parallel::contact_mask`]), which reads all eight; a pair whose nodes one rank owns
    /// needs nothing from the others, and the skin test reads only a rank's own nodes
    /// ([`crate::contact_detection::must_detect`]). Called every step; recomputed when the
    /// list changes (`generation`: the full and incremental detections so far; after an
    /// incremental one only its added pairs, from `origins`, whose nodes are then exchanged
    /// at once: [`Parallel::share_added_pairs_nodes`]). A full detection makes the nodes
    /// within reach current first ([`Parallel::share_nodes_near`]).
    pub fn follow_pairs(
        &mut self,
        tets: &crate::state::Tets,
        surface: &[u32],
        pairs: &[[u32; 2]],
        origins: &[crate::contact_detection::PairOrigin],
        generation: (u64, u64),
    ) {
        if self.pairs_exported == Some(generation) || self.base_readers.shared.is_empty() {
            return;
        }
        use rayon::prelude::*;
        let (p, me) = (&self.partition, self.comm.rank());
        let spanning = |&[a, b]: &[u32; 2]| {
            let (ta, tb) = (
                tets.nodes[surface[a as usize] as usize],
                tets.nodes[surface[b as usize] as usize],
            );
            let all = [ta[0], ta[1], ta[2], ta[3], tb[0], tb[1], tb[2], tb[3]];
            let first = p.owner(all[0] as usize);
            all.iter()
                .any(|&n| p.owner(n as usize) != first)
                .then_some(all)
        };
        // After an incremental detection (the same full one) only the added pairs are new:
        // the readers only grow.
        let incremental = matches!(self.pairs_exported, Some((full, _)) if full == generation.0)
            && origins.len() == pairs.len();
        let added: Vec<[u32; 8]> = if incremental {
            (pairs.iter().zip(origins))
                .filter(|(_, o)| matches!(o, crate::contact_detection::PairOrigin::New { .. }))
                .filter_map(|(pair, _)| spanning(pair))
                .collect()
        } else {
            self.contact_readers = self.base_readers.clone();
            pairs.par_iter().filter_map(spanning).collect()
        };
        let before = self.contact_readers.keys.len();
        let mut new_readers = incremental.then(|| Readers::new(self.contact_readers.shared.len()));
        for nodes in &added {
            self.contact_readers.add(p, me, nodes, nodes);
            if let Some(r) = &mut new_readers {
                r.add(p, me, nodes, nodes);
            }
        }
        self.contact_readers.finish();
        // What the added pairs read, for the exchange before this step's stage 5
        // ([`Parallel::share_added_pairs_nodes`]).
        self.added_halo = new_readers.map(|mut r| {
            r.finish();
            Halo::new(p, me, &r.keys)
        });
        if !incremental || self.contact_readers.keys.len() != before || self.share_every_node {
            self.halo = Halo::new(p, me, &self.contact_readers.keys);
        }
        self.share_every_node = false;
        self.pairs_exported = Some(generation);
    }

    /// After stage 7: each rank's nodes that other ranks read, positions and velocities, to
    /// those ranks (a neighbour exchange: what the next step reads of nodes other ranks own).
    pub fn share_exports(&mut self, nodes: &mut crate::state::Nodes) {
        if self.share_every_node {
            return self.share_nodes(nodes);
        }
        self.exchange_halo(nodes, self.check_halo.is_some());
    }

    /// Within a step, after an incremental detection: the nodes of the pairs it added that
    /// two ranks compute, from their owners to the ranks that compute the pairs (a neighbour
    /// exchange of its own, [`Parallel::follow_pairs`] made it), so that stage 5 finds them
    /// current. Nothing when every node is shared (it is, then).
    pub fn share_added_pairs_nodes(&mut self, nodes: &mut crate::state::Nodes) {
        if let Some(mut added) = self.added_halo.take() {
            if !self.share_every_node {
                std::mem::swap(&mut self.halo, &mut added);
                self.exchange_halo(nodes, false);
                std::mem::swap(&mut self.halo, &mut added);
            }
        }
    }

    /// The halo's neighbour exchange; with `poison`, every node not kept current first set
    /// to NaN (`FDEM_CHECK_HALO`).
    fn exchange_halo(&mut self, nodes: &mut crate::state::Nodes, poison: bool) {
        let t = std::time::Instant::now();
        let halo = &mut self.halo;
        for ((_, which), buf) in halo.send.iter().zip(&mut halo.send_buf) {
            for (k, &n) in which.iter().enumerate() {
                buf[6 * k..6 * k + 3].copy_from_slice(nodes.x[n as usize].as_slice());
                buf[6 * k + 3..6 * k + 6].copy_from_slice(nodes.v[n as usize].as_slice());
            }
        }
        let sends: Vec<(usize, &[f64])> = (halo.send.iter().zip(&halo.send_buf))
            .map(|((r, _), b)| (*r, b.as_slice()))
            .collect();
        let mut recvs: Vec<(usize, &mut [f64])> = (halo.recv.iter().zip(&mut halo.recv_buf))
            .map(|((r, _), b)| (*r, b.as_mut_slice()))
            .collect();
        self.comm.exchange_f64(&sends, &mut recvs);
        if let Some(current) = self.check_halo.as_ref().filter(|_| poison) {
            // Every node not kept current poisoned; the halo's are written just below.
            let stale = Vec3::repeat(Real::NAN);
            for n in (0..current.len()).filter(|&n| !current[n]) {
                (nodes.x[n], nodes.v[n]) = (stale, stale);
            }
            let c = &mut nodes.constrained;
            for (&n, r) in c.node.iter().zip(&mut c.reaction) {
                if !current[n as usize] {
                    *r = stale;
                }
            }
        }
        for ((_, which), buf) in halo.recv.iter().zip(&halo.recv_buf) {
            for (k, &n) in which.iter().enumerate() {
                let v = &buf[6 * k..6 * k + 6];
                nodes.x[n as usize] = crate::math::Vec3::new(v[0], v[1], v[2]);
                nodes.v[n as usize] = crate::math::Vec3::new(v[3], v[4], v[5]);
            }
        }
        let received = 8 * halo.recv_buf.iter().map(|b| b.len() as u64).sum::<u64>();
        self.bytes += received;
        self.halo_bytes += received;
        self.seconds += t.elapsed().as_secs_f64();
    }

    /// The number of nodes some rank besides their owner reads while stepping (each shared
    /// after every step with the ranks that read it).
    pub fn shared_nodes(&self) -> usize {
        let readers = if self.pairs_exported.is_some() {
            &self.contact_readers
        } else {
            &self.base_readers
        };
        if self.share_every_node {
            self.partition.n_nodes
        } else {
            readers.shared.iter().filter(|&&s| s).count()
        }
    }

    pub fn rank(&self) -> usize {
        self.comm.rank()
    }

    /// The chunks' owners a split made now would give (the same on every rank: each group's
    /// centre comes from the rank owning it, whose nodes are current there; a small
    /// collective, without sharing any node). For [`crate::pipeline::Simulation::repartition`]
    /// to decide whether a split pays.
    pub fn owners_by_place_now(
        &mut self,
        x: &[Vec3],
        tets: &Tets,
        bodies: &[Body],
        work: &[u32],
    ) -> Vec<u32> {
        let mut groups = chunk_groups(x, tets, bodies, work);
        let p = &self.partition;
        let mine: Vec<(u32, [Real; 3])> = (groups.iter().enumerate())
            .filter(|(_, g)| p.owns_chunk(g.0.start))
            .map(|(i, g)| (i as u32, [g.2.x, g.2.y, g.2.z]))
            .collect();
        for (i, c) in self.gather_items(&mine, "chunk centres") {
            groups[i as usize].2 = Vec3::new(c[0], c[1], c[2]);
        }
        let n_chunks = x.len().div_ceil(crate::integration::CHUNK);
        owners_of_groups(
            &groups,
            self.comm.size(),
            n_chunks,
            Some(&self.partition.chunk_owner),
        )
    }

    /// Stage 7: each rigid body's resultant force and torque (from
    /// `integration::rigid::gather_loads`) from the rank owning its nodes, which alone has
    /// all their forces (a partition never splits a rigid body), to every rank; every rank
    /// then advances every rigid body alike.
    pub fn share_rigid_loads(&mut self, rigid: &mut crate::integration::rigid::RigidBodies) {
        if rigid.is_empty() {
            return;
        }
        let t = std::time::Instant::now();
        let p = &self.partition;
        let mine = |nodes: &Range<usize>| p.owner(nodes.start) == p.rank;
        self.buffer.clear();
        for rb in &rigid.bodies {
            if mine(&rb.nodes) {
                self.buffer.extend(rb.force.iter().chain(rb.torque.iter()));
            } else {
                self.buffer.extend([-0.0; 6]);
            }
        }
        self.comm.sum_f64(&mut self.buffer);
        for (rb, v) in rigid.bodies.iter_mut().zip(self.buffer.chunks_exact(6)) {
            rb.force = crate::math::Vec3::new(v[0], v[1], v[2]);
            rb.torque = crate::math::Vec3::new(v[3], v[4], v[5]);
        }
        self.bytes += (self.buffer.len() * 8 * (self.comm.size() - 1)) as u64;
        self.seconds += t.elapsed().as_secs_f64();
    }

    /// The step's first meeting, after stage 3 (stage 4 needs every rank's break events):
    /// one sum over the ranks of the exact sums of stages 1 and 2 (their designated units'
    /// partials, `elements` and the joints'), of the energy a fracture criterion released (`released`, the designated
    /// joints'), of the ranks' break-event counts and of their skin tests
    /// (`surface_moved_here`: a surface node of this rank moved beyond skin/2); then, only in
    /// a step where some joint broke, the events to all, merged in joint order (every rank
    /// marks the joints broken). Stage 1's totals wait for this meeting instead of having
    /// their own, so a rank slower in stage 1 and another slower in stage 2 wait once for
    /// the difference of their sums, not twice. Returns the totals and the released energy
    /// [J] as one process gets them.
    #[allow(clippy::too_many_arguments)]
    pub fn close_joint_stages(
        &mut self,
        elements: &[crate::elements::ElementSums],
        released: &crate::math::ExactSum,
        events: &mut Vec<BreakEvent>,
        first: usize,
        joints: &mut Joints,
        surface_moved_here: bool,
    ) -> (crate::elements::ElementSums, JointSums, Real) {
        use crate::math::ExactSum;
        type El = crate::elements::ElementSums;
        let t = std::time::Instant::now();
        let mine: Vec<BreakEvent> = events[first..]
            .iter()
            .filter(|e| self.joints.designated[e.joint])
            .cloned()
            .collect();
        let (ne, nj) = (El::LEN * ExactSum::LEN, JointSums::LEN * ExactSum::LEN);
        let counts = ne + nj + ExactSum::LEN;
        self.buffer.clear();
        self.buffer.resize(counts + 2, 0.0);
        {
            let (e_part, rest) = self.buffer.split_at_mut(ne);
            let (j_part, rest) = rest.split_at_mut(nj);
            let (el_designated, jb_designated) =
                (&self.elements.designated, &self.joint_blocks.designated);
            write_exact(elements, |i| el_designated[i], e_part);
            write_exact(&joints.unit_partials, |i| jb_designated[i], j_part);
            released.digits(&mut rest[..ExactSum::LEN]);
            rest[ExactSum::LEN] = mine.len() as f64;
            rest[ExactSum::LEN + 1] = f64::from(u8::from(surface_moved_here));
        }
        self.comm.sum_f64(&mut self.buffer);
        self.bytes += (self.buffer.len() * 8 * (self.comm.size() - 1)) as u64;
        let el: El = read_exact(&self.buffer[..ne]);
        let js: JointSums = read_exact(&self.buffer[ne..ne + nj]);
        let released = ExactSum::from_digits(&self.buffer[ne + nj..counts]).value();
        let n_events = self.buffer[counts];
        self.skin_moved = Some(self.buffer[counts + 1] > 0.0);
        events.truncate(first);
        if n_events > 0.0 {
            let mut all = self.gather_items(&mine, "break events");
            all.sort_by_key(|e| e.joint);
            for e in &all {
                joints.broken[e.joint] = true;
            }
            events.extend(all);
        }
        self.seconds += t.elapsed().as_secs_f64();
        (el, js, released)
    }

    /// Every rank's `mine` to every rank, in rank order (a collective; `what` names the
    /// items in a failure). Counts the bytes received; the caller times the exchange.
    pub fn gather_items<T>(&mut self, mine: &[T], what: &str) -> Vec<T>
    where
        T: serde::Serialize + serde::de::DeserializeOwned,
    {
        let bytes = postcard::to_allocvec(mine).unwrap_or_else(|e| panic!("{what} serialize: {e}"));
        let mut all = Vec::new();
        self.gather_bytes_each(bytes, what, false, |items: Vec<T>| all.extend(items));
        all
    }

    /// [`Parallel::gather_items`] handing each rank's items to `take` in rank order, one
    /// rank's at a time, instead of putting every rank's together: what a rank holds at once
    /// is the received bytes and one rank's items (the whole model's joint histories are a
    /// few hundred bytes a joint). `mine` goes once serialized.
    pub fn gather_each<T>(&mut self, mine: Vec<T>, what: &str, take: impl FnMut(Vec<T>))
    where
        T: serde::Serialize + serde::de::DeserializeOwned,
    {
        self.gather_vec_each(mine, what, false, take);
    }

    /// [`Parallel::gather_each`] to rank 0 only: `take` sees every rank's items there and is
    /// not called on the other ranks (for what only rank 0 reads: whole frames).
    pub fn gather_each_to_root<T>(&mut self, mine: Vec<T>, what: &str, take: impl FnMut(Vec<T>))
    where
        T: serde::Serialize + serde::de::DeserializeOwned,
    {
        self.gather_vec_each(mine, what, true, take);
    }

    /// `mine` serialized once and dropped, then [`Parallel::gather_bytes_each`].
    fn gather_vec_each<T>(
        &mut self,
        mine: Vec<T>,
        what: &str,
        to_root: bool,
        take: impl FnMut(Vec<T>),
    ) where
        T: serde::Serialize + serde::de::DeserializeOwned,
    {
        let bytes =
            postcard::to_allocvec(&mine).unwrap_or_else(|e| panic!("{what} serialize: {e}"));
        drop(mine);
        self.gather_bytes_each(bytes, what, to_root, take);
    }

    fn gather_bytes_each<T>(
        &mut self,
        bytes: Vec<u8>,
        what: &str,
        to_root: bool,
        mut take: impl FnMut(Vec<T>),
    ) where
        T: serde::de::DeserializeOwned,
    {
        let received = if to_root {
            self.comm.gather_bytes_to_root(&bytes)
        } else {
            self.comm.allgather_bytes(&bytes)
        };
        let total: u64 = received.iter().map(|b| b.len() as u64).sum();
        self.bytes += total.saturating_sub(bytes.len() as u64);
        drop(bytes);
        for b in &received {
            take(
                postcard::from_bytes::<Vec<T>>(b)
                    .unwrap_or_else(|e| panic!("{what} deserialize: {e}")),
            );
        }
    }

    /// The ranks' load imbalance since the last call (or the start): the slowest rank's
    /// stage seconds over the mean, from this rank's total `stage_seconds` (exchange and
    /// waiting excluded). The same on every rank: a collective of one number per rank.
    pub fn imbalance_since_last_check(&mut self, stage_seconds: f64) -> Real {
        let since = stage_seconds - self.stage_seconds_at_check;
        self.stage_seconds_at_check = stage_seconds;
        let ranks = self.values_of_ranks(since);
        let mean = ranks.iter().sum::<Real>() / ranks.len() as Real;
        let slowest = ranks.iter().fold(0.0, |a: Real, &b| a.max(b));
        if mean > 0.0 {
            slowest / mean
        } else {
            1.0
        }
    }

    /// A sum over ranks of one value per rank, added in rank order (the same on every rank;
    /// for a quantity that is not a unit partial).
    pub fn sum_in_rank_order(&mut self, value: Real) -> Real {
        self.values_of_ranks(value).iter().sum()
    }

    /// Sum [`crate::math::ExactSum::digits`] arrays over the ranks, in place (a collective;
    /// exact in any order).
    pub fn sum_exact_digits(&mut self, digits: &mut [f64]) {
        self.comm.sum_f64(digits);
        self.bytes += (digits.len() * 8 * (self.comm.size() - 1)) as u64;
    }

    /// The largest of one value per rank (the same on every rank): one max-reduction of a
    /// single number (until 2026-12-07 every rank's value to every rank; it runs every
    /// step, for the stop signal).
    pub fn largest_over_ranks(&mut self, value: Real) -> Real {
        let t = std::time::Instant::now();
        let mut v = [value];
        self.comm.max_f64(&mut v);
        self.bytes += (8 * (self.comm.size() - 1)) as u64;
        self.seconds += t.elapsed().as_secs_f64();
        v[0]
    }

    /// Every rank's stage times, exchange time, most pairs held and peak resident memory
    /// (`peak_memory` [B], 0 if not known) into [`Parallel::rank_seconds`] (a collective:
    /// one sum of 10 numbers per rank). The exchange time is this rank's up to the call; the
    /// gather itself is not counted.
    pub fn gather_timings(&mut self, stages: &[f64; 7], peak_memory: f64) {
        const PER_RANK: usize = 10;
        let (n, rank) = (self.comm.size(), self.comm.rank());
        let mut buf = vec![0.0; n * PER_RANK];
        buf[rank * PER_RANK..rank * PER_RANK + 7].copy_from_slice(stages);
        buf[rank * PER_RANK + 7] = self.seconds;
        buf[rank * PER_RANK + 8] = self.pairs_held as f64;
        buf[rank * PER_RANK + 9] = peak_memory;
        self.comm.sum_f64(&mut buf);
        self.rank_seconds = buf
            .chunks_exact(PER_RANK)
            .map(|c| RankSeconds {
                stages: c[..7].try_into().expect("7 stages"),
                exchange: c[7],
                pairs_held: c[8],
                peak_memory: c[9],
            })
            .collect();
    }

    /// Every rank's `value`, indexed by rank (a collective).
    fn values_of_ranks(&mut self, value: Real) -> &[Real] {
        let t = std::time::Instant::now();
        let n = self.comm.size();
        let buf = &mut self.buffer;
        buf.clear();
        buf.resize(n, 0.0);
        buf[self.comm.rank()] = value;
        self.comm.sum_f64(buf);
        self.seconds += t.elapsed().as_secs_f64();
        &self.buffer
    }

    /// The positions and velocities of the nodes `which` (the same list on every rank) from
    /// their owners to every rank, each rank sending those it owns in list order, with the
    /// reactions when `reactions` (for the script's queries of node sets).
    pub fn share_listed_nodes(
        &mut self,
        nodes: &mut crate::state::Nodes,
        which: &[u32],
        reactions: bool,
    ) {
        const PER_NODE: usize = 6;
        let t = std::time::Instant::now();
        let (p, me) = (&self.partition, self.comm.rank());
        let mut at = vec![0usize; self.comm.size() + 1];
        for &n in which {
            at[p.owner(n as usize) + 1] += PER_NODE;
        }
        for r in 0..self.comm.size() {
            at[r + 1] += at[r];
        }
        let segments: Vec<Range<usize>> = at.windows(2).map(|w| w[0]..w[1]).collect();
        let buf = &mut self.buffer;
        buf.clear();
        buf.resize(at[self.comm.size()], 0.0);
        let mut next = at.clone();
        for &n in which.iter().filter(|&&n| p.owner(n as usize) == me) {
            let k = &mut next[me];
            buf[*k..*k + 3].copy_from_slice(nodes.x[n as usize].as_slice());
            buf[*k + 3..*k + 6].copy_from_slice(nodes.v[n as usize].as_slice());
            *k += PER_NODE;
        }
        self.comm.allgather_ranges_f64(buf, &segments);
        for &n in which {
            let r = p.owner(n as usize);
            if r != me {
                let k = &mut next[r];
                let v = &buf[*k..*k + PER_NODE];
                nodes.x[n as usize] = Vec3::new(v[0], v[1], v[2]);
                nodes.v[n as usize] = Vec3::new(v[3], v[4], v[5]);
                *k += PER_NODE;
            }
        }
        self.bytes += (8 * (at[self.comm.size()] - segments[me].len())) as u64;
        if reactions {
            let c = &nodes.constrained;
            let mut slots: Vec<usize> = which.iter().filter_map(|&n| c.slot(n)).collect();
            slots.sort_unstable();
            slots.dedup();
            self.bytes += self.share_reactions(&mut nodes.constrained, &slots, false);
        }
        self.seconds += t.elapsed().as_secs_f64();
    }

    /// Every rank's nodes' positions and velocities (and reactions, with `reactions`) to rank
    /// 0 only (a collective): what a whole frame (a checkpoint) reads of the nodes. The other ranks' copies are left as they are, and
    /// no rank counts its nodes as shared (`nodes_shared_at`), so a later read of the whole
    /// model by every rank shares them again.
    pub fn gather_nodes_to_root(&mut self, nodes: &mut crate::state::Nodes, reactions: bool) {
        let t = std::time::Instant::now();
        let me = self.comm.rank();
        let per_node = 6;
        let mut own: Vec<f64> = Vec::new();
        for n in self.partition.nodes_of(me).flatten() {
            own.extend_from_slice(nodes.x[n].as_slice());
            own.extend_from_slice(nodes.v[n].as_slice());
        }
        let before = self.bytes;
        let mut received: Vec<Vec<f64>> = Vec::new();
        self.gather_each_to_root(own, "node states", |of_rank| received.push(of_rank));
        for (r, values) in received.iter().enumerate().filter(|(r, _)| *r != me) {
            let nodes_of_r = self.partition.nodes_of(r).flatten();
            for (n, s) in nodes_of_r.zip(values.chunks_exact(per_node)) {
                nodes.x[n] = Vec3::new(s[0], s[1], s[2]);
                nodes.v[n] = Vec3::new(s[3], s[4], s[5]);
            }
        }
        if reactions {
            let all: Vec<usize> = (0..nodes.constrained.len()).collect();
            self.bytes += self.share_reactions(&mut nodes.constrained, &all, true);
        }
        self.whole_bytes += self.bytes - before;
        self.seconds += t.elapsed().as_secs_f64();
    }

    /// The positions of the nodes `which` (the same list on every rank) from their owners to
    /// rank 0 only (a collective): what a crack frame reads when the model's frames are
    /// written in pieces. Nothing counts as shared.
    pub fn gather_listed_nodes_to_root(&mut self, nodes: &mut crate::state::Nodes, which: &[u32]) {
        let t = std::time::Instant::now();
        let me = self.comm.rank();
        let p = &self.partition;
        let mine: Vec<(u32, [f64; 3])> = (which.iter())
            .filter(|&&n| p.owner(n as usize) == me)
            .map(|&n| (n, nodes.x[n as usize].into()))
            .collect();
        let before = self.bytes;
        self.gather_each_to_root(mine, "listed nodes", |of_rank: Vec<(u32, [f64; 3])>| {
            for (n, x) in of_rank {
                nodes.x[n as usize] = x.into();
            }
        });
        self.whole_bytes += self.bytes - before;
        self.seconds += t.elapsed().as_secs_f64();
    }

    /// Every rank's nodes' positions, velocities and reactions to every rank: the whole
    /// model current on every rank (before the script reads it, at the end of a run, before
    /// a new split).
    pub fn share_nodes(&mut self, nodes: &mut crate::state::Nodes) {
        let t = std::time::Instant::now();
        let mut received = self.gather_owned(&mut [&mut nodes.x, &mut nodes.v]);
        let all: Vec<usize> = (0..nodes.constrained.len()).collect();
        received += self.share_reactions(&mut nodes.constrained, &all, false);
        self.bytes += received;
        self.whole_bytes += received;
        self.seconds += t.elapsed().as_secs_f64();
    }

    /// The reactions of the constrained nodes at `slots` of [`crate::state::Constrained`]
    /// (ascending, the same on every rank, as the list is) from the ranks owning their nodes,
    /// to every rank, or to rank 0 alone with `to_root` (a collective: each rank sends its
    /// own in slot order). Returns the bytes received.
    fn share_reactions(
        &mut self,
        c: &mut crate::state::Constrained,
        slots: &[usize],
        to_root: bool,
    ) -> u64 {
        let (me, size) = (self.comm.rank(), self.comm.size());
        let p = &self.partition;
        let owners: Vec<usize> = (slots.iter())
            .map(|&s| p.owner(c.node[s] as usize))
            .collect();
        let mut at = vec![0usize; size + 1];
        for &r in &owners {
            at[r + 1] += 3;
        }
        for r in 0..size {
            at[r + 1] += at[r];
        }
        let segments: Vec<Range<usize>> = at.windows(2).map(|w| w[0]..w[1]).collect();
        let buf = &mut self.buffer;
        buf.clear();
        buf.resize(at[size], 0.0);
        let mut k = segments[me].start;
        for (&s, _) in slots.iter().zip(&owners).filter(|(_, &r)| r == me) {
            buf[k..k + 3].copy_from_slice(c.reaction[s].as_slice());
            k += 3;
        }
        if to_root {
            let mine = buf[segments[me].clone()].to_vec();
            let mut received: Vec<Vec<f64>> = Vec::new();
            let before = self.bytes;
            self.gather_each_to_root(mine, "reactions", |of_rank| received.push(of_rank));
            let bytes = self.bytes - before;
            self.bytes = before;
            for (r, values) in received.iter().enumerate().filter(|(r, _)| *r != me) {
                let of_r = slots.iter().zip(&owners).filter(|(_, &o)| o == r);
                for ((&s, _), v) in of_r.zip(values.chunks_exact(3)) {
                    c.reaction[s] = Vec3::new(v[0], v[1], v[2]);
                }
            }
            return bytes;
        }
        self.comm.allgather_ranges_f64(buf, &segments);
        let mut next: Vec<usize> = segments.iter().map(|r| r.start).collect();
        for (&s, &r) in slots.iter().zip(&owners) {
            if r != me {
                let k = &mut next[r];
                c.reaction[s] = Vec3::new(buf[*k], buf[*k + 1], buf[*k + 2]);
                *k += 3;
            }
        }
        (8 * (at[size] - segments[me].len())) as u64
    }

    /// Every node's value of each of `fields` from the rank that owns it, on every rank (one
    /// all-gather: each rank's nodes chunk by chunk, 3 numbers a field and node, one segment
    /// per rank in rank order). Returns the bytes received.
    fn gather_owned(&mut self, fields: &mut [&mut Vec<Vec3>]) -> u64 {
        let per_node = 3 * fields.len();
        let p = &self.partition;
        let mut at = 0;
        let segments: Vec<Range<usize>> = (p.nodes_per_rank.iter())
            .map(|&n| {
                at += per_node * n;
                at - per_node * n..at
            })
            .collect();
        let buf = &mut self.buffer;
        buf.clear();
        buf.resize(at, 0.0);
        let mut k = segments[self.comm.rank()].start;
        for n in p.nodes_of(self.comm.rank()).flatten() {
            for field in fields.iter() {
                buf[k..k + 3].copy_from_slice(field[n].as_slice());
                k += 3;
            }
        }
        self.comm.allgather_ranges_f64(buf, &segments);
        for (r, seg) in segments.iter().enumerate() {
            if r == self.comm.rank() {
                continue;
            }
            let mut k = seg.start;
            for n in p.nodes_of(r).flatten() {
                for field in fields.iter_mut() {
                    field[n] = Vec3::new(buf[k], buf[k + 1], buf[k + 2]);
                    k += 3;
                }
            }
        }
        (8 * (at - segments[self.comm.rank()].len())) as u64
    }
}

impl Parallel {
    /// Before a full contact detection: the x and v of every node within `reach` of the
    /// bounding box of this rank's own nodes, from their owners (a collective). Each rank
    /// learns every rank's box so inflated (6 numbers a rank), sends each rank the nodes of
    /// its own inside that rank's box (the counts first, one number per pair of ranks, then a
    /// neighbour exchange of id, x and v) and receives alike. Returns, per node, whether it
    /// is current on this rank now: its own and those received. (Until 2026-12-07 every
    /// node went to every rank.)
    pub fn share_nodes_near(&mut self, nodes: &mut crate::state::Nodes, reach: Real) -> Vec<bool> {
        use rayon::prelude::*;
        let t = std::time::Instant::now();
        let (me, size) = (self.comm.rank(), self.comm.size());
        let p = &self.partition;
        let own: Vec<usize> = p.nodes_of(me).flatten().collect();
        let x = &nodes.x;
        let (lo, hi) = own.par_iter().map(|&n| (x[n], x[n])).reduce(
            || {
                (
                    Vec3::repeat(Real::INFINITY),
                    Vec3::repeat(Real::NEG_INFINITY),
                )
            },
            |a, b| (a.0.inf(&b.0), a.1.sup(&b.1)),
        );
        let mut boxes = vec![0.0; 6 * size];
        boxes[6 * me..6 * me + 3].copy_from_slice((lo - Vec3::repeat(reach)).as_slice());
        boxes[6 * me + 3..6 * me + 6].copy_from_slice((hi + Vec3::repeat(reach)).as_slice());
        let ranges: Vec<Range<usize>> = (0..size).map(|r| 6 * r..6 * r + 6).collect();
        self.comm.allgather_ranges_f64(&mut boxes, &ranges);
        let inside = |q: usize, v: &Vec3| {
            let b = &boxes[6 * q..6 * q + 6];
            (0..3).all(|k| b[k] <= v[k] && v[k] <= b[k + 3])
        };
        // Only the ranks whose box meets this rank's nodes' box can hold any of them.
        let near: Vec<usize> = (0..size)
            .filter(|&q| {
                q != me
                    && (0..3).all(|k| boxes[6 * q + k] <= hi[k] && lo[k] <= boxes[6 * q + k + 3])
            })
            .collect();
        let mut sends: Vec<Vec<f64>> = vec![Vec::new(); size];
        for &q in &near {
            let list: Vec<usize> = own
                .par_iter()
                .copied()
                .filter(|&n| inside(q, &x[n]))
                .collect();
            let buf = &mut sends[q];
            buf.reserve(7 * list.len());
            for n in list {
                buf.push(n as f64);
                buf.extend_from_slice(x[n].as_slice());
                buf.extend_from_slice(nodes.v[n].as_slice());
            }
        }
        let recv_bufs = self.send_counted(&sends);
        let mut current = vec![false; nodes.len()];
        for &n in &own {
            current[n] = true;
        }
        let mut received = 0u64;
        for buf in &recv_bufs {
            for v in buf.chunks_exact(7) {
                let n = v[0] as usize;
                nodes.x[n] = Vec3::new(v[1], v[2], v[3]);
                nodes.v[n] = Vec3::new(v[4], v[5], v[6]);
                current[n] = true;
            }
            received += 8 * buf.len() as u64;
        }
        let overhead = 8 * (6 * (size - 1) + size) as u64;
        self.bytes += received + overhead;
        self.near_bytes += received + overhead;
        self.seconds += t.elapsed().as_secs_f64();
        current
    }

    /// Send `sends[q]` to each rank q (nothing to this rank or where empty) and receive what
    /// each rank sends this one, indexed by rank: the counts first (one number per pair of
    /// ranks, since only the sender knows them), then a neighbour exchange. A collective;
    /// the caller counts the bytes.
    fn send_counted(&mut self, sends: &[Vec<f64>]) -> Vec<Vec<f64>> {
        let me = self.comm.rank();
        let counts: Vec<u64> = sends.iter().map(|b| b.len() as u64).collect();
        let incoming = self.comm.alltoall_counts(&counts);
        let mut recv_bufs: Vec<Vec<f64>> = (incoming.iter().enumerate())
            .map(|(r, &c)| vec![0.0; if r == me { 0 } else { c as usize }])
            .collect();
        let send_list: Vec<(usize, &[f64])> = (sends.iter().enumerate())
            .filter(|(q, b)| *q != me && !b.is_empty())
            .map(|(q, b)| (q, b.as_slice()))
            .collect();
        let mut recv_list: Vec<(usize, &mut [f64])> = (recv_bufs.iter_mut().enumerate())
            .filter(|(r, b)| *r != me && !b.is_empty())
            .map(|(r, b)| (r, b.as_mut_slice()))
            .collect();
        self.comm.exchange_f64(&send_list, &mut recv_list);
        recv_bufs
    }

    /// [`Parallel::share_positions_at_detection`] to rank 0 alone (a checkpoint).
    pub fn gather_positions_at_detection_to_root(&mut self, x_at: &mut [Vec3]) {
        let t = std::time::Instant::now();
        let me = self.comm.rank();
        let own: Vec<Vec3> = (self.partition.nodes_of(me).flatten())
            .map(|n| x_at[n])
            .collect();
        let before = self.bytes;
        let mut received: Vec<Vec<Vec3>> = Vec::new();
        self.gather_each_to_root(own, "positions at detection", |of_rank| {
            received.push(of_rank)
        });
        for (r, values) in received.iter().enumerate().filter(|(r, _)| *r != me) {
            for (n, &x) in self.partition.nodes_of(r).flatten().zip(values) {
                x_at[n] = x;
            }
        }
        self.whole_bytes += self.bytes - before;
        self.seconds += t.elapsed().as_secs_f64();
    }

    /// Every node's position at the last full contact detection (`x_at`) from its owner, on
    /// every rank (a collective): a rank records only the positions it had current then
    /// ([`Parallel::share_nodes_near`]), and a new split needs them all.
    pub fn share_positions_at_detection(&mut self, x_at: &mut Vec<Vec3>) {
        let t = std::time::Instant::now();
        let received = self.gather_owned(&mut [x_at]);
        self.bytes += received;
        self.whole_bytes += received;
        self.seconds += t.elapsed().as_secs_f64();
    }
}

impl crate::contact_detection::PairExchange for Parallel {
    fn computes(&self) -> &[bool] {
        &self.partition.tet_relevant
    }

    fn make_every_node_current(&mut self, nodes: &mut crate::state::Nodes) {
        self.share_nodes(nodes);
    }

    fn make_near_current(&mut self, nodes: &mut crate::state::Nodes, reach: Real) -> Vec<bool> {
        self.share_nodes_near(nodes, reach)
    }

    fn largest(&mut self, value: Real) -> Real {
        self.largest_over_ranks(value)
    }

    fn designates(&self, tet: usize) -> bool {
        self.partition.tet_min_rank[tet] as usize == self.comm.rank()
    }

    fn sum_over_ranks(&mut self, sum: &mut crate::math::ExactSum) {
        use crate::math::ExactSum;
        let t = std::time::Instant::now();
        let mut digits = vec![0.0; ExactSum::LEN];
        sum.digits(&mut digits);
        self.sum_exact_digits(&mut digits);
        *sum = ExactSum::from_digits(&digits);
        self.seconds += t.elapsed().as_secs_f64();
    }

    fn any_rank(&mut self, mine: bool) -> bool {
        // Settled at the step's first meeting when the skin test is asked within a step.
        match self.skin_moved {
            Some(any) => any,
            None => self.largest_over_ranks(if mine { 1.0 } else { 0.0 }) > 0.0,
        }
    }

    fn skin_test_answered(&self) -> Option<bool> {
        self.skin_moved
    }

    fn owned_chunks(&self) -> (&[bool], usize) {
        (&self.owned_chunks, crate::integration::CHUNK)
    }
}

impl Parallel {
    /// Stage 5's work for this rank over stage 4's candidate `pairs` (indices into the
    /// `surface` tets), which are its own: each has a tet with a node of this rank, so the
    /// rank computes them all, every step each exists (its history is current there). A pair
    /// is designated to the lowest rank owning a node of one of its tets.
    pub fn contact_mask(
        &self,
        surface: &[u32],
        pairs: &[[u32; 2]],
    ) -> crate::contact_interaction::PairMask {
        let p = &self.partition;
        let rank = self.rank() as u32;
        let designated: Vec<bool> = pairs
            .iter()
            .map(|&[a, b]| {
                let (ea, eb) = (surface[a as usize] as usize, surface[b as usize] as usize);
                debug_assert!(
                    p.tet_relevant[ea] || p.tet_relevant[eb],
                    "a rank's own pair"
                );
                p.tet_min_rank[ea].min(p.tet_min_rank[eb]) == rank
            })
            .collect();
        // The surface tets of the pairs, ascending: one bit per surface tet, so that the
        // walk over the whole surface reads S/64 words (its part of the pairs, O(pairs),
        // is the work).
        let mut needed = vec![0u64; surface.len().div_ceil(64)];
        for &i in pairs.iter().flatten() {
            needed[i as usize / 64] |= 1 << (i % 64);
        }
        let listed = (needed.iter().enumerate()).flat_map(|(w, &bits)| {
            let mut rest = bits;
            std::iter::from_fn(move || {
                (rest != 0).then(|| {
                    let b = rest.trailing_zeros();
                    rest &= rest - 1;
                    (w * 64) as u32 + b
                })
            })
        });
        crate::contact_interaction::PairMask {
            decomposed: true,
            designated,
            surface: listed.collect(),
        }
    }

    /// The step's second meeting, after stage 7's nodes (the halo follows): one sum over the
    /// ranks of the exact sums of stage 7's chunks (each one rank's) and of stage 5's tally
    /// of the pairs designated to each rank ([`crate::contact_interaction::ContactTally`],
    /// when `contact`), with the count of their records; the largest of stage 5's maxima;
    /// then, only in a step where some pair handed a joint over, started touching or saw its
    /// friction law fail, those records to all, merged in pair order. Stage 5's totals wait
    /// for this meeting instead of having their own. Every rank gets what one rank gets.
    pub fn close_contact_and_integration(
        &mut self,
        chunks: &[IntegrationSums],
        ci: &mut crate::contact_interaction::ContactInteraction,
        contact: bool,
        time: Real,
    ) -> (IntegrationSums, crate::contact_interaction::ContactSums) {
        use crate::contact_interaction::{ContactSums, ContactTally, PairRecord};
        use crate::math::ExactSum;
        let t = std::time::Instant::now();
        let ni = IntegrationSums::LEN * ExactSum::LEN;
        let nc = if contact {
            ContactTally::SUM_LEN + 1
        } else {
            0
        };
        self.buffer.clear();
        self.buffer.resize(ni + nc, 0.0);
        let p = &self.partition;
        write_exact(chunks, |c| p.owns_chunk(c), &mut self.buffer[..ni]);
        let mine: Vec<PairRecord> = if contact {
            ci.records_to_send()
        } else {
            Vec::new()
        };
        if contact {
            ci.rank_tally()
                .write_sums(&mut self.buffer[ni..ni + ContactTally::SUM_LEN]);
            self.buffer[ni + ContactTally::SUM_LEN] = mine.len() as f64;
        }
        self.comm.sum_f64(&mut self.buffer);
        self.bytes += (self.buffer.len() * 8 * (self.comm.size() - 1)) as u64;
        let is: IntegrationSums = read_exact(&self.buffer[..ni]);
        let mut cs = ContactSums::default();
        if contact {
            let mut maxima = ci.rank_tally().maxima();
            self.comm.max_f64(&mut maxima);
            self.bytes += (maxima.len() * 8 * (self.comm.size() - 1)) as u64;
            let all = if self.buffer[ni + ContactTally::SUM_LEN] > 0.0 {
                let mut all = self.gather_items(&mine, "contact records");
                all.sort_by_key(|r| r.pair);
                all
            } else {
                Vec::new()
            };
            let law_failure = all.iter().find_map(|r| r.law_failure.map(|f| (r.pair, f)));
            let tally = ContactTally::read_sums(
                &self.buffer[ni..ni + ContactTally::SUM_LEN],
                maxima,
                law_failure,
            );
            cs = ci.apply_records(&tally, &all, time);
        }
        self.seconds += t.elapsed().as_secs_f64();
        (is, cs)
    }

    /// The skin test's answer settled at this step's first meeting (consumed).
    pub fn take_skin_moved(&mut self) -> Option<bool> {
        self.skin_moved.take()
    }

    /// Give every rank the whole candidate list, with every pair's history from its
    /// designated rank (a rank holds and keeps current only the pairs it computes). Before a
    /// new split; a collective. The next step's
    /// stage 4 keeps this rank's pairs again
    /// ([`crate::contact_detection::keep_this_ranks_pairs`]).
    pub fn share_contact_histories(
        &mut self,
        cd: &mut crate::contact_detection::ContactDetection,
        ci: &mut crate::contact_interaction::ContactInteraction,
    ) {
        self.contact_histories_to(cd, ci, false);
    }

    /// [`Parallel::share_contact_histories`] to rank 0 alone (a checkpoint; the other ranks'
    /// lists stay as they are); a collective.
    pub fn gather_contact_histories_to_root(
        &mut self,
        cd: &mut crate::contact_detection::ContactDetection,
        ci: &mut crate::contact_interaction::ContactInteraction,
    ) {
        self.contact_histories_to(cd, ci, true);
    }

    fn contact_histories_to(
        &mut self,
        cd: &mut crate::contact_detection::ContactDetection,
        ci: &mut crate::contact_interaction::ContactInteraction,
        root: bool,
    ) {
        use crate::contact_interaction::DesignatedStates;
        use rayon::prelude::*;
        let t = std::time::Instant::now();
        let mine = vec![ci.designated_states(&cd.pairs)];
        let before = self.bytes;
        let mut ranks: Vec<DesignatedStates> = Vec::new();
        if root {
            self.gather_each_to_root(mine, "pair histories", |of_rank| ranks.extend(of_rank));
        } else {
            self.gather_each(mine, "pair histories", |of_rank| ranks.extend(of_rank));
        }
        self.whole_bytes += self.bytes - before;
        if root && self.comm.rank() != 0 {
            self.seconds += t.elapsed().as_secs_f64();
            return;
        }
        // Every rank's keys ascend and no pair is designated to two ranks: the whole list is
        // their merge by key, each pair's history found by its rank's cursor.
        let mut order: Vec<(u64, u32, u32)> = (ranks.iter().enumerate())
            .flat_map(|(r, d)| {
                (d.keys.iter().enumerate()).map(move |(i, k)| (k.0, r as u32, i as u32))
            })
            .collect();
        order.par_sort_unstable_by_key(|o| o.0);
        cd.pairs = order
            .iter()
            .map(|o| [(o.0 >> 32) as u32, o.0 as u32])
            .collect();
        cd.local = false;
        let mut cursor = vec![0usize; ranks.len()];
        let states = order.iter().map(|&(_, r, i)| {
            let d = &ranks[r as usize];
            let c = &mut cursor[r as usize];
            let history = d.histories.get(*c).filter(|h| h.0 == i).map(|h| h.1);
            *c += history.is_some() as usize;
            (d.keys[i as usize].1, history)
        });
        ci.set_states(order.len(), states);
        self.seconds += t.elapsed().as_secs_f64();
    }
}

impl Parallel {
    /// Each joint's largest damage (over its points), on rank 0 only (None on the others),
    /// from the ranks the damaged joints are designated to: what a whole frame reads of the
    /// joints. A collective; 9–13 bytes a damaged joint (postcard's variable-length ids),
    /// where sharing the histories sends every joint's whole history to every rank.
    pub fn gather_joint_damage_to_root(&mut self, joints: &Joints) -> Option<Vec<Real>> {
        let t = std::time::Instant::now();
        let mine: Vec<(u32, Real)> = (0..joints.len())
            .filter(|&j| self.joints.designates(j) && joints.is_damaged(j))
            .map(|j| (j as u32, joints.largest_damage(j)))
            .collect();
        let before = self.bytes;
        let mut damage = (self.comm.rank() == 0).then(|| vec![0.0; joints.len()]);
        self.gather_each_to_root(mine, "joint damage", |of_rank: Vec<(u32, Real)>| {
            if let Some(d) = &mut damage {
                for (j, dj) in of_rank {
                    d[j as usize] = dj;
                }
            }
        });
        self.whole_bytes += self.bytes - before;
        self.seconds += t.elapsed().as_secs_f64();
        damage
    }

    /// The touching pairs' outputs of the last step, on rank 0 only (None on the others), in
    /// pair order, from each rank's designated pairs (`mine`,
    /// [`crate::contact_interaction::ContactInteraction::designated_outputs`]; no pair is
    /// designated to two ranks): what a whole frame reads of contact. A collective.
    pub fn gather_pair_outputs_to_root(
        &mut self,
        mine: Vec<(u64, crate::contact_interaction::PairOut)>,
    ) -> Option<Vec<crate::contact_interaction::PairOut>> {
        let t = std::time::Instant::now();
        let before = self.bytes;
        let mut all = (self.comm.rank() == 0).then(Vec::new);
        self.gather_each_to_root(mine, "pair outputs", |of_rank| {
            if let Some(a) = &mut all {
                a.extend(of_rank);
            }
        });
        let outputs = all.map(|mut a| {
            // Each rank's keys ascend: the merge by key is pair order.
            a.sort_unstable_by_key(|o| o.0);
            a.into_iter().map(|o| o.1).collect()
        });
        self.whole_bytes += self.bytes - before;
        self.seconds += t.elapsed().as_secs_f64();
        outputs
    }
}

/// Which ranks' pieces of a frame written in pieces use each node: a piece is the tets whose
/// first node a rank owns ([`Parallel::piece_of_tet`]); a node of a continuous body may be
/// in several.
pub struct PieceRanks {
    first: Vec<u32>,
    /// (node, rank) for the nodes in more than one piece, besides `first`; sorted.
    more: Vec<(u32, u32)>,
}

impl PieceRanks {
    /// The ranks whose pieces use node `n`.
    fn of(&self, n: u32) -> impl Iterator<Item = u32> + '_ {
        let from = self.more.partition_point(|m| m.0 < n);
        let more = self.more[from..].iter().take_while(move |m| m.0 == n);
        (self.first.get(n as usize).copied())
            .filter(|&r| r != u32::MAX)
            .into_iter()
            .chain(more.map(|m| m.1))
    }
}

impl Parallel {
    /// The rank whose piece of a frame written in pieces holds tet `e` (of `tets`): the owner
    /// of its first node. That rank computes every pair of the tet and the element unit
    /// holding it, so the tet's nodes, stress and pairs are current on it.
    pub fn piece_of_tet(&self, tets: &Tets, e: usize) -> usize {
        self.partition.owner(tets.nodes[e][0] as usize)
    }

    /// [`PieceRanks`] of the model's tets.
    pub fn piece_ranks(&self, tets: &Tets, n_nodes: usize) -> PieceRanks {
        let mut first = vec![u32::MAX; n_nodes];
        let mut more = Vec::new();
        for e in 0..tets.len() {
            let q = self.piece_of_tet(tets, e) as u32;
            for n in tets.nodes[e] {
                let f = &mut first[n as usize];
                if *f == u32::MAX {
                    *f = q;
                } else if *f != q {
                    more.push((n, q));
                }
            }
        }
        more.sort_unstable();
        more.dedup();
        PieceRanks { first, more }
    }

    /// For this rank's piece of a frame written in pieces: each joint's largest damage, right
    /// for every joint of a tet in the piece and every joint designated to this rank (zero
    /// for the others), from the ranks the
    /// damaged joints are designated to. A collective: each rank sends (joint, damage) of
    /// its designated damaged joints to the ranks whose pieces hold one of their two tets, a
    /// neighbour exchange (the joints across pieces), not a gather of every joint.
    pub fn joint_damage_for_piece(&mut self, joints: &Joints, tets: &Tets) -> Vec<Real> {
        let t = std::time::Instant::now();
        let me = self.comm.rank();
        let mut damage = vec![0.0; joints.len()];
        let mut sends: Vec<Vec<f64>> = vec![Vec::new(); self.comm.size()];
        for j in (0..joints.len()).filter(|&j| self.joints.designates(j) && joints.is_damaged(j)) {
            let d = joints.largest_damage(j);
            damage[j] = d;
            let [a, b] = joints.tets[j].map(|e| self.piece_of_tet(tets, e as usize));
            if a != me {
                sends[a].extend([j as f64, d]);
            }
            if b != me && b != a {
                sends[b].extend([j as f64, d]);
            }
        }
        let received = self.send_counted(&sends);
        for v in received.iter().flat_map(|b| b.chunks_exact(2)) {
            damage[v[0] as usize] = v[1];
        }
        let bytes = 8 * received.iter().map(|b| b.len() as u64).sum::<u64>();
        self.bytes += bytes;
        self.whole_bytes += bytes;
        self.seconds += t.elapsed().as_secs_f64();
        damage
    }

    /// For this rank's piece of a frame written in pieces: the touching pairs' outputs of
    /// the last step with a node in the piece, in pair order (with some of this rank's own
    /// beside them). `mine` are this rank's designated touching pairs' outputs with their
    /// keys ([`crate::contact_interaction::ContactInteraction::designated_outputs`]); each
    /// goes to the other ranks whose pieces use one of its nodes (`ranks`), a neighbour
    /// exchange. A node's contact force summed over them in pair order is the one-process
    /// sum.
    pub fn pair_outputs_for_piece(
        &mut self,
        mine: Vec<(u64, crate::contact_interaction::PairOut)>,
        ranks: &PieceRanks,
    ) -> Vec<crate::contact_interaction::PairOut> {
        use crate::contact_interaction::PairOut;
        let t = std::time::Instant::now();
        let me = self.comm.rank() as u32;
        let mut sends: Vec<Vec<f64>> = vec![Vec::new(); self.comm.size()];
        let mut to: Vec<u32> = Vec::new();
        for (key, out) in &mine {
            to.clear();
            to.extend(out.nodes().iter().flat_map(|&n| ranks.of(n)));
            to.sort_unstable();
            to.dedup();
            for &q in to.iter().filter(|&&q| q != me) {
                let buf = &mut sends[q as usize];
                buf.extend([(key >> 32) as f64, (key & 0xffff_ffff) as f64]);
                out.write(buf);
            }
        }
        let received = self.send_counted(&sends);
        let mut all = mine;
        for v in received
            .iter()
            .flat_map(|b| b.chunks_exact(2 + PairOut::LEN))
        {
            let key = ((v[0] as u64) << 32) | v[1] as u64;
            all.push((key, PairOut::read(&v[2..])));
        }
        // No pair is designated to two ranks: the keys are distinct, and their order is
        // pair order.
        all.sort_unstable_by_key(|o| o.0);
        let bytes = 8 * received.iter().map(|b| b.len() as u64).sum::<u64>();
        self.bytes += bytes;
        self.whole_bytes += bytes;
        self.seconds += t.elapsed().as_secs_f64();
        all.into_iter().map(|o| o.1).collect()
    }
}

/// One joint's history, as its designated rank sends it to the others.
#[derive(serde::Serialize, serde::Deserialize)]
struct JointHistory {
    joint: u32,
    state: [crate::joints::law::PointHistory; 3],
    anchor: [crate::math::Vec3; 3],
    slid: [Real; 3],
    offset: [crate::math::Vec3; 3],
    last_energy: [Real; 3],
    keeps_faces: bool,
    handed_over: bool,
    rate: Option<crate::joints::RateState>,
}

impl Parallel {
    /// Give every rank every joint's history from its designated rank (a rank keeps only the
    /// joints it computes current while stepping). Before a new split; a collective.
    pub fn share_joint_histories(&mut self, joints: &mut Joints) {
        self.joint_histories_to(joints, false);
    }

    /// [`Parallel::share_joint_histories`] to rank 0 alone (a checkpoint); a collective.
    pub fn gather_joint_histories_to_root(&mut self, joints: &mut Joints) {
        self.joint_histories_to(joints, true);
    }

    fn joint_histories_to(&mut self, joints: &mut Joints, root: bool) {
        let t = std::time::Instant::now();
        let get = |v: &Vec<bool>, j: usize| v.get(j).copied().unwrap_or(false);
        let mine: Vec<JointHistory> = (0..joints.len())
            .filter(|&j| self.joints.designates(j))
            .map(|j| JointHistory {
                joint: j as u32,
                state: joints.state[j],
                anchor: joints.anchor[j],
                slid: joints.slid[j],
                offset: joints.offset[j],
                last_energy: joints.last_energy[j],
                keeps_faces: get(&joints.keeps_faces, j),
                handed_over: get(&joints.handed_over, j),
                rate: (!joints.rate.is_empty()).then(|| joints.rate[j]),
            })
            .collect();
        let before = self.bytes;
        // (The receivers' arrays whole first: a rank holds its units' histories only.)
        if !root || self.rank() == 0 {
            joints.hold_all();
        }
        let take = |of_rank: Vec<JointHistory>| {
            for h in of_rank {
                let j = h.joint as usize;
                joints.state[j] = h.state;
                joints.anchor[j] = h.anchor;
                joints.slid[j] = h.slid;
                joints.offset[j] = h.offset;
                joints.last_energy[j] = h.last_energy;
                if let Some(k) = joints.keeps_faces.get_mut(j) {
                    *k = h.keeps_faces;
                }
                if let Some(k) = joints.handed_over.get_mut(j) {
                    *k = h.handed_over;
                }
                if let (Some(r), Some(hr)) = (joints.rate.get_mut(j), h.rate) {
                    *r = hr;
                }
            }
        };
        if root {
            self.gather_each_to_root(mine, "joint histories", take);
        } else {
            self.gather_each(mine, "joint histories", take);
        }
        self.whole_bytes += self.bytes - before;
        self.seconds += t.elapsed().as_secs_f64();
    }
}

/// The digits ([`crate::math::ExactSum::digits`]) of the exact sums, field by field, of the
/// partials `include`d, into `out` (`P::LEN` × `ExactSum::LEN` values) for a sum over ranks.
fn write_exact<P: Partial>(partials: &[P], include: impl Fn(usize) -> bool, out: &mut [f64]) {
    let sums = crate::math::exact_sum::exact_fields(partials, include);
    for (s, o) in sums
        .iter()
        .zip(out.chunks_exact_mut(crate::math::ExactSum::LEN))
    {
        s.digits(o);
    }
}

/// A [`Partial`] from the summed digits of its fields' exact sums.
fn read_exact<P: Partial>(digits: &[f64]) -> P {
    use crate::math::exact_sum::{read_rounded, MAX_FIELDS};
    use crate::math::ExactSum;
    let mut all: [ExactSum; MAX_FIELDS] = Default::default();
    for (s, d) in all.iter_mut().zip(digits.chunks_exact(ExactSum::LEN)) {
        *s = ExactSum::from_digits(d);
    }
    read_rounded(&all)
}

impl Partial for crate::elements::ElementSums {
    const LEN: usize = 3;
    fn write(&self, out: &mut [f64]) {
        out.copy_from_slice(&[self.strain_energy, self.viscous_power, self.inverted as f64]);
    }
    fn read(v: &[f64]) -> Self {
        Self {
            strain_energy: v[0],
            viscous_power: v[1],
            inverted: v[2] as usize,
        }
    }
}

impl Partial for JointSums {
    const LEN: usize = 4;
    fn write(&self, out: &mut [f64]) {
        out.copy_from_slice(&[
            self.energy,
            self.dissipated,
            self.newly_failed as f64,
            self.parted as f64,
        ]);
    }
    fn read(v: &[f64]) -> Self {
        Self {
            energy: v[0],
            dissipated: v[1],
            newly_failed: v[2] as usize,
            parted: v[3] as usize,
        }
    }
}

impl Partial for IntegrationSums {
    const LEN: usize = 10;
    fn write(&self, out: &mut [f64]) {
        out.copy_from_slice(&[
            self.kinetic,
            self.gravity_work,
            self.reaction_work_before,
            self.reaction_work_after,
            self.damping_before,
            self.damping_after,
            self.non_finite as f64,
            self.momentum.x,
            self.momentum.y,
            self.momentum.z,
        ]);
    }
    fn read(v: &[f64]) -> Self {
        Self {
            kinetic: v[0],
            gravity_work: v[1],
            reaction_work_before: v[2],
            reaction_work_after: v[3],
            damping_before: v[4],
            damping_after: v[5],
            non_finite: v[6] as usize,
            momentum: crate::math::Vec3::new(v[7], v[8], v[9]),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integration::CHUNK;

    /// A body of `chunks` chunks of nodes, the nodes of chunk k at x = `place(k)` (y, z
    /// spread a little so that x is the widest extent).
    fn body(name: &str, first: usize, chunks: usize, layout: Layout) -> Body {
        Body {
            name: name.into(),
            layout,
            material: 0,
            tets: 0..0,
            nodes: first..first + chunks * CHUNK,
            boundary: Vec::new(),
            mesh: crate::mesh::Mesh::default(),
        }
    }

    /// The case the contiguous node ranges got wrong: a slab whose nodes come first and a
    /// row of small bodies above it, added in an order unrelated to their place. Split by
    /// place, every rank owns a slice of the slab and the small bodies over that slice:
    /// the ranks' chunk centres do not interleave along x, and each rank's nodes are its
    /// share within one chunk (the bisection cuts between chunks).
    #[test]
    fn ranks_own_compact_regions_in_balanced_shares() {
        let slab = 16;
        let small = 16;
        let n = (slab + small) * CHUNK;
        let mut x = vec![Vec3::zeros(); n];
        for (i, p) in x.iter_mut().enumerate() {
            let c = i / CHUNK;
            let along = if c < slab {
                (i as Real + 0.5) / (slab * CHUNK) as Real
            } else {
                // Small bodies added out of place: chunk k of them at ((7k mod 16) + ½)/16.
                (((c - slab) * 7 % small) as Real + 0.5) / small as Real
            };
            *p = Vec3::new(
                along,
                0.01 * (i % 7) as Real,
                if c < slab { 0.0 } else { 0.05 },
            );
        }
        let bodies = vec![body("slab", 0, slab, Layout::Continuous)];
        let tets = Tets::default();
        for size in 1..=5 {
            let parts: Vec<Partition> = (0..size)
                .map(|r| Partition::new(r, size, &x, &tets, &bodies))
                .collect();
            // Every rank computes the same split.
            for p in &parts[1..] {
                assert_eq!(p.chunk_owner, parts[0].chunk_owner, "np {size}");
            }
            let p = &parts[0];
            assert_eq!(p.nodes_per_rank.iter().sum::<usize>(), n);
            let share = n as Real / size as Real;
            for (r, &nodes) in p.nodes_per_rank.iter().enumerate() {
                assert!(
                    (nodes as Real - share).abs() <= CHUNK as Real,
                    "np {size}: rank {r} owns {nodes} nodes, share {share}"
                );
            }
            // Each rank's chunk centres along x form an interval that no other rank's
            // centre falls inside.
            let centre = |c: usize| {
                (c * CHUNK..(c + 1) * CHUNK).map(|i| x[i].x).sum::<Real>() / CHUNK as Real
            };
            let span: Vec<(Real, Real)> = (0..size)
                .map(|r| {
                    p.rank_chunks[r]
                        .iter()
                        .fold((Real::INFINITY, Real::NEG_INFINITY), |s, &c| {
                            (s.0.min(centre(c as usize)), s.1.max(centre(c as usize)))
                        })
                })
                .collect();
            for (c, &owner) in p.chunk_owner.iter().enumerate() {
                for (r, &(lo, hi)) in span.iter().enumerate() {
                    if r != owner as usize {
                        assert!(
                            !(lo < centre(c) && centre(c) < hi),
                            "np {size}: chunk {c} of rank {owner} inside rank {r}'s span"
                        );
                    }
                }
            }
            // The slab is shared by every rank (it went whole to rank 0 with ranges).
            let slab_ranks: std::collections::BTreeSet<u32> =
                p.chunk_owner[..slab].iter().copied().collect();
            assert_eq!(
                slab_ranks.len(),
                size,
                "np {size}: slab on ranks {slab_ranks:?}"
            );
        }
    }

    /// A continuous body of `chunks` chunks of nodes in a row along x (y spread a little,
    /// so that x is the widest extent), without tets.
    fn row(chunks: usize) -> (Vec<Vec3>, Vec<Body>, Tets) {
        let x = (0..chunks * CHUNK)
            .map(|i| Vec3::new(i as Real, 0.01 * (i % 5) as Real, 0.0))
            .collect();
        let bodies = vec![body("row", 0, chunks, Layout::Continuous)];
        (x, bodies, Tets::default())
    }

    /// The halo's two sides agree: what rank r sends rank q is what q receives from r, node
    /// for node and in the same order, though each rank derives its lists alone (from the
    /// pieces of work it and the others compute); nothing goes to a rank that does not read
    /// it, and a node read by every rank (a force set's) goes to every other rank.
    #[test]
    fn the_halo_sends_what_the_other_side_receives() {
        let chunks = 6;
        let n = chunks * CHUNK;
        // Chunks in a row along x: the bisection gives each rank a run of them.
        let (x, bodies, tets) = row(chunks);
        // Pieces of work: 4 nodes each, some within a chunk, some across chunk borders,
        // some joining far chunks (contact pairs), in a scrambled but fixed order.
        let pieces: Vec<[u32; 4]> = (0..400u64)
            .map(|k| {
                let a = (k * 7919 % n as u64) as u32;
                let step = [1, 3, CHUNK as u64 / 2, CHUNK as u64 + 5][k as usize % 4];
                [0, 1, 2, 3].map(|j| ((a as u64 + j * step) % n as u64) as u32)
            })
            .collect();
        let read_by_all = [5u32, (3 * CHUNK + 17) as u32];
        for size in 2..=4 {
            let halos: Vec<Halo> = (0..size)
                .map(|me| {
                    let p = Partition::new(me, size, &x, &tets, &bodies);
                    let mut readers = Readers::new(n);
                    for piece in &pieces {
                        readers.add(&p, me, piece, piece);
                    }
                    readers.add_read_by_all(&p, me, &read_by_all);
                    readers.finish();
                    Halo::new(&p, me, &readers.keys)
                })
                .collect();
            let p = Partition::new(0, size, &x, &tets, &bodies);
            assert!(
                halos.iter().all(|h| h.sent() > 0 && h.received() > 0),
                "np {size}: every rank exchanges"
            );
            for (r, h) in halos.iter().enumerate() {
                for (q, sent) in &h.send {
                    assert_ne!(*q, r);
                    let got = halos[*q].recv.iter().find(|(from, _)| *from == r);
                    assert_eq!(got.map(|g| &g.1), Some(sent), "np {size}: {r} → {q}");
                    assert!(sent.windows(2).all(|w| w[0] < w[1]), "in node order");
                    assert!(sent.iter().all(|&n| p.owner(n as usize) == r));
                }
                // Every node received is read by a piece this rank computes (or by all).
                for (from, got) in &h.recv {
                    assert!(halos[*from].send.iter().any(|(q, _)| *q == r));
                    for &node in got {
                        let read = read_by_all.contains(&node)
                            || pieces.iter().any(|piece| {
                                piece.contains(&node)
                                    && piece.iter().any(|&m| p.owner(m as usize) == r)
                            });
                        assert!(
                            read,
                            "np {size}: rank {r} receives node {node} it never reads"
                        );
                    }
                }
                // And every node it reads of another rank's is received.
                let received = |node: u32| h.recv.iter().any(|(_, l)| l.contains(&node));
                for piece in pieces
                    .iter()
                    .filter(|piece| piece.iter().any(|&m| p.owner(m as usize) == r))
                {
                    for &node in piece.iter().filter(|&&m| p.owner(m as usize) != r) {
                        assert!(received(node), "np {size}: rank {r} misses node {node}");
                    }
                }
                for &node in &read_by_all {
                    let owner = p.owner(node as usize);
                    if owner != r {
                        assert!(
                            h.recv
                                .iter()
                                .any(|(from, l)| *from == owner && l.contains(&node)),
                            "np {size}: rank {r} misses node {node}, read by every rank"
                        );
                    }
                }
            }
        }
    }

    /// A split weighed by the work follows it: of eight chunks in a row, the first two carry
    /// work worth three times their corners (each then weighs as much as four plain chunks:
    /// 8 of 14 in all), so 2 ranks take 2 and 6 chunks (the cut nearest half the weight),
    /// where by corners alone they take 4 and 4; without work the split is the corners'
    /// exactly.
    #[test]
    fn a_split_weighed_by_work_follows_it() {
        let chunks = 8;
        let n = chunks * CHUNK;
        let (x, bodies, tets) = row(chunks);
        // A node of no tet weighs one corner: with work, 4 a node plus its work.
        let work: Vec<u32> = (0..n).map(|i| if i < 2 * CHUNK { 12 } else { 0 }).collect();
        let by_corners = Partition::keeping(0, 2, &x, &tets, &bodies, &[], None);
        let by_work = Partition::keeping(0, 2, &x, &tets, &bodies, &work, None);
        assert_eq!(by_corners.nodes_per_rank, vec![4 * CHUNK, 4 * CHUNK]);
        let mut shares = by_work.nodes_per_rank.clone();
        shares.sort_unstable();
        assert_eq!(shares, vec![2 * CHUNK, 6 * CHUNK]);
        let worked = by_work.chunk_owner[0];
        assert!(by_work.chunk_owner[..2].iter().all(|&r| r == worked));
        assert!(by_work.chunk_owner[2..].iter().all(|&r| r != worked));
        assert_eq!(
            Partition::new(0, 2, &x, &tets, &bodies).chunk_owner,
            by_corners.chunk_owner
        );
    }

    /// A rigid body's nodes are never split between ranks (its owner gathers its force and
    /// torque), even where it spans several chunks; and with fewer groups than ranks, the
    /// ranks left without nodes own nothing rather than a part of one.
    #[test]
    fn a_rigid_body_stays_on_one_rank() {
        let n = 6 * CHUNK;
        let x: Vec<Vec3> = (0..n).map(|i| Vec3::new(i as Real, 0.0, 0.0)).collect();
        // A rigid body over chunks 1 to 4, starting and ending inside a chunk.
        let mut rigid = body("rigid", CHUNK + 100, 3, Layout::Rigid);
        rigid.nodes.end += 50;
        let bodies = vec![rigid.clone()];
        let tets = Tets::default();
        for size in 2..=4 {
            let p = Partition::new(0, size, &x, &tets, &bodies);
            let owner = p.owner(rigid.nodes.start);
            assert!(
                rigid.nodes.clone().all(|i| p.owner(i) == owner),
                "np {size}: the rigid body is split"
            );
            assert_eq!(p.nodes_per_rank.iter().sum::<usize>(), n);
        }
        // Three groups (chunk 0, chunks 1–4, chunk 5) on five ranks.
        let p = Partition::new(0, 5, &x, &tets, &bodies);
        let owning = p.nodes_per_rank.iter().filter(|&&k| k > 0).count();
        assert_eq!(owning, 3, "{:?}", p.nodes_per_rank);
    }

    /// `sim.repartition(#{ if_imbalance })` decides from the ranks' stage seconds since its
    /// last check: the slowest over the mean, the same on every rank. Three thread-ranks
    /// report 1, 1, 4 s (imbalance 4 / 2 = 2), then 2, 2, 2 s more (1: balanced), then
    /// nothing (1 by convention, no division by zero).
    #[test]
    fn the_imbalance_is_measured_since_the_last_check() {
        let seen = comm::ThreadComm::run(3, |c| {
            let rank = c.rank();
            let mut par = Parallel::pending(c);
            let first = [1.0, 1.0, 4.0][rank];
            [
                par.imbalance_since_last_check(first),
                par.imbalance_since_last_check(first + 2.0),
                par.imbalance_since_last_check(first + 2.0),
            ]
        });
        for s in seen {
            assert_eq!(s, [2.0, 1.0, 1.0]);
        }
    }

    /// A re-split whose parts are the old ones in another order keeps every chunk with its
    /// owner; parts that moved keep what overlaps most, and a part overlapping no old
    /// rank takes the rank left over.
    #[test]
    fn a_new_split_keeps_the_owners_it_can() {
        let previous = [0u32, 0, 0, 1, 1, 1, 2, 2, 2];
        // The same three parts, numbered 2, 0, 1: renumbered back.
        let parts = [2u32, 2, 2, 0, 0, 0, 1, 1, 1];
        let rank_of = matching_ranks(&parts, &previous, 3);
        let kept: Vec<u32> = parts.iter().map(|&p| rank_of[p as usize]).collect();
        assert_eq!(kept, previous);
        // Shifted by one chunk: part 1 (chunks 1–3) overlaps rank 0 twice and rank 1 once;
        // part 0 (chunk 0 and 8) overlaps ranks 0 and 2 once.
        let parts = [0u32, 1, 1, 1, 2, 2, 2, 2, 0];
        let rank_of = matching_ranks(&parts, &previous, 3);
        assert_eq!(rank_of, vec![2, 0, 1]);
        // 5 of 9 chunks keep their owner (chunks 1, 2, 4, 5 and 8), against 4 with the
        // bisection's own numbering.
        let moved = |r: &[u32]| {
            (parts.iter().zip(&previous))
                .filter(|(&p, &o)| r[p as usize] != o)
                .count()
        };
        assert_eq!(moved(&rank_of), 4);
        assert_eq!(moved(&[0, 1, 2]), 5);
    }
}
