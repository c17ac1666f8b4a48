//! Fragments: the connected components of tetrahedra over shared nodes and intact joints,
//! kept up to date as joints break without relabelling the whole model.
//!
//! **Grains.** Tets that share a node are joined for good (nodes are never split), so the
//! components over shared nodes alone, the *grains*, are computed once: a continuous body
//! is one grain (or a few, if its mesh is in pieces), a tet of a jointed body is one. A
//! fragment is then a component of the grain graph whose edges are the intact joints.
//!
//! **Splits, found from the breaks alone.** Breaking joints only removes edges. A fragment
//! that falls apart has a broken joint on the border of each of its pieces, so searching
//! from the grains on either side of this step's broken joints finds every piece. One
//! breadth-first search per such grain runs in turns, one grain each: two searches that
//! meet are in one piece and go on as one; a piece whose searches all ran out of grains is
//! a whole piece, cut off, and takes a fresh label. When one piece is left searching it is
//! the rest of the fragment and keeps the old label. A break that splits nothing (the usual
//! case: the joint's two tets are still joined round the crack tip) costs the few grains
//! its two searches visit before they meet; a split costs about the grains of the smaller
//! pieces, never the whole model.
//!
//! **Labels** are unique but not dense: a fresh label is the next unused number. Stage 4
//! compares them only for equality ([`FragmentTracker::labels`]). The dense numbering the
//! output shows ([`super::fragments`]: 0.. in order of each fragment's first tet) is made
//! from scratch when asked.

use crate::math::Lists;

/// Union–find over `0..n` with path halving; the root of a set is its lowest member.
fn find(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        parent[i as usize] = parent[parent[i as usize] as usize];
        i = parent[i as usize];
    }
    i
}

fn union(parent: &mut [u32], a: u32, b: u32) -> u32 {
    let (ra, rb) = (find(parent, a), find(parent, b));
    let (lo, hi) = (ra.min(rb), ra.max(rb));
    parent[hi as usize] = lo;
    lo
}

/// Two label lists make the same partition: the same tets share labels (whatever the
/// labels' values).
pub fn same_partition(a: &[u32], b: &[u32]) -> bool {
    let mut ab = std::collections::HashMap::new();
    let mut ba = std::collections::HashMap::new();
    a.len() == b.len()
        && a.iter()
            .zip(b)
            .all(|(x, y)| *ab.entry(*x).or_insert(*y) == *y && *ba.entry(*y).or_insert(*x) == *x)
}

/// Fragment labels of a model's tets, updated as joints break ([`FragmentTracker::split`]).
#[derive(Clone, Debug, Default)]
pub struct FragmentTracker {
    /// Grain of each tet.
    grain: Vec<u32>,
    /// Tets of each grain.
    grain_tets: Lists<u32>,
    /// Joints at each grain (its tets' joints to other grains, both sides): [joint, the
    /// grain on the other side].
    grain_joints: Lists<[u32; 2]>,
    /// Fragment label of each grain.
    grain_label: Vec<u32>,
    next_label: u32,
    /// Fragments (distinct labels).
    fragment_count: usize,
    /// Splits whose searches ran over their budget, so that every fragment was labelled anew.
    pub relabelled_all: u64,
    /// Per grain, during a split: the search that visited it, plus one (0: none).
    visited_by: Vec<u32>,
}

