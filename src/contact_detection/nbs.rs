//! Munjiza's NBS (No Binary Search) on axis-aligned boxes, with the brute-force oracle and a
//! sort-and-sweep comparison point.
//!
//! The cell size d is the largest box extent. Every
//! element is mapped to the integer cell of its box centre, `floor(c/d)`; two boxes that
//! overlap have centres less than d apart on every axis, so they sit in the same or
//! neighbouring cells, and only those 27 cells are searched. Occupied cells are found by
//! hashing their integer coordinates (an open-addressing table of ≥ 2N slots), never by
//! searching or by an array over the domain: time and memory are O(N) whatever the extent
//! (fragments kilometres apart cost what they cost packed). Elements are scattered into
//! their cells in index order and every pair is emitted once, by its lower index, in index
//! order — the pair list is identical for any number of threads.

use crate::math::{Real, Vec3};
use rayon::prelude::*;

/// Axis-aligned box.
#[derive(serde::Serialize, serde::Deserialize, Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub lo: Vec3,
    pub hi: Vec3,
}

impl Aabb {
    #[inline(always)]
    pub fn of_points(p: &[Vec3]) -> Self {
        let mut lo = p[0];
        let mut hi = p[0];
        for q in &p[1..] {
            lo = lo.inf(q);
            hi = hi.sup(q);
        }
        Aabb { lo, hi }
    }
    #[inline(always)]
    pub fn inflate(&self, r: Real) -> Self {
        Aabb {
            lo: self.lo - Vec3::repeat(r),
            hi: self.hi + Vec3::repeat(r),
        }
    }
    #[inline(always)]
    pub fn overlaps(&self, o: &Aabb) -> bool {
        self.lo.x <= o.hi.x
            && o.lo.x <= self.hi.x
            && self.lo.y <= o.hi.y
            && o.lo.y <= self.hi.y
            && self.lo.z <= o.hi.z
            && o.lo.z <= self.hi.z
    }
    /// The smallest box holding both.
    #[inline(always)]
    pub fn union(&self, o: &Aabb) -> Self {
        Aabb {
            lo: self.lo.inf(&o.lo),
            hi: self.hi.sup(&o.hi),
        }
    }
    #[inline(always)]
    pub fn centre(&self) -> Vec3 {
        (self.lo + self.hi) * 0.5
    }
    #[inline(always)]
    pub fn max_extent(&self) -> Real {
        (self.hi - self.lo).max()
    }
}

const CHUNK: usize = 2048;

/// One slot of the cell hash table: a cell's integer coordinates and its run of elements in
/// the cell-sorted arrays (`count == 0`: free slot). One cache line answers a lookup.
#[derive(serde::Serialize, serde::Deserialize, Clone, Copy, Debug, Default)]
struct Slot {
    c: [i64; 3],
    start: u32,
    count: u32,
}

/// Reusable NBS buffers (no allocation per detection once warmed up).
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, Default)]
pub struct NbsWorkspace {
    /// Integer cell of each element.
    cell_xyz: Vec<[i64; 3]>,
    /// Open-addressing table of occupied cells.
    slots: Vec<Slot>,
    /// Slot of each element.
    slot_of: Vec<u32>,
    /// Elements grouped by cell (index order within a cell), and their boxes in that order.
    sorted: Vec<u32>,
    sorted_boxes: Vec<Aabb>,
    fill: Vec<u32>,
    chunk_pairs: Vec<Vec<[u32; 2]>>,
    /// Pairs per first element (counting sort of the output by first index).
    first_count: Vec<u32>,
    /// The grid last built: cell size and origin.
    cell: Real,
    origin: Vec3,
}

impl NbsWorkspace {
    /// Free the per-chunk pair buffers: the pairs were copied to the caller's list, and a
    /// simulation detects rarely, so keeping a second copy of every pair between detections
    /// would cost 8 B per candidate pair for nothing.
    pub fn release_pair_buffers(&mut self) {
        self.chunk_pairs = Vec::new();
    }

