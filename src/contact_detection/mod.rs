//! Stage 4: contact detection — the broad phase. Reads node positions, tets, bodies and the
//! joints' broken flags; writes the candidate pairs of surface elements whose (inflated)
//! bounding boxes overlap, and hands stage 5 an old→new remap of the pair list
//! ([`PairOrigin`]) so that stage 5 carries its per-pair history over.
//!
//! **Search**: Munjiza's NBS ([`nbs`]), linear in time and memory, with a brute-force oracle
//! and a sort-and-sweep comparison point.
//!
//! **Surface**: tets with a free face (the outer boundary of a continuous body, every face of
//! a jointed body's tet not held by an intact joint), refreshed when joints break.
//!
//! **Skin.** Boxes are inflated by `skin/2` on every side. While no node has moved more than
//! `skin/2` since the last detection, every box still lies inside its inflated box, so every
//! pair that can touch is already a candidate: detection need not run again (see
//! [`Detector::needs_update`]).
//!
//! **Which pairs are candidates**: pairs are excluded while their tets are connected: in the
//! same fragment and touching in the reference configuration (a shared reference node
//! position: neighbours in one mesh, or glued faces of two bodies), unless they are the two
//! sides of a broken joint; and a continuous body does not contact itself. So intact material
//! never contacts itself, cracks and separate fragments do, and distant parts of one jointed
//! body may. A face plane of one tet with the whole other tet more than a skin outside it
//! separates the pair until the next detection.

pub mod nbs;

pub use nbs::{brute_force_pairs, nbs_pairs, nbs_pairs_of, sweep_pairs, Aabb, NbsWorkspace};

use crate::fracture::{BreakEvent, FragmentTracker};
use crate::joints::Joints;
use crate::math::{ExactSum, Real, Vec3};
use crate::state::{Body, Layout, Nodes, Tets};
use rayon::prelude::*;

/// Detection state between steps: positions at the last detection, skin.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, Default)]
pub struct Detector {
    /// Skin [m]: boxes are inflated by skin/2.
    pub skin: Real,
    /// Node positions at the last detection (only nodes of surface elements are checked).
    pub x_at_detection: Vec<Vec3>,
    /// Detections done (full: NBS over every surface tet).
    pub detections: u64,
    /// Incremental detections: joints broke, and only the pairs they made possible were
    /// added ([`update_pairs`]).
    #[serde(default)]
    pub incremental: u64,
    /// Force a detection at the next step (topology changed, first step, …).
    pub stale: bool,
    #[serde(skip)]
    pub workspace: NbsWorkspace,
    /// `x_at_detection` of the surface nodes, in the order of
    /// [`ContactDetection::surface_nodes`], for one process's skin test (made at each full
    /// detection, extended as nodes join the surface; empty on a rank of a decomposed model
    /// and after a restart until the next full detection: the skin test then reads
    /// `x_at_detection`).
    #[serde(skip)]
    surface_x: Vec<Vec3>,
    /// On a rank of a decomposed model: per node, whether its position was current on this
    /// rank at the last full detection (its own, or within reach of its own,
    /// [`PairExchange::make_near_current`]): `x_at_detection` holds only those. Empty when
    /// every node's is held (one process, or after the ranks shared them).
    #[serde(skip)]
    pub current: Vec<bool>,
}

impl Detector {
    /// The surface nodes' positions at the last detection, in the order of
    /// [`ContactDetection::surface_nodes`], as the skin test reads them (empty before the
    /// first detection and after a restart, until the surface changes).
    pub fn surface_positions(&self) -> &[Vec3] {
        &self.surface_x
    }

    /// True when some node in `nodes` moved more than skin/2 since the last detection (then
    /// a pair could come into contact that was not a candidate). `max` is exact, so the
    /// answer does not depend on threads.
    pub fn needs_update(&self, x: &[Vec3], nodes: &[u32]) -> bool {
        if self.stale || self.x_at_detection.len() != x.len() {
            return true;
        }
        self.moved_beyond_skin(x, nodes, |_| true)
    }

    /// Some node in `nodes` moved more than skin/2 since the last detection. When `nodes`
    /// are the surface nodes whose positions at detection `surface_x` holds, those are read
    /// in order instead of from `x_at_detection` (the surface nodes of a large body in
    /// spatial order are scattered through the node arrays).
    fn moved_beyond_skin(
        &self,
        x: &[Vec3],
        nodes: &[u32],
        tested: impl Fn(u32) -> bool + Sync,
    ) -> bool {
        let half = 0.5 * self.skin;
        let limit = half * half;
        if self.surface_x.len() == nodes.len() {
            return nodes
                .par_chunks(4096)
                .zip(self.surface_x.par_chunks(4096))
                .any(|(c, at)| {
                    c.iter()
                        .zip(at)
                        .any(|(&n, x0)| tested(n) && (x[n as usize] - x0).norm_squared() > limit)
                });
        }
        nodes.par_chunks(4096).any(|c| {
            c.iter().any(|&n| {
                tested(n)
                    && (x[n as usize] - self.x_at_detection[n as usize]).norm_squared() > limit
            })
        })
    }
}

/// Where a pair of the new candidate list comes from (the remap stage 4 hands stage 5).
#[derive(serde::Serialize, serde::Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub enum PairOrigin {
    /// The pair was a candidate before, at this index of the previous list: its history
    /// carries over.
    Kept(u32),
    /// A new candidate. `neighbours`: the two tets were connected when contact started (same
    /// fragment, a shared reference position), so they may overlap from the deformation they
    /// underwent while connected; `joint`: the broken joint between them (u32::MAX if none).
    New { neighbours: bool, joint: u32 },
}