impl FragmentTracker {
    /// The labels of a model with tets `tet_nodes` (node ids below `n_nodes`) and `joints`:
    /// the dense numbering of [`super::fragments`].
    pub fn build(
        tet_nodes: &[[u32; 4]],
        joint_tets: &[[u32; 2]],
        broken: &[bool],
        n_nodes: usize,
    ) -> Self {
        let n_tets = tet_nodes.len();
        // Grains: components over shared nodes, numbered in order of first tet.
        let mut parent: Vec<u32> = (0..n_tets as u32).collect();
        let mut first_at = vec![u32::MAX; n_nodes];
        for (e, t) in tet_nodes.iter().enumerate() {
            for &n in t {
                match first_at[n as usize] {
                    u32::MAX => first_at[n as usize] = e as u32,
                    f => {
                        union(&mut parent, f, e as u32);
                    }
                }
            }
        }
        let mut grain = vec![u32::MAX; n_tets];
        let mut n_grains = 0u32;
        for e in 0..n_tets {
            let r = find(&mut parent, e as u32) as usize;
            // The root is the lowest tet of its grain: numbered when first met.
            if r == e {
                grain[e] = n_grains;
                n_grains += 1;
            } else {
                grain[e] = grain[r];
            }
        }
        let ng = n_grains as usize;
        let grain_tets = Lists::from_pairs(ng, (0..n_tets as u32).map(|e| (grain[e as usize], e)));
        let across = |j: usize| {
            let [a, b] = joint_tets[j];
            let (ga, gb) = (grain[a as usize], grain[b as usize]);
            (ga != gb).then_some((ga, gb, j as u32))
        };
        let grain_joints = Lists::from_pairs(
            ng,
            (0..joint_tets.len())
                .filter_map(across)
                .flat_map(|(ga, gb, j)| [(ga, [j, gb]), (gb, [j, ga])]),
        );
        let mut tracker = FragmentTracker {
            grain,
            grain_tets,
            grain_joints,
            grain_label: vec![0; ng],
            next_label: 0,
            fragment_count: 0,
            relabelled_all: 0,
            visited_by: vec![0; ng],
        };
        tracker.label_grains(broken);
        tracker
    }

    /// Fragments: the components of grains over intact joints, numbered in order of first
    /// tet (grains are numbered so, and a component's root is its lowest grain).
    fn label_grains(&mut self, broken: &[bool]) {
        let ng = self.grain_label.len();
        let mut parent: Vec<u32> = (0..ng as u32).collect();
        for g in 0..ng as u32 {
            for &[j, h] in self.grain_joints.of(g) {
                if h > g && !broken[j as usize] {
                    union(&mut parent, g, h);
                }
            }
        }
        self.next_label = 0;
        for g in 0..ng {
            let r = find(&mut parent, g as u32) as usize;
            self.grain_label[g] = if r == g {
                self.next_label += 1;
                self.next_label - 1
            } else {
                self.grain_label[r]
            };
        }
        self.fragment_count = self.next_label as usize;
    }

    /// The fragment label of each tet: equal for two tets exactly when they are in one
    /// fragment ([`FragmentTracker::split`] keeps such a list up to date).
    pub fn labels(&self) -> Vec<u32> {
        self.grain
            .iter()
            .map(|&g| self.grain_label[g as usize])
            .collect()
    }

    /// Bytes held (capacity).
    pub fn bytes(&self) -> usize {
        let lists = |l: &Lists<u32>| (l.start.capacity() + l.items.capacity()) * 4;
        lists(&self.grain_tets)
            + self.grain_joints.start.capacity() * 4
            + self.grain_joints.items.capacity() * 8
            + (self.grain.capacity() + self.grain_label.capacity() + self.visited_by.capacity()) * 4
    }

    /// Built for a model of `n_tets` tets and `n_joints` joints.
    pub fn fits(&self, n_tets: usize, n_joints: usize) -> bool {
        self.grain.len() == n_tets
            && self.grain_joints.items.len() <= 2 * n_joints
            && self.visited_by.len() == self.grain_label.len()
    }

    /// `newly_broken` joints broke (their `broken` flags are set): split the fragments they
    /// cut apart, and relabel their tets in `tet_labels` (the tracker's [`labels`] before).
    /// Returns the number of pieces that were cut off (0: no fragment split). When the
    /// searches would visit more than a quarter of the grains, every fragment is labelled
    /// anew instead, in one pass over the grains and joints.
    ///
    /// [`labels`]: FragmentTracker::labels
    pub fn split(
        &mut self,
        newly_broken: &[u32],
        joint_tets: &[[u32; 2]],
        broken: &[bool],
        tet_labels: &mut [u32],
    ) -> usize {
        // The breaks inside a fragment: (label, grains on either side).
        let mut breaks: Vec<(u32, u32, u32)> = Vec::new();
        for &j in newly_broken {
            let [a, b] = joint_tets[j as usize];
            let (ga, gb) = (self.grain[a as usize], self.grain[b as usize]);
            let la = self.grain_label[ga as usize];
            if ga != gb && la == self.grain_label[gb as usize] {
                breaks.push((la, ga.min(gb), ga.max(gb)));
            }
        }
        breaks.sort_unstable();
        breaks.dedup();
        let before = self.fragment_count;
        let mut budget = (self.grain_label.len() / 4).max(1024);
        for group in breaks.chunk_by(|a, b| a.0 == b.0) {
            // The searches start from the grains beside the breaks, ascending.
            let mut sources: Vec<u32> = group.iter().flat_map(|b| [b.1, b.2]).collect();
            sources.sort_unstable();
            sources.dedup();
            let at = |g: u32| sources.binary_search(&g).unwrap_or_default() as u32;
            let sides: Vec<[u32; 2]> = group.iter().map(|b| [at(b.1), at(b.2)]).collect();
            if !self.split_fragment(&sources, &sides, broken, tet_labels, &mut budget) {
                // The searches would cost about what labelling every grain anew does.
                self.relabel_all(broken, tet_labels);
                break;
            }
        }
        self.fragment_count - before
    }