    /// Bytes held by the buffers (capacity) [B].
    pub fn bytes(&self) -> usize {
        use std::mem::size_of;
        self.cell_xyz.capacity() * size_of::<[i64; 3]>()
            + self.slots.capacity() * size_of::<Slot>()
            + (self.slot_of.capacity()
                + self.sorted.capacity()
                + self.fill.capacity()
                + self.first_count.capacity())
                * 4
            + self.sorted_boxes.capacity() * size_of::<Aabb>()
            + self
                .chunk_pairs
                .iter()
                .map(|c| c.capacity() * 8)
                .sum::<usize>()
    }
}

/// Slot of a cell: linear in x, so cells adjacent along x sit in adjacent slots and the 27
/// cells around a cell fall in 9 runs of 3 slots (9 cache lines, shared by the next cell).
#[inline(always)]
fn hash(c: &[i64; 3], mask: usize) -> usize {
    let h = (c[0] as u64)
        .wrapping_add((c[1] as u64).wrapping_mul(0x9E37_79B1))
        .wrapping_add((c[2] as u64).wrapping_mul(0x85EB_CA77_C2B2_AE3D));
    (h as usize) & mask
}

/// The slot of integer cell `c`, or None when no element lies in it.
#[inline(always)]
fn lookup(slots: &[Slot], c: &[i64; 3]) -> Option<Slot> {
    let mask = slots.len() - 1;
    let mut h = hash(c, mask);
    loop {
        let s = slots[h];
        if s.count == 0 {
            return None;
        }
        if s.c == *c {
            return Some(s);
        }
        h = (h + 1) & mask;
    }
}

/// All pairs `[i, j]` (i < j) of boxes that overlap and pass `keep`, by NBS, sorted (by i,
/// then j): the list depends only on the boxes and `keep`, not on threads or on how the
/// search is organised.
///
/// **Mixed sizes.** NBS's cell is the largest box, so a few large boxes (a coarse slab, a
/// rigid wall) beside many small ones would put hundreds of small boxes in every cell. When
/// the largest box is more than twice the median one, the boxes are split at 1.5 times the
/// median: the small ones are searched on a grid of their own size, the large ones on
/// theirs, and each large box looks up the small grid's cells it can reach.
pub fn nbs_pairs(
    boxes: &[Aabb],
    ws: &mut NbsWorkspace,
    keep: &(impl Fn(u32, u32) -> bool + Sync),
    out: &mut Vec<[u32; 2]>,
) {
    nbs_pairs_of(boxes, ws, keep, &|_| true, out);
}