/// Stage 4 state: surface, candidate pairs and the remap of the last detection.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, Default)]
pub struct ContactDetection {
    pub detector: Detector,
    /// Skin given by the script [m] (None: a quarter of the mean surface element size).
    pub skin: Option<Real>,
    /// Surface tets (a free face: outer boundary or broken joint), simulation ids, in the
    /// order they joined the surface: a tet keeps its index (the pairs' numbering) while it
    /// is on it. Those on it at the first refresh come in id order, each refresh's newcomers
    /// after them in id order, so that a refresh costs the tets that joined, not the surface
    /// (the same order for any number of threads and ranks, and after a restart).
    pub surface: Vec<u32>,
    /// Nodes of surface tets, each once: sorted at a refresh from scratch, each refresh from
    /// breaks' newcomers appended (sorted among themselves).
    pub surface_nodes: Vec<u32>,
    /// Fragment of each tet at the last detection.
    pub fragment: Vec<u32>,
    /// Fragment of each tet when contact started: only tets that were once connected can
    /// carry an overlap contact did not make.
    pub fragment0: Vec<u32>,
    /// Per joint: broken, and taken in by a surface refresh (its two tets may be a contact
    /// pair across it). A flag per joint, not a sorted list of the broken ones, so that a
    /// refresh after breaks costs the joints that broke, not every joint broken so far.
    pub broken_seen: Vec<bool>,
    /// Per tet, its joints: `joints_of_tet.1[joints_of_tet.0[e]..joints_of_tet.0[e + 1]]`
    /// (made at a refresh from scratch, for the joint between two tets).
    #[serde(skip)]
    joints_of_tet: (Vec<u32>, Vec<u32>),
    /// Candidate pairs (indices into `surface`, lower first), sorted. On a rank of a
    /// decomposed model, only the pairs it computes (`local`), between the script's reads of
    /// the whole model's state.
    pub pairs: Vec<[u32; 2]>,
    /// `pairs` holds only this rank's pairs (a decomposed model: those with a tet holding a
    /// node of the rank, [`keep_this_ranks_pairs`]); false on one process and while the
    /// whole list is shared for output, checkpoints and queries.
    #[serde(skip)]
    pub local: bool,
    /// With `local`: the number of candidate pairs over all ranks, as of the last change of
    /// the list ([`ContactDetection::candidate_pairs`]).
    #[serde(skip)]
    pub all_ranks_pairs: usize,
    /// For every pair of `pairs`: where it comes from, from a detection until stage 5 takes
    /// it ([`ContactDetection::take_remap`]).
    pub origins: Vec<PairOrigin>,
    /// Inflated boxes of the surface tets at the last detection (on a rank of a decomposed
    /// model, a box that overlaps nothing for the tets out of its reach; empty once the
    /// positions at detection were shared, until an incremental detection makes them anew).
    pub boxes: Vec<Aabb>,
    /// On a rank of a decomposed model: the surface nodes it owns, which its share of the
    /// skin test reads every step ([`surface_moved_here`]; None until first asked after the
    /// surface or the split changed).
    #[serde(skip)]
    pub own_surface_nodes: Option<Vec<u32>>,
    /// The nodes that joined the surface since [`ContactDetection::own_surface_nodes`] was
    /// listed (from the refreshes after breaks, in `surface_nodes`' order): its own among them
    /// are appended to it at the next skin test instead of listing the rank's surface nodes
    /// anew.
    #[serde(skip)]
    surface_nodes_joined: Vec<u32>,
    /// Surface lists must be rebuilt (joints broke: [`ContactDetection::joints_broke`];
    /// model changed: [`ContactDetection::prepare`]).
    surface_stale: bool,
    /// Surface refreshes made from the broken joints alone ([`refresh_after_breaks`]), not
    /// from scratch.
    #[serde(skip)]
    pub refreshes_from_breaks: u64,
    /// Break events seen by the last surface refresh.
    seen_breaks: usize,
    /// The joints broken since the last surface refresh, when they are all it must take in
    /// ([`ContactDetection::joints_broke`]; the refresh is then made from them alone).
    #[serde(skip)]
    newly_broken: Vec<u32>,
    /// The next refresh is made from scratch: the model changed ([`ContactDetection::prepare`]).
    #[serde(skip)]
    rebuild: bool,
    /// Free faces of each tet (boundary faces and faces of broken joints), kept between
    /// refreshes (empty until the first, and after a restart).
    #[serde(skip)]
    free_faces: Vec<i32>,
    /// Per tet, its index in `surface` (u32::MAX off it); kept with `free_faces`.
    #[serde(skip)]
    surface_index: Vec<u32>,
    /// Per node, whether it is in `surface_nodes`; kept with `free_faces`.
    #[serde(skip)]
    on_surface: Vec<bool>,
    /// On a rank of a decomposed model: the surface tets (indices, ascending) whose nodes'
    /// positions at the last full detection it holds, those within reach of its own
    /// ([`Detector::current`]), with the held tets that joined the surface since. An
    /// incremental detection tests the joined tets against these only. None: every surface
    /// tet (one process, or after the ranks shared every position).
    #[serde(skip)]
    held: Option<Vec<u32>>,
    /// Fragments, split as joints break (`fragment` holds its labels).
    #[serde(skip)]
    fragments: FragmentTracker,
    /// During a detection: the previous pair list and, for each of its pairs, its index in
    /// the list before the surface refresh (freed after each detection, as the remap is).
    old_pairs: Vec<[u32; 2]>,
    carried: Vec<u32>,
}

impl ContactDetection {
    /// Before the first step after the model changed: rebuild the surface at the next update.
    pub fn prepare(&mut self) {
        self.surface_stale = true;
        self.rebuild = true;
    }

    /// Joints broke since the last update (`break_events`: every break event so far, in
    /// order): the surface changes, by those joints' faces.
    pub fn joints_broke(&mut self, break_events: &[BreakEvent]) {
        match break_events.get(self.seen_breaks..) {
            Some([]) => return,
            Some(new) => self.broken_since_refresh(new.iter().map(|e| e.joint as u32)),
            None => self.prepare(),
        }
        self.seen_breaks = break_events.len();
    }

    /// `joints` broke (their flags are set) since the last update: the next update refreshes
    /// the surface from them.
    pub fn broken_since_refresh(&mut self, joints: impl IntoIterator<Item = u32>) {
        self.newly_broken.extend(joints);
        self.surface_stale = true;
    }

    /// Copy the surface nodes' positions at the last detection into `detector.surface_x`
    /// (nothing before the first detection; on a rank of a decomposed model the positions of
    /// the nodes it did not hold then are stale until shared, and the skin test reads only
    /// its own).
    fn record_surface_positions(&mut self) {
        let d = &mut self.detector;
        d.surface_x.clear();
        let at = &d.x_at_detection;
        if self.surface_nodes.iter().all(|&n| (n as usize) < at.len()) {
            d.surface_x
                .extend(self.surface_nodes.iter().map(|&n| at[n as usize]));
        }
    }

    /// On a rank of a decomposed model, every node's position at the last full detection has
    /// just been shared from its owner (`x_at_detection` whole): the positions no longer
    /// depend on which nodes the rank held then, nor may what was computed from them. The
    /// boxes (a box that overlaps nothing for each tet out of reach) go, so that an
    /// incremental detection makes them anew from the whole positions (after a new split the
    /// rank may compute tets it did not hold), and the skin test's copy of the surface's
    /// positions is made again.
    pub fn positions_at_detection_shared(&mut self) {
        self.detector.current.clear();
        self.held = None;
        self.boxes.clear();
        self.record_surface_positions();
    }

    /// The number of candidate pairs of the whole model (on a rank holding only its own,
    /// the count over all ranks).
    pub fn candidate_pairs(&self) -> usize {
        if self.local {
            self.all_ranks_pairs
        } else {
            self.pairs.len()
        }
    }

    /// The old→new remap of the last detection, for stage 5 (the buffer goes with it, so the
    /// remap costs no memory between detections).
    pub fn take_remap(&mut self) -> Vec<PairOrigin> {
        std::mem::take(&mut self.origins)
    }

    /// Bytes held by the detection buffers (capacity).
    pub fn bytes(&self) -> usize {
        use std::mem::size_of;
        self.detector.workspace.bytes()
            + (self.pairs.capacity() + self.old_pairs.capacity()) * 8
            + self.origins.capacity() * size_of::<PairOrigin>()
            + self.boxes.capacity() * size_of::<Aabb>()
            + (self.surface.capacity() + self.surface_nodes.capacity()) * 4
            + (self.fragment.capacity() + self.fragment0.capacity() + self.free_faces.capacity())
                * 4
            + (self.surface_index.capacity() + self.held.as_ref().map_or(0, Vec::capacity)) * 4
            + self.on_surface.capacity()
            + self.broken_seen.capacity()
            + (self.joints_of_tet.0.capacity() + self.joints_of_tet.1.capacity()) * 4
            + self.fragments.bytes()
            + (self.detector.x_at_detection.capacity() + self.detector.surface_x.capacity())
                * size_of::<Vec3>()
    }
}