    /// Every fragment labelled anew from the intact joints (as [`FragmentTracker::build`]
    /// does, from the grains it made).
    fn relabel_all(&mut self, broken: &[bool], tet_labels: &mut [u32]) {
        self.label_grains(broken);
        for (l, &g) in tet_labels.iter_mut().zip(&self.grain) {
            *l = self.grain_label[g as usize];
        }
        self.relabelled_all += 1;
    }

    /// One fragment, with breaks between the grains `sources` (ascending; `sides`: each
    /// break's two, as indices into `sources`): the searches in turns, the pieces cut off
    /// labelled. False, with nothing changed, when the searches visited more than `budget`
    /// grains.
    ///
    /// First only the searches of breaks not yet settled take turns. A break is settled
    /// when its two sides' searches met (they are still joined) or one of them ran out (a
    /// piece cut off). When every break's sides met, nothing split: each removed joint can
    /// be replaced by a path, so the fragment is whole, even where two breaks far apart have
    /// not met each other. When a piece was cut off, the searches go on until one set is
    /// left searching, which keeps the label (two unsettled pieces on either side of a piece
    /// cut off may be apart).
    fn split_fragment(
        &mut self,
        sources: &[u32],
        sides: &[[u32; 2]],
        broken: &[bool],
        tet_labels: &mut [u32],
        budget: &mut usize,
    ) -> bool {
        let mut q = Searches::new(sources);
        for (s, &g) in sources.iter().enumerate() {
            self.visited_by[g as usize] = s as u32 + 1;
        }
        // Per set root, while some break is unsettled: it has one (None: all search).
        let mut unsettled = Some(vec![false; sources.len()]);
        let mut changed = true;
        let within_budget = 'turns: loop {
            if changed {
                changed = false;
                if let Some(active) = &mut unsettled {
                    if !q.mark_unsettled(sides, active) {
                        if q.cut_off.is_empty() {
                            break 'turns true;
                        }
                        unsettled = None;
                    }
                }
            }
            if unsettled.is_none() && q.searching <= 1 {
                break 'turns true;
            }
            let mut expanded = false;
            for s in 0..sources.len() {
                let root = find(&mut q.parent, s as u32) as usize;
                if q.head[s] == q.visited[s].len() || unsettled.as_ref().is_some_and(|a| !a[root]) {
                    continue;
                }
                expanded = true;
                match self.expand(&mut q, s, broken, budget, unsettled.as_mut()) {
                    None => break 'turns false,
                    Some(c) => changed |= c,
                }
            }
            // (A set whose searches ran out is counted in `expand`, so this is not reached
            // while a set is searching.)
            debug_assert!(expanded, "fragment searches stalled");
            if !expanded {
                break 'turns true;
            }
        };
        self.label_pieces(&mut q, within_budget, tet_labels);
        within_budget
    }

    /// Search `s` expands its next grain. Returns whether sets met or one ran out (None:
    /// over `budget`).
    fn expand(
        &mut self,
        q: &mut Searches,
        s: usize,
        broken: &[bool],
        budget: &mut usize,
        mut unsettled: Option<&mut Vec<bool>>,
    ) -> Option<bool> {
        let mut changed = false;
        let g = q.visited[s][q.head[s]];
        q.head[s] += 1;
        let mut root = find(&mut q.parent, s as u32);
        q.pending[root as usize] -= 1;
        for &[j, h] in self.grain_joints.of(g) {
            if broken[j as usize] {
                continue;
            }
            match self.visited_by[h as usize] {
                0 if *budget == 0 => return None,
                0 => {
                    *budget -= 1;
                    self.visited_by[h as usize] = s as u32 + 1;
                    q.visited[s].push(h);
                    q.pending[root as usize] += 1;
                }
                by => {
                    let other = find(&mut q.parent, by - 1);
                    if other != root {
                        let p = q.pending[root as usize] + q.pending[other as usize];
                        let (r, o) = (root as usize, other as usize);
                        let active = unsettled.as_ref().map(|a| a[r] || a[o]);
                        root = union(&mut q.parent, root, other);
                        q.pending[root as usize] = p;
                        if let (Some(a), Some(w)) = (unsettled.as_mut(), active) {
                            a[root as usize] = w;
                        }
                        q.searching -= 1;
                        changed = true;
                    }
                }
            }
        }
        if q.pending[root as usize] == 0 {
            // Every grain its searches reached is expanded: a whole piece.
            q.cut_off.push(root);
            q.ran_out[root as usize] = true;
            q.searching -= 1;
            changed = true;
        }
        Some(changed)
    }

    /// After the searches: the pieces cut off take fresh labels, in the order they ran out
    /// (the same on every run; none when the searches went over their budget); the set
    /// still searching keeps the fragment's, as does the last piece when every set ran out.
    /// The marks of every grain visited are cleared.
    fn label_pieces(&mut self, q: &mut Searches, within_budget: bool, tet_labels: &mut [u32]) {
        let mut label_of_root = vec![u32::MAX; q.visited.len()];
        if within_budget {
            let fresh = q.cut_off.len() - usize::from(q.searching == 0);
            for &r in &q.cut_off[..fresh] {
                label_of_root[r as usize] = self.next_label;
                self.next_label += 1;
            }
            self.fragment_count += fresh;
        }
        for s in 0..q.visited.len() {
            let label = label_of_root[find(&mut q.parent, s as u32) as usize];
            for &g in &q.visited[s] {
                self.visited_by[g as usize] = 0;
                if label != u32::MAX {
                    self.grain_label[g as usize] = label;
                    for &e in self.grain_tets.of(g) {
                        tet_labels[e as usize] = label;
                    }
                }
            }
        }
    }
}