/// [`nbs_pairs`] restricted to the pairs with an element that passes `mine` (either one):
/// the pairs one rank of a decomposed model computes, those with a tet holding a node of its
/// own. Sorted like the whole list, of which it is the sub-list. The grid is built over
/// every box; the search runs only around the elements of `mine`, in both directions (a
/// pair of two such elements from the lower, a pair with one from that one), and, when the
/// sizes are mixed, the large boxes' lookups keep the pairs with an element of `mine`.
pub fn nbs_pairs_of(
    boxes: &[Aabb],
    ws: &mut NbsWorkspace,
    keep: &(impl Fn(u32, u32) -> bool + Sync),
    mine: &(impl Fn(u32) -> bool + Sync),
    out: &mut Vec<[u32; 2]>,
) {
    out.clear();
    if boxes.len() < 2 {
        return;
    }
    let extents: Vec<Real> = boxes.par_iter().map(Aabb::max_extent).collect();
    let largest = extents.iter().fold(0.0, |a: Real, &b| a.max(b));
    let mut sorted_extents = extents.clone();
    let mid = sorted_extents.len() / 2;
    let median = *sorted_extents
        .select_nth_unstable_by(mid, |a, b| a.total_cmp(b))
        .1;
    // A cell holds ~(d/median)³ times the boxes it would at the median size (measured: a
    // jointed bar on a slab twice as coarse, largest/median 2.8, stage 4 −23 %).
    let split = 1.5 * median;
    if !(largest > 2.0 * median && median > 0.0) {
        single_level(boxes, ws, keep, mine, out);
        // Grouped by first index already: sort each group by the second.
        out.chunk_by_mut(|a, b| a[0] == b[0])
            .for_each(|g| g.sort_unstable_by_key(|p| p[1]));
        return;
    }
    let (small, big): (Vec<u32>, Vec<u32>) =
        (0..boxes.len() as u32).partition(|&i| extents[i as usize] <= split);
    // Pairs within each class: the class's own grid, indices mapped back (both lists are in
    // index order, so i < j stays i < j).
    for class in [&big, &small] {
        let sub: Vec<Aabb> = class.iter().map(|&i| boxes[i as usize]).collect();
        let sub_keep = |i: u32, j: u32| keep(class[i as usize], class[j as usize]);
        let sub_mine = |e: u32| mine(class[e as usize]);
        let mut pairs = Vec::new();
        single_level(&sub, ws, &sub_keep, &sub_mine, &mut pairs);
        out.extend(
            pairs
                .iter()
                .map(|&[i, j]| [class[i as usize], class[j as usize]]),
        );
    }
    // The small grid is the last one built: each large box looks up the cells whose small
    // boxes can reach it (a small box's centre lies within half the small cell of it).
    let cross: Vec<Vec<[u32; 2]>> = big
        .par_chunks(64)
        .map(|chunk| {
            let mut pairs = Vec::new();
            for &g in chunk {
                large_box_pairs(boxes, ws, &small, g, keep, &mut pairs);
            }
            pairs.retain(|p| mine(p[0]) || mine(p[1]));
            pairs
        })
        .collect();
    out.extend(cross.into_iter().flatten());
    out.par_sort_unstable();
}

/// The pairs of large box `g` with the small boxes (`small`: their indices, the grid in
/// `ws` built over them), as [lower, higher] index.
fn large_box_pairs(
    boxes: &[Aabb],
    ws: &NbsWorkspace,
    small: &[u32],
    g: u32,
    keep: &(impl Fn(u32, u32) -> bool + Sync),
    pairs: &mut Vec<[u32; 2]>,
) {
    let b = boxes[g as usize];
    let (d, origin) = (ws.cell, ws.origin);
    let reach = Vec3::repeat(0.5 * d);
    let lo = ((b.lo - reach - origin) / d).map(Real::floor);
    let hi = ((b.hi + reach - origin) / d).map(Real::floor);
    let mut push = |s: u32| {
        if b.overlaps(&boxes[s as usize]) {
            let pair = [s.min(g), s.max(g)];
            if keep(pair[0], pair[1]) {
                pairs.push(pair);
            }
        }
    };
    let cells = (hi - lo).map(|x| x + 1.0);
    if cells.x * cells.y * cells.z > small.len() as Real {
        // Larger than the small boxes' whole grid: test them all.
        small.iter().for_each(|&s| push(s));
        return;
    }
    let (lo, hi) = (lo.map(|x| x as i64), hi.map(|x| x as i64));
    for z in lo.z..=hi.z {
        for y in lo.y..=hi.y {
            for x in lo.x..=hi.x {
                if let Some(slot) = lookup(&ws.slots, &[x, y, z]) {
                    let run = slot.start as usize..(slot.start + slot.count) as usize;
                    for &k in &ws.sorted[run] {
                        push(small[k as usize]);
                    }
                }
            }
        }
    }
}

/// NBS over all of `boxes` with one cell size: the pairs with an element that passes
/// `mine`, ordered by their first index.
fn single_level(
    boxes: &[Aabb],
    ws: &mut NbsWorkspace,
    keep: &(impl Fn(u32, u32) -> bool + Sync),
    mine: &(impl Fn(u32) -> bool + Sync),
    out: &mut Vec<[u32; 2]>,
) {
    out.clear();
    if boxes.len() < 2 {
        return;
    }
    assign_cells(boxes, ws);
    sort_into_cells(boxes, ws);
    search_neighbour_cells(boxes.len(), ws, keep, mine);
    order_by_first(boxes.len(), ws, out);
}

