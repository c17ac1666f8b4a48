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

/// A compressed list of lists (CSR): `items[start[i]..start[i + 1]]` for list `i`.
#[derive(Clone, Debug, Default)]
struct Lists<T> {
    start: Vec<u32>,
    items: Vec<T>,
}

impl<T: Copy + Default> Lists<T> {
    /// The lists of `n` keys from (key, item) pairs, each list in the order given.
    fn from_pairs(n: usize, pairs: impl Iterator<Item = (u32, T)> + Clone) -> Self {
        let mut start = vec![0u32; n + 1];
        for (k, _) in pairs.clone() {
            start[k as usize + 1] += 1;
        }
        for i in 0..n {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut items = vec![T::default(); start[n] as usize];
        for (k, v) in pairs {
            items[fill[k as usize] as usize] = v;
            fill[k as usize] += 1;
        }
        Lists { start, items }
    }

    fn of(&self, i: u32) -> &[T] {
        &self.items[self.start[i as usize] as usize..self.start[i as usize + 1] as usize]
    }
}

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
        // The grains on either side of the breaks, by fragment.
        let mut sources: Vec<(u32, u32)> = Vec::new();
        for &j in newly_broken {
            let [a, b] = joint_tets[j as usize];
            let (ga, gb) = (self.grain[a as usize], self.grain[b as usize]);
            let la = self.grain_label[ga as usize];
            if ga != gb && la == self.grain_label[gb as usize] {
                sources.push((la, ga));
                sources.push((la, gb));
            }
        }
        sources.sort_unstable();
        sources.dedup();
        let before = self.fragment_count;
        let mut budget = (self.grain_label.len() / 4).max(1024);
        let mut i = 0;
        while i < sources.len() {
            let label = sources[i].0;
            let n = sources[i..].iter().take_while(|s| s.0 == label).count();
            let grains: Vec<u32> = sources[i..i + n].iter().map(|s| s.1).collect();
            if !self.split_fragment(&grains, broken, tet_labels, &mut budget) {
                // The searches would cost about what labelling every grain anew does.
                self.relabel_all(broken, tet_labels);
                break;
            }
            i += n;
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

    /// One fragment, with breaks at `sources` (its grains beside them, ascending): the
    /// searches in turns (module doc), the pieces cut off labelled. False, with nothing
    /// changed, when the searches visited more than `budget` grains.
    fn split_fragment(
        &mut self,
        sources: &[u32],
        broken: &[bool],
        tet_labels: &mut [u32],
        budget: &mut usize,
    ) -> bool {
        let n = sources.len();
        if n < 2 {
            return true;
        }
        // Search s: the grains it visited, in order (a queue: those from `head[s]` on are
        // still to expand). Searches that met are one set of `parent`, whose root counts
        // the grains its searches still have to expand.
        let mut visited: Vec<Vec<u32>> = sources.iter().map(|&g| vec![g]).collect();
        let mut head = vec![0usize; n];
        let mut parent: Vec<u32> = (0..n as u32).collect();
        let mut pending = vec![1usize; n];
        let mut searching = n;
        for (s, &g) in sources.iter().enumerate() {
            self.visited_by[g as usize] = s as u32 + 1;
        }
        let mut cut_off: Vec<u32> = Vec::new();
        let mut over_budget = false;
        'turns: while searching > 1 {
            let mut expanded = false;
            for s in 0..n {
                if head[s] == visited[s].len() {
                    continue;
                }
                expanded = true;
                let g = visited[s][head[s]];
                head[s] += 1;
                let mut root = find(&mut parent, s as u32);
                pending[root as usize] -= 1;
                for &[j, h] in self.grain_joints.of(g) {
                    if broken[j as usize] {
                        continue;
                    }
                    match self.visited_by[h as usize] {
                        0 if *budget == 0 => {
                            over_budget = true;
                            break 'turns;
                        }
                        0 => {
                            *budget -= 1;
                            self.visited_by[h as usize] = s as u32 + 1;
                            visited[s].push(h);
                            pending[root as usize] += 1;
                        }
                        by => {
                            let other = find(&mut parent, by - 1);
                            if other != root {
                                let p = pending[root as usize] + pending[other as usize];
                                root = union(&mut parent, root, other);
                                pending[root as usize] = p;
                                searching -= 1;
                            }
                        }
                    }
                }
                if pending[root as usize] == 0 {
                    // Every grain its searches reached is expanded: a whole piece.
                    cut_off.push(root);
                    searching -= 1;
                }
                if searching <= 1 {
                    break 'turns;
                }
            }
            // (Every set whose searches ran out is counted above, so this cannot be reached
            // with two sets still searching.)
            debug_assert!(expanded, "fragment searches stalled");
            if !expanded {
                break;
            }
        }
        // The pieces cut off take fresh labels (in the order they ran out, the same on every
        // run); the piece still searching keeps the fragment's.
        let mut label_of_root = vec![u32::MAX; n];
        if !over_budget {
            for &r in &cut_off {
                label_of_root[r as usize] = self.next_label;
                self.next_label += 1;
            }
            self.fragment_count += cut_off.len();
        }
        for s in 0..n {
            let label = label_of_root[find(&mut parent, s as u32) as usize];
            for &g in &visited[s] {
                self.visited_by[g as usize] = 0;
                if label != u32::MAX {
                    self.grain_label[g as usize] = label;
                    for &e in self.grain_tets.of(g) {
                        tet_labels[e as usize] = label;
                    }
                }
            }
        }
        !over_budget
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
            if round % 15 == 7 {
                let plane = (rng.next_u64() % (n as u64 - 1)) as u32;
                now.extend((0..joint_tets.len() as u32).filter(|&j| {
                    let [a, b] = joint_tets[j as usize];
                    a < first && b < first && a / (n * n) == plane && b / (n * n) == plane + 1
                }));
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