/// The breadth-first searches of one fragment's split, one per source grain
/// ([`FragmentTracker::split_fragment`]).
struct Searches {
    /// Per search, the grains it visited in order: a queue, those from `head` on still to
    /// expand.
    visited: Vec<Vec<u32>>,
    head: Vec<usize>,
    /// Searches that met are one set (union–find); per set root, the grains its searches
    /// still have to expand, and whether they ran out (a piece cut off).
    parent: Vec<u32>,
    pending: Vec<usize>,
    ran_out: Vec<bool>,
    /// Sets still searching.
    searching: usize,
    /// The roots of the sets that ran out, in order.
    cut_off: Vec<u32>,
}

impl Searches {
    fn new(sources: &[u32]) -> Self {
        let n = sources.len();
        Searches {
            visited: sources.iter().map(|&g| vec![g]).collect(),
            head: vec![0; n],
            parent: (0..n as u32).collect(),
            pending: vec![1; n],
            ran_out: vec![false; n],
            searching: n,
            cut_off: Vec::new(),
        }
    }

    /// Marks in `active` the set roots with an unsettled break (its two sides in sets that
    /// have not met, neither run out); false when there is none.
    fn mark_unsettled(&mut self, sides: &[[u32; 2]], active: &mut [bool]) -> bool {
        active.fill(false);
        let mut any = false;
        for &[a, b] in sides {
            let (ra, rb) = (find(&mut self.parent, a), find(&mut self.parent, b));
            if ra != rb && !self.ran_out[ra as usize] && !self.ran_out[rb as usize] {
                active[ra as usize] = true;
                active[rb as usize] = true;
                any = true;
            }
        }
        any
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A jointed grid of `n`³ one-tet grains (each tet its own nodes) with a joint between
    /// face neighbours, plus a continuous block of shared-node tets joined to one corner:
    /// breaking random joints in batches, the tracker's fragments after each batch are the
    /// connected components recomputed from scratch (the oracle: union–find over every
    /// node and intact joint), including the batches that cut pieces off.
    #[test]
    fn splitting_from_the_breaks_gives_the_components_from_scratch() {
        // 7³ grains: every split found by the searches; 20³: a plane cut off costs more
        // than a quarter of the grains, so those splits label every fragment anew.
        assert_eq!(split_in_rounds(7), 0);
        assert!(split_in_rounds(20) > 0);
    }

    /// Returns how often the tracker labelled every fragment anew.
    fn split_in_rounds(n: u32) -> u64 {
        let id = |i: u32, j: u32, k: u32| (i * n + j) * n + k;
        let mut tet_nodes: Vec<[u32; 4]> = (0..n * n * n)
            .map(|e| [4 * e, 4 * e + 1, 4 * e + 2, 4 * e + 3])
            .collect();
        let mut joint_tets = Vec::new();
        for i in 0..n {
            for j in 0..n {
                for k in 0..n {
                    if i + 1 < n {
                        joint_tets.push([id(i, j, k), id(i + 1, j, k)]);
                    }
                    if j + 1 < n {
                        joint_tets.push([id(i, j, k), id(i, j + 1, k)]);
                    }
                    if k + 1 < n {
                        joint_tets.push([id(i, j, k), id(i, j, k + 1)]);
                    }
                }
            }
        }
        // A continuous body: 10 tets in a chain sharing nodes, joined to tet 0 and tet 5.
        let base = 4 * n * n * n;
        let first = tet_nodes.len() as u32;
        for t in 0..10 {
            tet_nodes.push([base + t, base + t + 1, base + t + 2, base + 100 + t]);
        }
        joint_tets.push([0, first + 3]);
        joint_tets.push([first + 7, id(0, 0, 5)]);
        let n_nodes = (base + 200) as usize;
        let mut broken = vec![false; joint_tets.len()];
        let mut tracker = FragmentTracker::build(&tet_nodes, &joint_tets, &broken, n_nodes);
        let mut labels = tracker.labels();
        assert_eq!(tracker.grain_label.len(), (n * n * n + 1) as usize);
        let mut rng = crate::math::SplitMix64(11);
        let mut pieces = 0;
        for round in 0..60 {
            // Random joints, and now and then a whole plane (a slab cut off).
            let per_round = (joint_tets.len() as u64 / 25).max(40);
            let mut now: Vec<u32> = (0..1 + rng.next_u64() % per_round)
                .map(|_| (rng.next_u64() % joint_tets.len() as u64) as u32)
                .filter(|&j| !broken[j as usize])
                .collect();
            // Now and then a whole plane of joints (a slab cut off), or two planes two cells
            // apart in one batch (a layer cut out between two pieces that are apart).
            let cut_plane = |now: &mut Vec<u32>, plane: u32| {
                now.extend((0..joint_tets.len() as u32).filter(|&j| {
                    let [a, b] = joint_tets[j as usize];
                    a < first && b < first && a / (n * n) == plane && b / (n * n) == plane + 1
                }))
            };
            if round % 15 == 7 {
                cut_plane(&mut now, (rng.next_u64() % (n as u64 - 1)) as u32);
            }
            if round % 15 == 11 {
                let plane = (rng.next_u64() % (n as u64 - 3)) as u32;
                cut_plane(&mut now, plane);
                cut_plane(&mut now, plane + 2);
            }
            now.sort_unstable();
            now.dedup();
            now.iter().for_each(|&j| broken[j as usize] = true);
            pieces += tracker.split(&now, &joint_tets, &broken, &mut labels);
            let oracle = FragmentTracker::build(&tet_nodes, &joint_tets, &broken, n_nodes);
            assert_eq!(labels, tracker.labels());
            assert!(
                same_partition(&labels, &oracle.labels()),
                "round {round}: the fragments differ from the components from scratch"
            );
            assert!(tracker.visited_by.iter().all(|&v| v == 0));
            let count = |l: &[u32]| l.iter().collect::<std::collections::HashSet<_>>().len();
            assert_eq!(count(&labels), count(&oracle.labels()));
        }
        let count = labels
            .iter()
            .collect::<std::collections::HashSet<_>>()
            .len();
        assert_eq!(
            pieces + 1,
            count,
            "every piece cut off is one more fragment"
        );
        assert!(
            count > 40,
            "the test must cut many pieces off: {count} fragments"
        );
        tracker.relabelled_all
    }
}