/// The integer cell of every box centre. Cell size: the largest box; cells counted from the
/// smallest centre (only to keep the integers small — nothing is sized by the extent).
fn assign_cells(boxes: &[Aabb], ws: &mut NbsWorkspace) {
    let (d, origin) = boxes
        .par_iter()
        .map(|b| (b.max_extent(), b.centre()))
        .reduce(
            || (0.0, Vec3::repeat(Real::INFINITY)),
            |a, b| (a.0.max(b.0), a.1.inf(&b.1)),
        );
    let d = if d > 0.0 { d } else { 1.0 };
    (ws.cell, ws.origin) = (d, origin);
    let inv = 1.0 / d;
    ws.cell_xyz.clear();
    ws.cell_xyz.par_extend(boxes.par_iter().map(|b| {
        let c = (b.centre() - origin) * inv;
        [c.x.floor() as i64, c.y.floor() as i64, c.z.floor() as i64]
    }));
}

/// Occupied cells in the hash table with their element counts, then a counting sort of the
/// elements by cell (index order within each cell) and their boxes in that order.
fn sort_into_cells(boxes: &[Aabb], ws: &mut NbsWorkspace) {
    let n = boxes.len();
    // Count the elements of each cell (consecutive elements are often in the same cell, so
    // the last slot is remembered).
    let cap = (2 * n).next_power_of_two();
    ws.slots.clear();
    ws.slots.resize(cap, Slot::default());
    ws.slot_of.clear();
    let mask = cap - 1;
    let mut last: Option<([i64; 3], usize)> = None;
    for c in &ws.cell_xyz {
        let h = match last {
            Some((lc, lh)) if lc == *c => lh,
            _ => {
                let mut h = hash(c, mask);
                loop {
                    let s = &mut ws.slots[h];
                    if s.count == 0 {
                        s.c = *c;
                        break;
                    }
                    if s.c == *c {
                        break;
                    }
                    h = (h + 1) & mask;
                }
                last = Some((*c, h));
                h
            }
        };
        ws.slots[h].count += 1;
        ws.slot_of.push(h as u32);
    }
    // Runs of the cells in the sorted arrays (prefix sum over the table).
    let mut acc = 0u32;
    for s in ws.slots.iter_mut() {
        s.start = acc;
        acc += s.count;
    }
    ws.fill.clear();
    ws.fill.extend(ws.slots.iter().map(|s| s.start));
    ws.sorted.clear();
    ws.sorted.resize(n, 0);
    for (e, &h) in ws.slot_of.iter().enumerate() {
        let k = &mut ws.fill[h as usize];
        ws.sorted[*k as usize] = e as u32;
        *k += 1;
    }
    ws.sorted_boxes.clear();
    ws.sorted_boxes
        .par_extend(ws.sorted.par_iter().map(|&e| boxes[e as usize]));
}

/// Search the 27 cells around each element of `mine`'s cell for overlapping boxes that pass
/// `keep`: higher-indexed ones, and lower-indexed ones not in `mine` (so that each pair
/// with an element of `mine` is found once), visiting the elements cell by cell
/// (neighbouring elements share their lookups' cache lines); pairs, [lower, higher], per
/// chunk of elements in `ws.chunk_pairs`.
fn search_neighbour_cells(
    n: usize,
    ws: &mut NbsWorkspace,
    keep: &(impl Fn(u32, u32) -> bool + Sync),
    mine: &(impl Fn(u32) -> bool + Sync),
) {
    let n_chunks = n.div_ceil(CHUNK);
    ws.chunk_pairs.resize_with(n_chunks, Vec::new);
    let (slots, sorted, sorted_boxes, cell_xyz) =
        (&ws.slots, &ws.sorted, &ws.sorted_boxes, &ws.cell_xyz);
    ws.chunk_pairs
        .par_iter_mut()
        .enumerate()
        .for_each(|(ci, pairs)| {
            pairs.clear();
            for k in ci * CHUNK..((ci + 1) * CHUNK).min(n) {
                let e = sorted[k] as usize;
                if !mine(e as u32) {
                    continue;
                }
                let c = cell_xyz[e];
                let be = &sorted_boxes[k];
                let e = e as u32;
                for dz in -1..=1 {
                    for dy in -1..=1 {
                        for dx in -1..=1 {
                            let Some(s) = lookup(slots, &[c[0] + dx, c[1] + dy, c[2] + dz]) else {
                                continue;
                            };
                            let run = s.start as usize..(s.start + s.count) as usize;
                            for (&f, bf) in sorted[run.clone()].iter().zip(&sorted_boxes[run]) {
                                if (f > e || (f < e && !mine(f)))
                                    && be.overlaps(bf)
                                    && keep(e.min(f), e.max(f))
                                {
                                    pairs.push([e.min(f), e.max(f)]);
                                }
                            }
                        }
                    }
                }
            }
        });
}