/// How the ranks of a decomposed model share stage 4 (implemented by `crate::parallel`).
/// Every rank holds the surface, fragments and boxes, and reaches every detection with the
/// same inputs; each searches only the pairs it computes (a tet of the pair holds a node of
/// the rank, [`PairExchange::computes`]) and keeps those ([`ContactDetection::local`]):
/// each rank's list is the sub-list of the single-process list with its pairs, in the same
/// order, and no list is gathered. Positions are made current where they are read: before
/// a full detection, the nodes within reach of a rank's own (the default skin, which sets
/// the reach, an exact sum over the ranks' designated surface tets); an incremental one
/// reads the positions of its last full detection, which are current for the same nodes.
/// The skin test reads each rank's own nodes ([`must_detect`]).
pub trait PairExchange {
    /// Per tet: it has a node of this rank (the rank computes every pair it is in).
    fn computes(&self) -> &[bool];
    /// Every node's position and velocity from its owner, on every rank (a collective).
    fn make_every_node_current(&mut self, nodes: &mut Nodes);
    /// The position and velocity of every node within `reach` of this rank's own nodes'
    /// bounding box, from their owners (a collective); per node, whether it is current.
    fn make_near_current(&mut self, nodes: &mut Nodes, reach: Real) -> Vec<bool>;
    /// The largest of one value per rank (a collective).
    fn largest(&mut self, value: Real) -> Real;
    /// Per tet: this rank is the lowest owning one of its nodes (each tet is designated to
    /// one rank).
    fn designates(&self, tet: usize) -> bool;
    /// Every rank's exact sum added to `sum` (a collective; exact in any order).
    fn sum_over_ranks(&mut self, sum: &mut ExactSum);
    /// Whether `mine` holds on some rank (a collective).
    fn any_rank(&mut self, mine: bool) -> bool;
    /// The skin test's answer for every rank, when the step's first meeting settled it (a
    /// decomposed step asks it there), else None.
    fn skin_test_answered(&self) -> Option<bool>;
    /// The node chunks this rank owns (its nodes are current on it), and the chunk size.
    fn owned_chunks(&self) -> (&[bool], usize);
}

/// On a rank of a decomposed model holding the whole list (after the script read the whole
/// model's state, or a checkpoint was restored), keep only the pairs it computes (`computes`:
/// per tet, it has a node of the rank) and hand stage 5 the remap, as a detection does.
/// Returns false, doing nothing, when the list is this rank's already.
pub fn keep_this_ranks_pairs(cd: &mut ContactDetection, computes: &[bool]) -> bool {
    if cd.local {
        return false;
    }
    let surface = &cd.surface;
    let mine = |p: &[u32; 2]| p.iter().any(|&i| computes[surface[i as usize] as usize]);
    cd.origins = (cd.pairs.iter().enumerate())
        .filter(|(_, p)| mine(p))
        .map(|(k, _)| PairOrigin::Kept(k as u32))
        .collect();
    cd.pairs = cd.pairs.iter().filter(|p| mine(p)).copied().collect();
    cd.local = true;
    true
}