/// Order the pairs by their first element (a counting sort: linear, deterministic).
fn order_by_first(n: usize, ws: &mut NbsWorkspace, out: &mut Vec<[u32; 2]>) {
    ws.first_count.clear();
    ws.first_count.resize(n + 1, 0);
    for p in ws.chunk_pairs.iter().flatten() {
        ws.first_count[p[0] as usize + 1] += 1;
    }
    for i in 0..n {
        ws.first_count[i + 1] += ws.first_count[i];
    }
    let total = ws.first_count[n] as usize;
    out.resize(total, [0, 0]);
    for p in ws.chunk_pairs.iter().flatten() {
        let k = &mut ws.first_count[p[0] as usize];
        out[*k as usize] = *p;
        *k += 1;
    }
}

/// All overlapping pairs by checking every pair: O(N²), the test oracle. Sorted.
pub fn brute_force_pairs(boxes: &[Aabb], keep: impl Fn(u32, u32) -> bool) -> Vec<[u32; 2]> {
    let mut out = Vec::new();
    for i in 0..boxes.len() {
        for j in i + 1..boxes.len() {
            if boxes[i].overlaps(&boxes[j]) && keep(i as u32, j as u32) {
                out.push([i as u32, j as u32]);
            }
        }
    }
    out
}

/// Sort and sweep along x (O(N log N) + pairs): a comparison point. Sorted.
pub fn sweep_pairs(boxes: &[Aabb]) -> Vec<[u32; 2]> {
    let mut order: Vec<u32> = (0..boxes.len() as u32).collect();
    order.par_sort_unstable_by(|&a, &b| {
        boxes[a as usize]
            .lo
            .x
            .total_cmp(&boxes[b as usize].lo.x)
            .then(a.cmp(&b))
    });
    let mut out = Vec::new();
    for (k, &a) in order.iter().enumerate() {
        let ba = &boxes[a as usize];
        for &b in &order[k + 1..] {
            let bb = &boxes[b as usize];
            if bb.lo.x > ba.hi.x {
                break;
            }
            if ba.overlaps(bb) {
                out.push([a.min(b), a.max(b)]);
            }
        }
    }
    out.par_sort_unstable();
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn random_boxes(n: usize, seed: u64, spread: Real, sizes: &[Real]) -> Vec<Aabb> {
        let mut s = seed;
        let mut r = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as Real / (1u64 << 53) as Real
        };
        (0..n)
            .map(|i| {
                let c = Vec3::new(r(), r(), r()) * spread;
                let h = sizes[i % sizes.len()] * (0.5 + r());
                Aabb {
                    lo: c - Vec3::repeat(h * 0.5),
                    hi: c + Vec3::new(h, h * r(), h * 0.7) * 0.5,
                }
            })
            .collect()
    }

    fn sorted(mut v: Vec<[u32; 2]>) -> Vec<[u32; 2]> {
        v.sort_unstable();
        v
    }

    #[test]
    fn nbs_equals_brute_force_and_sweep() {
        let mut ws = NbsWorkspace::default();
        let mut out = Vec::new();
        for (seed, spread, sizes) in [
            (1u64, 10.0, vec![1.0]),
            (2, 3.0, vec![1.0]),                  // dense
            (3, 100.0, vec![1.0]),                // sparse
            (4, 10.0, vec![0.1, 0.5, 2.0, 0.05]), // mixed sizes: two grids
            // A coarse part beside a fine one (one box in ten 25 times larger), and one box
            // covering everything: two grids, the giant tested against every small box.
            (5, 10.0, [vec![0.2; 9], vec![5.0]].concat()),
            (6, 10.0, [vec![0.2; 499], vec![40.0]].concat()),
        ] {
            let boxes = random_boxes(1500, seed, spread, &sizes);
            let brute = brute_force_pairs(&boxes, |_, _| true);
            nbs_pairs(&boxes, &mut ws, &|_, _| true, &mut out);
            // Sorted as it comes: the list is canonical.
            assert_eq!(out, brute, "seed {seed}");
            // keep() sees each pair as [lower, higher] and filters it.
            let odd = |i: u32, j: u32| {
                assert!(i < j);
                (i + j) % 2 == 1
            };
            nbs_pairs(&boxes, &mut ws, &odd, &mut out);
            let brute_odd = brute_force_pairs(&boxes, |i, j| (i + j) % 2 == 1);
            assert_eq!(out, brute_odd, "seed {seed}, filtered");
            assert_eq!(sweep_pairs(&boxes), brute, "seed {seed}");
            assert!(!brute.is_empty());
        }
    }

    /// The search restricted to the pairs with an element of a rank's set (as the ranks of
    /// a decomposed model restrict it): the sub-list of the whole list with an element in
    /// the set, in its order, for one grid and for two (mixed sizes, where large boxes look
    /// up small ones), for sets that are ranges, scattered, empty or everything.
    #[test]
    fn the_pairs_of_a_set_are_the_whole_lists_pairs_with_an_element_in_it() {
        let mut ws = NbsWorkspace::default();
        let (mut whole, mut part) = (Vec::new(), Vec::new());
        for (seed, sizes) in [
            (11u64, vec![1.0]),
            (12, vec![0.1, 0.5, 2.0, 0.05]),
            (13, [vec![0.2; 99], vec![40.0]].concat()),
        ] {
            let boxes = random_boxes(1200, seed, 10.0, &sizes);
            let keep = |i: u32, j: u32| !(i * 7 + j).is_multiple_of(5);
            nbs_pairs(&boxes, &mut ws, &keep, &mut whole);
            assert!(whole.len() > 1000, "seed {seed}: {} pairs", whole.len());
            let sets: [&(dyn Fn(u32) -> bool + Sync); 5] = [
                &|e| e < 600,
                &|e| (400..1199).contains(&e),
                &|e| e % 3 == 1,
                &|_| false,
                &|_| true,
            ];
            for (s, set) in sets.iter().enumerate() {
                nbs_pairs_of(&boxes, &mut ws, &keep, &|e| set(e), &mut part);
                let expected: Vec<[u32; 2]> = (whole.iter())
                    .filter(|p| set(p[0]) || set(p[1]))
                    .copied()
                    .collect();
                assert_eq!(part, expected, "seed {seed}, set {s}");
            }
        }
    }

    /// Two clusters 1e6 cell sizes apart: same pairs, and the buffers do not grow with the
    /// distance.
    #[test]
    fn far_apart_costs_no_memory() {
        let near = random_boxes(2000, 9, 10.0, &[1.0]);
        let mut far = near.clone();
        for b in far.iter_mut().skip(1000) {
            b.lo.x += 1.0e6;
            b.hi.x += 1.0e6;
        }
        let mut ws = NbsWorkspace::default();
        let mut out = Vec::new();
        nbs_pairs(&near, &mut ws, &|_, _| true, &mut out);
        let bytes_near = ws.bytes();
        let mut ws2 = NbsWorkspace::default();
        nbs_pairs(&far, &mut ws2, &|_, _| true, &mut out);
        assert_eq!(sorted(out.clone()), brute_force_pairs(&far, |_, _| true));
        assert!(
            ws2.bytes() <= bytes_near + bytes_near / 4,
            "{} vs {}",
            ws2.bytes(),
            bytes_near
        );
    }
}