/// Whether stage 4 must run this step: the surface changed, a detection is due, or a
/// surface node moved more than skin/2 since the last detection. The same on every rank of
/// a decomposed model: each tests the surface nodes it owns (only those are current on it
/// between detections) and the answers are combined.
pub fn must_detect(
    cd: &ContactDetection,
    x: &[Vec3],
    ranks: Option<&mut (dyn PairExchange + '_)>,
) -> bool {
    cd.surface_stale
        || cd.detector.stale
        || cd.detector.x_at_detection.len() != x.len()
        || surface_moved(cd, x, ranks)
}

/// One rank's part of the skin test: some surface node that passes `owned` moved more than
/// skin/2 since the last detection. False when the detection's record does not fit the
/// nodes (then [`must_detect`] answers without the test). A decomposed step answers it for
/// all ranks at its first meeting, before stage 4 asks (`crate::parallel`). It reads the
/// rank's own surface nodes, listed once per surface and split
/// ([`ContactDetection::own_surface_nodes`]), not the whole surface every step.
pub fn surface_moved_here(
    cd: &mut ContactDetection,
    x: &[Vec3],
    owned: impl Fn(u32) -> bool + Sync,
) -> bool {
    if cd.detector.stale || cd.detector.x_at_detection.len() != x.len() {
        return false;
    }
    let surface_nodes = &cd.surface_nodes;
    let joined = std::mem::take(&mut cd.surface_nodes_joined);
    let own = match &mut cd.own_surface_nodes {
        // After a refresh from breaks, its own among the nodes that joined (none of them
        // listed before: they were not on the surface).
        Some(own) => {
            own.extend(joined.into_iter().filter(|&n| owned(n)));
            own
        }
        None => cd.own_surface_nodes.insert(
            surface_nodes
                .par_iter()
                .copied()
                .filter(|&n| owned(n))
                .collect(),
        ),
    }
    .as_slice();
    // (When the rank owns every surface node the list is the surface's, in its order.)
    cd.detector.moved_beyond_skin(x, own, |_| true)
}

/// Some surface node moved more than skin/2 since the last detection (on every rank alike:
/// see [`must_detect`]).
fn surface_moved(
    cd: &ContactDetection,
    x: &[Vec3],
    ranks: Option<&mut (dyn PairExchange + '_)>,
) -> bool {
    match ranks {
        None => cd
            .detector
            .moved_beyond_skin(x, &cd.surface_nodes, |_| true),
        Some(r) => {
            // (Within a step the ranks answered it at their first meeting.)
            if let Some(any) = r.skin_test_answered() {
                return any;
            }
            let (owned, chunk) = r.owned_chunks();
            let mine = cd
                .detector
                .moved_beyond_skin(x, &cd.surface_nodes, |n| owned[n as usize / chunk]);
            r.any_rank(mine)
        }
    }
}

/// Stage 4: refresh the surface lists when the topology changed, and re-detect the candidate
/// pairs when a node moved more than skin/2 since the last detection. Returns true when it
/// detected: then `origins` maps every new pair to its old index (or marks it new), for
/// stage 5 to carry its history over.
///
/// On a decomposed model (`ranks`), each rank searches and keeps only the pairs it computes
/// (a full detection's NBS, an incremental one's tests of the tets that joined the surface):
/// its list is the single-process list's sub-list of those pairs. `nodes` are written only
/// there: before a full detection the nodes within reach of the rank's own are made current
/// from their owners. (After an incremental one, stage 5 reads the nodes of the added pairs
/// that two ranks compute: the caller exchanges those,
/// `crate::parallel::Parallel::share_added_pairs_nodes`.)
pub fn update_pairs(
    cd: &mut ContactDetection,
    nodes: &mut Nodes,
    tets: &Tets,
    bodies: &[Body],
    joints: &Joints,
    mut ranks: Option<&mut (dyn PairExchange + '_)>,
) -> bool {
    // (The lists kept between refreshes fit the model only after a refresh from scratch.)
    let from_scratch = cd.rebuild
        || cd.free_faces.len() != tets.len()
        || cd.surface_index.len() != tets.len()
        || cd.on_surface.len() != nodes.len()
        || cd.broken_seen.len() != joints.len()
        || cd.joints_of_tet.0.len() != tets.len() + 1
        || !cd.fragments.fits(tets.len(), joints.len());
    if cd.surface_stale || from_scratch {
        let detected_before = !cd.detector.stale
            && cd.detector.x_at_detection.len() == nodes.x.len()
            && cd.skin.is_none_or(|s| s == cd.detector.skin);
        let change = match from_scratch {
            false => refresh_after_breaks(cd, tets, joints),
            true => {
                let before = Topology {
                    surface: cd.surface.clone(),
                    fragment: cd.fragment.clone(),
                    broken: cd.broken_seen.clone(),
                };
                refresh_surface(cd, nodes, tets, bodies, joints);
                surface_change(cd, joints, &before)
            }
        };
        if let Some(change) = change.filter(|_| detected_before) {
            if add_pairs_of_broken_joints(
                cd,
                nodes,
                tets,
                bodies,
                joints,
                &change,
                ranks.as_deref_mut(),
            ) {
                return true;
            }
        }
    } else if !must_detect(cd, &nodes.x, ranks.as_deref_mut()) {
        return false;
    } else {
        cd.carried.clear();
        cd.carried.extend(0..cd.pairs.len() as u32);
    }
    // A full detection reads, and records, the positions of the nodes within reach of the
    // tets this rank computes (every node on one process), a reach the skin sets.
    if cd.skin.is_none() && cd.detector.skin == 0.0 {
        cd.detector.skin = default_skin(cd, nodes, tets, ranks.as_deref_mut());
    }
    let current = match ranks.as_deref_mut() {
        Some(r) => make_reach_current(cd, nodes, tets, r),
        None => None,
    };
    detect_all_pairs(cd, nodes, tets, bodies, joints, ranks, current);
    true
}

/// The skin when the script gives none: a quarter of the surface tets' mean extent at the
/// current positions. The extents are summed exactly ([`ExactSum`]), so the skin has the
/// same bits for any number of threads and ranks: on a decomposed model each rank sums the
/// surface tets designated to it (their nodes are current there) and the sums are added.
fn default_skin(
    cd: &ContactDetection,
    nodes: &Nodes,
    tets: &Tets,
    ranks: Option<&mut (dyn PairExchange + '_)>,
) -> Real {
    let (x, tn) = (&nodes.x, &tets.nodes);
    let mine: Vec<u32> = match &ranks {
        Some(r) => (cd.surface.iter().copied())
            .filter(|&e| r.designates(e as usize))
            .collect(),
        None => cd.surface.clone(),
    };
    let mut sum = (mine.par_iter())
        .fold(ExactSum::default, |mut s, &e| {
            s.add(Aabb::of_points(&tn[e as usize].map(|n| x[n as usize])).max_extent());
            s
        })
        .reduce(ExactSum::default, |mut a, b| {
            a.merge(&b);
            a
        });
    if let Some(r) = ranks {
        r.sum_over_ranks(&mut sum);
    }
    0.25 * sum.value() / cd.surface.len().max(1) as Real
}

/// On a rank of a decomposed model, before a full detection: make current the nodes that the
/// pairs of the tets it computes can reach, and return which nodes are current (None: every
/// node, in a model without surface tets). A pair's two
/// inflated boxes overlap, so every node of a partner of a tet with a node `o` of this rank
/// lies within e_a + e_b + skin of `o` in each coordinate (e: the tets' extents): within
/// 2·e_max + skin of this rank's nodes' box, e_max the largest extent of any tet (each rank
/// measures the tets with a node of its own, whose nodes are all current on it: a work unit
/// of stage 1 spanning ranks is read whole by each). A 1 % margin covers rounding.
fn make_reach_current(
    cd: &ContactDetection,
    nodes: &mut Nodes,
    tets: &Tets,
    r: &mut (dyn PairExchange + '_),
) -> Option<Vec<bool>> {
    let skin = cd.skin.unwrap_or(cd.detector.skin);
    if skin <= 0.0 {
        // (A model without surface tets: nothing to reach.)
        r.make_every_node_current(nodes);
        return None;
    }
    let (x, computes) = (&nodes.x, r.computes());
    let extent = (tets.nodes.par_iter().zip(computes))
        .filter(|(_, &c)| c)
        .map(|(t, _)| Aabb::of_points(&t.map(|n| x[n as usize])).max_extent())
        .reduce(|| 0.0, Real::max);
    let extent = r.largest(extent);
    let reach = 1.01 * (2.0 * extent + skin);
    Some(r.make_near_current(nodes, reach))
}

/// A full detection at the current positions (`current`: on a decomposed model, the nodes
/// current on this rank, those within reach of its own; None: every node): NBS over the surface
/// box (on a decomposed model only around the tets this rank computes, keeping its pairs),
/// then the old→new remap; records the positions.
fn detect_all_pairs(
    cd: &mut ContactDetection,
    nodes: &Nodes,
    tets: &Tets,
    bodies: &[Body],
    joints: &Joints,
    ranks: Option<&mut (dyn PairExchange + '_)>,
    current: Option<Vec<bool>>,
) {
    let x = &nodes.x;
    let tn = &tets.nodes;
    if let Some(s) = cd.skin {
        cd.detector.skin = s;
    }
    let half = 0.5 * cd.detector.skin;
    let (near, planes) = held_boxes_and_planes(cd, tn, x, half, current.as_deref());
    let continuous: Vec<bool> = bodies.iter().map(|b| b.layout != Layout::Jointed).collect();
    let filter = CandidateFilter {
        surface: &cd.surface,
        fragment: &cd.fragment,
        fragment0: &cd.fragment0,
        broken: BrokenJoints {
            seen: &cd.broken_seen,
            of_tet: &cd.joints_of_tet,
            tets: &joints.tets,
        },
        tet_nodes: tn,
        tet_body: &tets.body,
        continuous: &continuous,
        x,
        x0: &nodes.x0,
        skin: cd.detector.skin,
        planes: Some(&planes),
    };
    let computes = ranks.as_ref().map(|r| r.computes());
    let surface = &cd.surface;
    let mine = |i: u32| computes.is_none_or(|c| c[surface[i as usize] as usize]);
    std::mem::swap(&mut cd.pairs, &mut cd.old_pairs);
    match &near {
        None => nbs_pairs_of(
            &cd.boxes,
            &mut cd.detector.workspace,
            &|i, j| filter.keep(i, j),
            &mine,
            &mut cd.pairs,
        ),
        Some(near) => {
            // Only the surface tets whose nodes are current here; indices in order, so the
            // pairs stay sorted.
            let boxes: Vec<Aabb> = near.iter().map(|&i| cd.boxes[i as usize]).collect();
            nbs_pairs_of(
                &boxes,
                &mut cd.detector.workspace,
                &|a, b| filter.keep_with(near[a as usize], near[b as usize], [a, b]),
                &|a| mine(near[a as usize]),
                &mut cd.pairs,
            );
            for p in &mut cd.pairs {
                *p = p.map(|i| near[i as usize]);
            }
        }
    }
    cd.held = near;
    cd.detector.workspace.release_pair_buffers();
    cd.local = computes.is_some();
    cd.origins = origins_in(&cd.pairs, &cd.old_pairs, &cd.carried, &filter);
    cd.old_pairs = Vec::new();
    cd.carried = Vec::new();
    record_positions(cd, x, current);
    cd.detector.stale = false;
    cd.detector.detections += 1;
}

/// A full detection's boxes (into `cd.boxes`) and face planes at the positions `x`. On a
/// decomposed model (`current`: per node, whether it is current on this rank) it also returns
/// the surface tets whose nodes are current here (`near`, in index order): every partner of
/// this rank's tets is among them. Only they get their box and face planes, the planes
/// indexed as `near` (the others a box that overlaps nothing), so a rank's detection
/// computes its part of the surface, not the whole.
fn held_boxes_and_planes(
    cd: &mut ContactDetection,
    tn: &[[u32; 4]],
    x: &[Vec3],
    half: Real,
    current: Option<&[bool]>,
) -> (Option<Vec<u32>>, Vec<FacePlanes>) {
    let near: Option<Vec<u32>> = current.map(|c| {
        let surface = &cd.surface;
        (0..surface.len() as u32)
            .into_par_iter()
            .filter(|&i| {
                tn[surface[i as usize] as usize]
                    .iter()
                    .all(|&n| c[n as usize])
            })
            .collect()
    });
    let corners = |i: &u32| tn[cd.surface[*i as usize] as usize].map(|n| x[n as usize]);
    // Each element meets dozens of overlapping boxes: its face planes once, not per pair
    // (freed after the search, like NBS's pair buffers); indexed as `near` on a rank.
    let planes = match &near {
        None => {
            surface_boxes(&mut cd.boxes, &cd.surface, tn, x, half);
            let all = 0..cd.surface.len() as u32;
            all.into_par_iter()
                .map(|i| FacePlanes::of(&corners(&i)))
                .collect()
        }
        Some(near) => {
            let fresh: Vec<Aabb> = (near.par_iter())
                .map(|i| Aabb::of_points(&corners(i)).inflate(half))
                .collect();
            cd.boxes.clear();
            (cd.boxes).resize(
                cd.surface.len(),
                Aabb::of_points(&[Vec3::repeat(Real::NAN)]),
            );
            near.iter()
                .zip(fresh)
                .for_each(|(&i, b)| cd.boxes[i as usize] = b);
            near.par_iter()
                .map(|i| FacePlanes::of(&corners(i)))
                .collect()
        }
    };
    (near, planes)
}

/// The positions at a full detection (`current`: on a decomposed model, per node, whether it
/// is current on this rank; the detector keeps it).
fn record_positions(cd: &mut ContactDetection, x: &[Vec3], current: Option<Vec<bool>>) {
    // The positions at detection: on a rank only those current on it (the others are not
    // known here; the skin test and an incremental detection read only these, and the
    // ranks share them when the whole model is read), so the record is its part too.
    let at = &mut cd.detector.x_at_detection;
    match &current {
        None => {
            at.clear();
            at.extend_from_slice(x);
        }
        Some(c) => {
            at.resize(x.len(), Vec3::repeat(Real::NAN));
            (at.par_iter_mut().zip(x).zip(c))
                .filter(|(_, &c)| c)
                .for_each(|((a, x), _)| *a = *x);
        }
    }
    match current {
        // (The skin test's copy in surface order is for one process: a rank tests its own
        // surface nodes, from `x_at_detection`.)
        None => {
            cd.record_surface_positions();
            cd.detector.current.clear();
        }
        Some(c) => {
            cd.detector.surface_x.clear();
            cd.detector.current = c;
        }
    }
}

/// Where each pair of the new list `pairs` comes from: kept from the old list `old` (its
/// index before the surface refresh, `carried`), or new. Both lists are sorted.
fn origins_in(
    pairs: &[[u32; 2]],
    old: &[[u32; 2]],
    carried: &[u32],
    filter: &CandidateFilter,
) -> Vec<PairOrigin> {
    let mut k = 0;
    pairs
        .iter()
        .map(|p| {
            while k < old.len() && old[k][0] < p[0] {
                k += 1;
            }
            let mut q = k;
            while q < old.len() && old[q][0] == p[0] {
                if old[q][1] == p[1] {
                    return PairOrigin::Kept(carried[q]);
                }
                q += 1;
            }
            filter.new_pair(p[0], p[1])
        })
        .collect()
}

/// The box of each surface tet at the positions `x`, inflated by `half` (skin/2).
fn surface_boxes(boxes: &mut Vec<Aabb>, surface: &[u32], tn: &[[u32; 4]], x: &[Vec3], half: Real) {
    boxes.clear();
    boxes.par_extend(
        surface
            .par_iter()
            .map(|&e| Aabb::of_points(&tn[e as usize].map(|n| x[n as usize])).inflate(half)),
    );
}

/// The surface, fragments and broken faces before a refresh.
struct Topology {
    surface: Vec<u32>,
    fragment: Vec<u32>,
    broken: Vec<bool>,
}

/// What a surface refresh changed, when an incremental detection can take it in: the tets
/// that joined the surface and the faces of the joints that broke.
struct SurfaceChange {
    /// The surface indices of the tets that joined it: the surface's end (it started at
    /// `joined.start` tets).
    joined: std::ops::Range<u32>,
    /// The newly broken joints' tet pairs (lower id first), sorted, with the joint id.
    new_faces: Vec<([u32; 2], u32)>,
}

/// What a refresh from scratch changed against `before`: None (a full detection) when a
/// fragment split (pairs across the whole separating crack become candidates), a tet left
/// the surface, or too many joined.
fn surface_change(
    cd: &ContactDetection,
    joints: &Joints,
    before: &Topology,
) -> Option<SurfaceChange> {
    if cd.surface.len() < before.surface.len()
        || cd.surface.len() - before.surface.len() > INCREMENTAL_LIMIT
        || !crate::fracture::same_partition(&cd.fragment, &before.fragment)
    {
        return None;
    }
    // The tets that stayed keep their order, the newcomers follow (`refresh_surface`):
    // unless a tet left, the list before is the start of the list after.
    let n_before = before.surface.len();
    if cd.surface[..n_before] != before.surface[..] {
        return None;
    }
    if before.broken.len() != cd.broken_seen.len() {
        return None;
    }
    let new_faces = (0..cd.broken_seen.len())
        .filter(|&j| cd.broken_seen[j] && !before.broken[j])
        .map(|j| {
            let [a, b] = joints.tets[j];
            ([a.min(b), a.max(b)], j as u32)
        })
        .collect();
    Some(SurfaceChange {
        joined: n_before as u32..cd.surface.len() as u32,
        new_faces,
    })
}

/// Largest number of tets joining the surface at one refresh for which the incremental
/// detection is used: it tests each against every surface box (a few ns each), a full
/// detection costs ~1–3 µs per surface tet.
const INCREMENTAL_LIMIT: usize = 256;

/// Joints broke since the last detection, at positions x(t₀): instead of detecting anew,
/// add the candidate pairs the breaks made possible — pairs of a tet that joined the surface,
/// and the two sides of each newly broken joint — found as a detection at t₀ would find them
/// (boxes and nearness from the positions at t₀, the skin test still measured from t₀). The
/// list is then the one a full detection at t₀ with the new topology gives (breaking only
/// lifts exclusions), so it holds every pair that can touch until the skin test fires.
/// `change`: the tets that joined and the faces that broke ([`SurfaceChange`]; when there
/// is none, there can be no incremental detection). Declines (returns false, for a full
/// detection) when a surface node moved more than skin/2 since t₀.
fn add_pairs_of_broken_joints(
    cd: &mut ContactDetection,
    nodes: &Nodes,
    tets: &Tets,
    bodies: &[Body],
    joints: &Joints,
    change: &SurfaceChange,
    mut ranks: Option<&mut (dyn PairExchange + '_)>,
) -> bool {
    let joined = change.joined.clone();
    if surface_moved(cd, &nodes.x, ranks.as_deref_mut())
        || joined_moved(cd, &nodes.x, tets, joined.clone(), ranks.as_deref_mut())
    {
        return false;
    }
    let tn = &tets.nodes;
    let half = 0.5 * cd.detector.skin;
    boxes_after_joining(cd, joined.start as usize, tn, half);
    let x = &cd.detector.x_at_detection;
    let continuous: Vec<bool> = bodies.iter().map(|b| b.layout != Layout::Jointed).collect();
    let filter = CandidateFilter {
        surface: &cd.surface,
        fragment: &cd.fragment,
        fragment0: &cd.fragment0,
        broken: BrokenJoints {
            seen: &cd.broken_seen,
            of_tet: &cd.joints_of_tet,
            tets: &joints.tets,
        },
        tet_nodes: tn,
        tet_body: &tets.body,
        continuous: &continuous,
        x,
        x0: &nodes.x0,
        skin: cd.detector.skin,
        planes: None,
    };
    let boxes = &cd.boxes;
    let test = |i: u32, j: u32| {
        let (a, b) = (i.min(j), i.max(j));
        (a != b && boxes[a as usize].overlaps(&boxes[b as usize]) && filter.keep(a, b))
            .then_some([a, b])
    };
    let is_joined = |i: u32| joined.contains(&i);
    // On a decomposed model, only the pairs with a tet this rank computes.
    let computes = ranks.as_ref().map(|r| r.computes());
    let surface = &cd.surface;
    let mine = |i: u32| computes.is_none_or(|c| c[surface[i as usize] as usize]);
    // A rank holds the positions at t₀ of the nodes within reach of its own: the tets it can
    // pair with (see `make_reach_current`).
    let held_at_t0 = |i: u32| {
        let c = &cd.detector.current;
        c.is_empty()
            || tn[surface[i as usize] as usize]
                .iter()
                .all(|&n| c[n as usize])
    };
    // Every held surface tet whose box overlaps the joined tets' common box, against each
    // joined tet it may pair with (of those whose extent can reach it, `JoinedTets`): a
    // joined tet against every surface tet (a pair of two joined tets once, from the lower),
    // a joined tet this rank does not compute only against those it does. On a rank, the
    // held tets are listed (`ContactDetection::held`): the scan is over its part.
    let held_joined: Vec<u32> = joined.clone().filter(|&n| held_at_t0(n)).collect();
    let index = JoinedTets::new(boxes, held_joined.iter().copied());
    let (is_joined, test, mine, index) = (&is_joined, &test, &mine, &index);
    let pairs_of = |i: u32| {
        (index.reaching(&boxes[i as usize]).iter().copied())
            .filter(move |&n| (mine(n) || mine(i)) && (!is_joined(i) || i > n))
            .filter_map(move |n| test(n, i))
    };
    let mut added: Vec<[u32; 2]> = match (index.common, &cd.held) {
        (None, _) => Vec::new(),
        (Some(common), None) => (0..cd.surface.len() as u32)
            .into_par_iter()
            .filter(|&i| boxes[i as usize].overlaps(&common))
            .flat_map_iter(pairs_of)
            .collect(),
        (Some(common), Some(held)) => (held.par_iter().chain(&held_joined).copied())
            .filter(|&i| boxes[i as usize].overlaps(&common))
            .flat_map_iter(pairs_of)
            .collect(),
    };
    // The two sides of each newly broken joint, both on the surface before.
    let index_of = |e: u32| Some(cd.surface_index[e as usize]).filter(|&i| i != u32::MAX);
    for (pair, _) in &change.new_faces {
        let (Some(i), Some(j)) = (index_of(pair[0]), index_of(pair[1])) else {
            continue;
        };
        if !is_joined(i) && !is_joined(j) && (mine(i) || mine(j)) && held_at_t0(i) && held_at_t0(j)
        {
            added.extend(test(i, j));
        }
    }
    added.sort_unstable();
    added.dedup();
    // Merge into the renumbered list (sorted), in place from the back; a kept pair carries
    // its history over. (A pair added was no candidate before: a joined tet was not on the
    // surface, and the two sides of an intact joint are excluded. Checked all the same.)
    added.retain(|p| cd.pairs.binary_search(p).is_err());
    cd.origins.clear();
    cd.origins
        .resize(cd.pairs.len() + added.len(), PairOrigin::Kept(0));
    let (origins, carried) = (&mut cd.origins, &cd.carried);
    merge_in_place(&mut cd.pairs, &added, |k, from| {
        origins[k] = match from {
            Ok(a) => PairOrigin::Kept(carried[a]),
            Err(b) => filter.new_pair(added[b][0], added[b][1]),
        }
    });
    cd.carried = Vec::new();
    if let Some(held) = &mut cd.held {
        held.extend_from_slice(&held_joined);
    }
    cd.detector.stale = false;
    cd.detector.incremental += 1;
    true
}

/// The tets that joined the surface at one refresh (surface indices), sorted along the
/// longest axis of their common box, so that a surface box is tested only against those
/// whose extent along it can reach it: the joined tets of a step lie along cracks that can
/// span the model (on the 55k-tet impact a surface box in the common box was tested against
/// 12.5 joined tets on average, of which it overlapped far fewer; 94 M box tests became 3.8 M).
struct JoinedTets {
    /// Sorted by their boxes' lower end along `axis`.
    tets: Vec<u32>,
    lower_ends: Vec<Real>,
    /// The largest extent of their boxes along `axis`.
    widest: Real,
    axis: usize,
    /// Their common box (None without tets).
    common: Option<Aabb>,
}

impl JoinedTets {
    fn new(boxes: &[Aabb], joined: impl Iterator<Item = u32>) -> Self {
        let mut tets: Vec<u32> = joined.collect();
        let common = (tets.iter())
            .map(|&n| boxes[n as usize])
            .reduce(|a, b| a.union(&b));
        let axis = common.map_or(0, |c| (c.hi - c.lo).imax());
        tets.sort_unstable_by(|&a, &b| {
            boxes[a as usize].lo[axis].total_cmp(&boxes[b as usize].lo[axis])
        });
        let lower_ends = (tets.iter()).map(|&n| boxes[n as usize].lo[axis]).collect();
        let widest = (tets.iter())
            .map(|&n| boxes[n as usize].hi[axis] - boxes[n as usize].lo[axis])
            .fold(0.0, Real::max);
        JoinedTets {
            tets,
            lower_ends,
            widest,
            axis,
            common,
        }
    }

    /// The joined tets whose lower end along the axis lies within [lo − widest, hi] of box
    /// `b`'s: the only ones whose extent can overlap it (the lower bound widened by a few
    /// roundings of the subtraction).
    fn reaching(&self, b: &Aabb) -> &[u32] {
        let (lo, hi) = (b.lo[self.axis], b.hi[self.axis]);
        let margin = 4.0 * Real::EPSILON * (lo.abs() + self.widest);
        let first = (self.lower_ends).partition_point(|&l| l < lo - self.widest - margin);
        let last = self.lower_ends.partition_point(|&l| l <= hi);
        &self.tets[first..last.max(first)]
    }
}

/// On a decomposed model whose ranks answered the step's skin test at their first meeting,
/// before the surface took in the tets that joined it: some node of a joined tet (`joined`:
/// surface indices) moved more than skin/2 since the last detection (each rank tests those
/// it owns; one collective). One process tests them with the rest of the surface
/// ([`surface_moved`] reads the refreshed list), so both decline the incremental detection
/// alike. False otherwise.
fn joined_moved(
    cd: &ContactDetection,
    x: &[Vec3],
    tets: &Tets,
    joined: std::ops::Range<u32>,
    ranks: Option<&mut (dyn PairExchange + '_)>,
) -> bool {
    let Some(r) = ranks.filter(|r| r.skin_test_answered().is_some()) else {
        return false;
    };
    let (owned, chunk) = r.owned_chunks();
    let (at, limit) = (
        &cd.detector.x_at_detection,
        (0.5 * cd.detector.skin).powi(2),
    );
    let mine = joined.into_iter().any(|i| {
        tets.nodes[cd.surface[i as usize] as usize]
            .iter()
            .any(|&n| {
                owned[n as usize / chunk] && (x[n as usize] - at[n as usize]).norm_squared() > limit
            })
    });
    r.largest(if mine { 1.0 } else { 0.0 }) > 0.0
}

/// The inflated boxes at the positions of the last detection, t₀, of the surface after the
/// tets from `n_before` on joined it (at its end): the tets that stayed keep the last
/// detection's boxes (the same positions, skin and function), so only the joined tets' are
/// computed. (All anew when the boxes are not the last detection's surface's.)
fn boxes_after_joining(cd: &mut ContactDetection, n_before: usize, tn: &[[u32; 4]], half: Real) {
    let x = &cd.detector.x_at_detection;
    if cd.boxes.len() != n_before {
        surface_boxes(&mut cd.boxes, &cd.surface, tn, x, half);
        return;
    }
    let joined = &cd.surface[n_before..];
    (cd.boxes).extend(
        (joined.iter())
            .map(|&e| Aabb::of_points(&tn[e as usize].map(|n| x[n as usize])).inflate(half)),
    );
}

/// The joints broken and taken in by the last surface refresh, and each tet's joints.
#[derive(Clone, Copy)]
struct BrokenJoints<'a> {
    seen: &'a [bool],
    of_tet: &'a (Vec<u32>, Vec<u32>),
    tets: &'a [[u32; 2]],
}

/// Which box pairs become candidates (see the module doc), over surface indices.
struct CandidateFilter<'a> {
    surface: &'a [u32],
    fragment: &'a [u32],
    fragment0: &'a [u32],
    broken: BrokenJoints<'a>,
    tet_nodes: &'a [[u32; 4]],
    tet_body: &'a [u32],
    continuous: &'a [bool],
    x: &'a [Vec3],
    x0: &'a [Vec3],
    skin: Real,
    /// The surface elements' face planes at `x` (a full detection), or None (computed per
    /// pair).
    planes: Option<&'a [FacePlanes]>,
}

/// A tetrahedron's corners and its faces' inward unit normals (zero for a degenerate face),
/// face f through corner `TET_FACES[f][0]`: what [`CandidateFilter::near`] tests a pair
/// with, computed once per surface element and detection instead of once per box overlap.
#[derive(Clone, Copy, Debug, Default)]
pub struct FacePlanes {
    corners: [Vec3; 4],
    normals: [Vec3; 4],
}

impl FacePlanes {
    fn of(p: &[Vec3; 4]) -> Self {
        let inward = crate::math::tet_volume(&p[0], &p[1], &p[2], &p[3]) >= 0.0;
        let normals = crate::mesh::TET_FACES.map(|f| {
            let nrm = (p[f[1]] - p[f[0]]).cross(&(p[f[2]] - p[f[0]]));
            let len = nrm.norm();
            if len == 0.0 {
                Vec3::zeros()
            } else if inward {
                nrm / len
            } else {
                -nrm / len
            }
        });
        FacePlanes {
            corners: *p,
            normals,
        }
    }

    /// Some face plane has all of `q` more than `skin` outside it (a degenerate face, with
    /// a zero normal, never separates: 0 > skin fails for skin ≥ 0).
    #[inline]
    fn separates(&self, q: &[Vec3; 4], skin: Real) -> bool {
        crate::mesh::TET_FACES
            .iter()
            .zip(&self.normals)
            .any(|(f, nrm)| {
                let p0 = self.corners[f[0]];
                q.iter().all(|v| (v - p0).dot(nrm) > skin)
            })
    }
}

impl CandidateFilter<'_> {
    /// No face plane of one tet has the whole other tet more than a skin outside it (else
    /// they stay apart until the next detection: each moves < skin/2).
    fn near(&self, a: u32, b: u32) -> bool {
        let (tn, x) = (self.tet_nodes, self.x);
        let pa = tn[a as usize].map(|n| x[n as usize]);
        let pb = tn[b as usize].map(|n| x[n as usize]);
        let (fa, fb) = (FacePlanes::of(&pa), FacePlanes::of(&pb));
        !(fa.separates(&pb, self.skin) || fb.separates(&pa, self.skin))
    }

    /// [`CandidateFilter::near`] of surface elements `i` and `j` from their planes
    /// precomputed at these positions (the same arithmetic, so the same answer).
    fn near_by_planes(&self, planes: &[FacePlanes], i: u32, j: u32) -> bool {
        let (pi, pj) = (&planes[i as usize], &planes[j as usize]);
        !(pi.separates(&pj.corners, self.skin) || pj.separates(&pi.corners, self.skin))
    }

    /// Reference positions the two tets share (0 for strangers).
    fn shared(&self, a: u32, b: u32) -> usize {
        let (na, nb) = (self.tet_nodes[a as usize], self.tet_nodes[b as usize]);
        let x0 = self.x0;
        na.iter()
            .filter(|p| nb.iter().any(|q| x0[*q as usize] == x0[**p as usize]))
            .count()
    }

    fn broken_joint(&self, a: u32, b: u32) -> Option<u32> {
        let BrokenJoints { seen, of_tet, tets } = self.broken;
        let of_a = &of_tet.1[of_tet.0[a as usize] as usize..of_tet.0[a as usize + 1] as usize];
        (of_a.iter().copied()).find(|&j| seen[j as usize] && tets[j as usize].contains(&b))
    }

    /// Surface elements `i` and `j` (overlapping boxes) are a candidate pair: near, and of
    /// different fragments, or of one fragment but neither one continuous body nor
    /// neighbours through an intact joint or a shared edge or node. The topological tests
    /// come first: they are cheaper than [`CandidateFilter::near`] and reject most box
    /// overlaps of an intact body (its neighbours').
    fn keep(&self, i: u32, j: u32) -> bool {
        self.keep_with(i, j, [i, j])
    }

    /// [`CandidateFilter::keep`] with the two elements' face planes at `slots` of `planes`
    /// (on a rank, the planes of the surface tets it holds only).
    fn keep_with(&self, i: u32, j: u32, slots: [u32; 2]) -> bool {
        let (a, b) = (self.surface[i as usize], self.surface[j as usize]);
        let near = || match self.planes {
            Some(planes) => self.near_by_planes(planes, slots[0], slots[1]),
            None => self.near(a, b),
        };
        if self.fragment[a as usize] != self.fragment[b as usize] {
            return near();
        }
        // A continuous body does not contact itself.
        let body = self.tet_body[a as usize];
        if body == self.tet_body[b as usize] && self.continuous[body as usize] {
            return false;
        }
        let topology = match self.shared(a, b) {
            0 => true,
            3 => self.broken_joint(a, b).is_some(),
            _ => false,
        };
        topology && near()
    }

    /// The origin of a pair (surface indices) that was not a candidate before.
    fn new_pair(&self, i: u32, j: u32) -> PairOrigin {
        let (a, b) = (self.surface[i as usize], self.surface[j as usize]);
        let neighbours =
            self.fragment0[a as usize] == self.fragment0[b as usize] && self.shared(a, b) > 0;
        let joint = if neighbours {
            self.broken_joint(a, b).unwrap_or(u32::MAX)
        } else {
            u32::MAX
        };
        PairOrigin::New { neighbours, joint }
    }
}

/// Surface tets, their nodes, fragments and broken faces. When the surface list changes, the
/// pairs are renumbered onto it (pairs of tets that left the surface are dropped) and
/// `carried` remembers each one's index in the list before.
fn refresh_surface(
    cd: &mut ContactDetection,
    nodes: &Nodes,
    tets: &Tets,
    bodies: &[Body],
    joints: &Joints,
) {
    let mut free = vec![0i32; tets.len()];
    for b in bodies {
        match b.layout {
            Layout::Jointed => free[b.tets.clone()].iter_mut().for_each(|f| *f = 4),
            Layout::Continuous | Layout::Rigid => {
                for f in &b.boundary {
                    free[f.tet as usize] += 1;
                }
            }
        }
    }
    for j in 0..joints.len() {
        let [a, b] = joints.tets[j];
        if !joints.broken[j] {
            free[a as usize] -= 1;
            free[b as usize] -= 1;
        }
    }
    // The tets that stay on the surface keep their order, the newcomers follow in id order
    // (the order refreshes from breaks give: see `ContactDetection::surface`).
    let mut listed = vec![false; tets.len()];
    let mut surface: Vec<u32> = (cd.surface.iter().copied())
        .filter(|&e| (e as usize) < tets.len() && free[e as usize] > 0)
        .inspect(|&e| listed[e as usize] = true)
        .collect();
    surface.extend((0..tets.len() as u32).filter(|&e| free[e as usize] > 0 && !listed[e as usize]));
    cd.carried.clear();
    if surface != cd.surface {
        let mut new_index = vec![u32::MAX; tets.len()];
        for (i, &e) in surface.iter().enumerate() {
            new_index[e as usize] = i as u32;
        }
        let mut moved: Vec<([u32; 2], u32)> = cd
            .pairs
            .iter()
            .enumerate()
            .filter_map(|(k, p)| {
                let (a, b) = (
                    new_index[cd.surface[p[0] as usize] as usize],
                    new_index[cd.surface[p[1] as usize] as usize],
                );
                (a != u32::MAX && b != u32::MAX).then_some(([a.min(b), a.max(b)], k as u32))
            })
            .collect();
        moved.sort_unstable_by_key(|m| m.0);
        cd.pairs = moved.iter().map(|m| m.0).collect();
        cd.carried.extend(moved.iter().map(|m| m.1));
        cd.surface = surface;
    } else {
        cd.carried.extend(0..cd.pairs.len() as u32);
    }
    let mut sn: Vec<u32> = cd
        .surface
        .iter()
        .flat_map(|&e| tets.nodes[e as usize])
        .collect();
    sn.sort_unstable();
    sn.dedup();
    cd.on_surface.clear();
    cd.on_surface.resize(nodes.len(), false);
    sn.iter().for_each(|&n| cd.on_surface[n as usize] = true);
    cd.surface_nodes = sn;
    cd.surface_index.clear();
    cd.surface_index.resize(tets.len(), u32::MAX);
    for (i, &e) in cd.surface.iter().enumerate() {
        cd.surface_index[e as usize] = i as u32;
    }
    cd.own_surface_nodes = None;
    cd.surface_nodes_joined.clear();
    cd.record_surface_positions();
    cd.fragments = FragmentTracker::build(&tets.nodes, &joints.tets, &joints.broken, nodes.len());
    cd.fragment = cd.fragments.labels();
    if cd.fragment0.len() != tets.len() {
        cd.fragment0 = cd.fragment.clone();
    }
    cd.broken_seen = joints.broken.clone();
    cd.joints_of_tet = joints_of_tets(&joints.tets, tets.len());
    cd.free_faces = free;
    cd.newly_broken.clear();
    cd.rebuild = false;
    cd.surface_stale = false;
    cd.detector.stale = true;
}

/// The surface refresh after the joints `cd.newly_broken` broke, from them alone: the same
/// lists as [`refresh_surface`] (tests/contact.rs,
/// `incremental_detection_after_fracture_equals_a_full_detection`) without its passes over
/// every tet and joint. A broken joint frees a face of each of its two tets: a tet with its
/// first free face joins the surface (none leaves it), and the pairs are renumbered onto
/// the longer list, in their order. The fragments are split from the breaks
/// ([`FragmentTracker::split`]). Returns what changed, when an incremental detection can
/// take it in (not when a fragment split off, or too many tets joined).
fn refresh_after_breaks(
    cd: &mut ContactDetection,
    tets: &Tets,
    joints: &Joints,
) -> Option<SurfaceChange> {
    let mut newly = std::mem::take(&mut cd.newly_broken);
    newly.sort_unstable();
    newly.dedup();
    // (Only joints that are broken, once: a joint given again is in the list already.)
    newly.retain(|&j| joints.broken[j as usize] && !cd.broken_seen[j as usize]);
    let (mut joined_tets, mut new_faces) = (Vec::new(), Vec::with_capacity(newly.len()));
    for &j in &newly {
        let [a, b] = joints.tets[j as usize];
        for t in [a, b] {
            let free = &mut cd.free_faces[t as usize];
            *free += 1;
            if *free == 1 {
                joined_tets.push(t);
            }
        }
        new_faces.push(([a.min(b), a.max(b)], j));
        cd.broken_seen[j as usize] = true;
    }
    joined_tets.sort_unstable();
    new_faces.sort_unstable();
    // The joined tets go to the surface's end: the others, and so the pairs, keep their
    // indices.
    let n_before = cd.surface.len();
    let joined = n_before as u32..(n_before + joined_tets.len()) as u32;
    for (&e, i) in joined_tets.iter().zip(joined.clone()) {
        cd.surface_index[e as usize] = i;
    }
    cd.surface.extend_from_slice(&joined_tets);
    cd.carried.clear();
    cd.carried.extend(0..cd.pairs.len() as u32);
    // Their nodes new to the surface, and those nodes' positions at the last detection.
    let mut nodes: Vec<u32> = (joined_tets.iter())
        .flat_map(|&e| tets.nodes[e as usize])
        .filter(|&n| !cd.on_surface[n as usize])
        .collect();
    nodes.sort_unstable();
    nodes.dedup();
    add_surface_nodes(cd, &nodes);
    if cd.own_surface_nodes.is_some() {
        // (For the rank's list of its own, at its next skin test.)
        cd.surface_nodes_joined.extend_from_slice(&nodes);
    }
    let split = cd
        .fragments
        .split(&newly, &joints.tets, &joints.broken, &mut cd.fragment);
    cd.newly_broken = newly;
    cd.newly_broken.clear();
    cd.refreshes_from_breaks += 1;
    cd.surface_stale = false;
    cd.detector.stale = true;
    (split == 0 && joined.len() <= INCREMENTAL_LIMIT).then_some(SurfaceChange { joined, new_faces })
}

/// `nodes` (none on the surface yet) join the surface nodes at their end, with their
/// positions at the last detection when those are kept (the lists
/// [`ContactDetection::record_surface_positions`] makes, without reading every surface
/// node's position again).
fn add_surface_nodes(cd: &mut ContactDetection, nodes: &[u32]) {
    nodes.iter().for_each(|&n| cd.on_surface[n as usize] = true);
    cd.surface_nodes.extend_from_slice(nodes);
    let d = &mut cd.detector;
    let at = &d.x_at_detection;
    let n_before = cd.surface_nodes.len() - nodes.len();
    if d.surface_x.len() == n_before && nodes.iter().all(|&n| (n as usize) < at.len()) {
        d.surface_x.extend(nodes.iter().map(|&n| at[n as usize]));
    } else if !d.surface_x.is_empty() {
        cd.record_surface_positions();
    }
    // (Left empty when it was: on a rank, or after a restart, the skin test reads
    // `x_at_detection`.)
}

/// Each tet's joints, in joint order (CSR: offsets per tet, then the joint ids).
fn joints_of_tets(joint_tets: &[[u32; 2]], n_tets: usize) -> (Vec<u32>, Vec<u32>) {
    let mut start = vec![0u32; n_tets + 1];
    joint_tets
        .iter()
        .flatten()
        .for_each(|&e| start[e as usize + 1] += 1);
    for e in 0..n_tets {
        start[e + 1] += start[e];
    }
    let mut next = start.clone();
    let mut ids = vec![0u32; 2 * joint_tets.len()];
    for (j, pair) in joint_tets.iter().enumerate() {
        for &e in pair {
            ids[next[e as usize] as usize] = j as u32;
            next[e as usize] += 1;
        }
    }
    (start, ids)
}

/// Merges the sorted `added` into the sorted `list`, in place from the back (no list is
/// allocated), and tells `place(k, from)` where each item went: index `k` of the merged list,
/// from `Ok(a)` (`list[a]`) or `Err(b)` (`added[b]`), in decreasing `k`, so a side array can
/// follow along in place. No item of `added` may be in `list`.
fn merge_in_place<T: Ord + Copy + Default>(
    list: &mut Vec<T>,
    added: &[T],
    mut place: impl FnMut(usize, Result<usize, usize>),
) {
    let (mut a, mut b) = (list.len(), added.len());
    list.resize(a + b, T::default());
    for k in (0..a + b).rev() {
        if b == 0 || (a > 0 && list[a - 1] > added[b - 1]) {
            a -= 1;
            list[k] = list[a];
            place(k, Ok(a));
        } else {
            b -= 1;
            list[k] = added[b];
            place(k, Err(b));
        }
    }
}
