//! Stage 5 test oracle: the contact kernel as it was before issue 14's speed work
//! (2026-11-28), kept to check the kernel in use against.
//!
//! It integrates the same exact energy and forces as [`super::potential`], with the same
//! clipping, region split, apex and kink facets, but carries each polygon vertex's own
//! barycentric coordinates through the clipping and integrates every node's surface integral
//! ∫φ N_i dA on every facet, where the kernel in use integrates only ∫φ dA and ∫φ·x dA and
//! maps them to the nodes once per pair. The two agree to rounding: issue 14 asks 1e-12 of
//! the largest force of every pair, checked by `oracle_agrees_with_the_kernel` on random
//! and thin-overlap pairs, and by `fdem bench` on every touching pair of its model
//! (`kernel_oracle_deviation`; `tests/contact.rs`,
//! `the_kernel_agrees_with_its_oracle_on_a_settled_stack`).

// Index loops over the 4 nodes / faces mirror the equations; iterators would obscure them.
#![allow(clippy::needless_range_loop)]

use super::potential::{
    face_pieces, kink_energy, ClipVertex, PairForces, Poly, RegionCones, Side, TetGeom, MAX_POLY,
};
use crate::math::{Real, Vec3};

/// A polygon vertex with its barycentric coordinates in the other element (`bo`) and in
/// its own (`bs`), both interpolated by the clipping.
#[derive(Clone, Copy)]
struct Vert {
    x: Vec3,
    bo: [Real; 4],
    bs: [Real; 4],
}

impl ClipVertex for Vert {
    #[inline(always)]
    fn lerp(&self, o: &Vert, t: Real) -> Vert {
        let mut bo = [0.0; 4];
        let mut bs = [0.0; 4];
        for k in 0..4 {
            bo[k] = self.bo[k] + (o.bo[k] - self.bo[k]) * t;
            bs[k] = self.bs[k] + (o.bs[k] - self.bs[k]) * t;
        }
        Vert {
            x: self.x + (o.x - self.x) * t,
            bo,
            bs,
        }
    }
    #[inline(always)]
    fn bo(&self) -> &[Real; 4] {
        &self.bo
    }
}

/// Accumulators for one pair (before multiplying by p).
struct Acc {
    /// ∫ φ_other N_i^c dA · n over facets (signed per the formulas), per contactor node.
    sc: [Vec3; 4],
    st: [Vec3; 4],
    e_c: Real,
    e_t: Real,
    area: Real,
    moment: Vec3,
    depth: Real,
    cones_c: RegionCones,
    cones_t: RegionCones,
}

/// The oracle's [`super::potential::overlapping_tet_tet`].
pub fn overlapping_tet_tet(c: &TetGeom, t: &TetGeom, p: Real) -> PairForces {
    let mut out = PairForces::default();
    let origin = c.x[0];
    let (c, t) = (&c.shifted(origin), &t.shifted(origin));
    let bc: [[Real; 4]; 4] = t.x.map(|x| c.bary(&x));
    let bt: [[Real; 4]; 4] = c.x.map(|x| t.bary(&x));
    let mut acc = Acc {
        sc: [Vec3::zeros(); 4],
        st: [Vec3::zeros(); 4],
        e_c: 0.0,
        e_t: 0.0,
        area: 0.0,
        moment: Vec3::zeros(),
        depth: 0.0,
        cones_c: RegionCones::new(),
        cones_t: RegionCones::new(),
    };
    let vertex = |x: Vec3, v: usize, bo: [Real; 4]| {
        let mut bs = [0.0; 4];
        bs[v] = 1.0;
        Vert { x, bo, bs }
    };
    for k in 0..4 {
        for (own, other, b, side) in [(c, t, &bt, Side::Contactor), (t, c, &bc, Side::Target)] {
            face_pieces(own, k, b, vertex, |poly, m, also| {
                integrate_piece(own, other, poly, k, (m, also), side, &mut acc)
            });
        }
    }
    if acc.area <= 0.0 {
        return out;
    }
    acc.e_c += kink_energy(c, t, &bt, &acc.cones_c);
    acc.e_t += kink_energy(t, c, &bc, &acc.cones_t);
    for i in 0..4 {
        out.fc[i] = -p * (c.g[i] * acc.e_c + acc.sc[i]);
        out.ft[i] = -p * (t.g[i] * acc.e_t + acc.st[i]);
    }
    out.energy = p * (acc.e_c + acc.e_t);
    out.area = 0.5 * acc.area;
    out.point = acc.moment / acc.area + origin;
    out.depth = acc.depth;
    out.touching = true;
    out
}

/// One planar facet on face k of `own` (outward normal n), inside region m of `other`
/// (φ_other = 4λ_m): its surface integrals per node, and its cone from the other's apex
/// of region m (the cone over it from its own region k's apex is 0: φ_own = 0 on face k).
fn integrate_piece(
    own: &TetGeom,
    other: &TetGeom,
    poly: &Poly<Vert>,
    k: usize,
    (m, also): (usize, u8),
    side: Side,
    acc: &mut Acc,
) {
    let n = own.normal[k];
    let mut phi = [0.0; MAX_POLY];
    for i in 0..poly.n {
        let bo = &poly.get(i).bo;
        phi[i] = 4.0 * bo[m];
        let d = (0..4)
            .map(|k| bo[k] * other.height[k])
            .fold(Real::INFINITY, Real::min);
        acc.depth = acc.depth.max(d);
    }
    let v0 = poly.get(0);
    let mut area = 0.0;
    let mut first = Vec3::zeros();
    let mut i_own = [0.0; 4];
    let mut i_oth = [0.0; 4];
    let mut i_phi = 0.0;
    for tri in 1..poly.n - 1 {
        let (b, c) = (tri, tri + 1);
        let (vb, vc) = (poly.get(b), poly.get(c));
        let at = 0.5 * (vb.x - v0.x).cross(&(vc.x - v0.x)).dot(&n);
        if at == 0.0 {
            continue;
        }
        area += at;
        first += (v0.x + vb.x + vc.x) * (at / 3.0);
        let (pa, pb, pc) = (phi[0], phi[b], phi[c]);
        let sphi = pa + pb + pc;
        i_phi += at * sphi / 3.0;
        let w = at / 12.0;
        for q in 0..4 {
            let (oa, ob, oc) = (v0.bs[q], vb.bs[q], vc.bs[q]);
            i_own[q] += w * (pa * oa + pb * ob + pc * oc + sphi * (oa + ob + oc));
            let (ta, tb, tc) = (v0.bo[q], vb.bo[q], vc.bo[q]);
            i_oth[q] += w * (pa * ta + pb * tb + pc * tc + sphi * (ta + tb + tc));
        }
    }
    if area <= 0.0 {
        return;
    }
    acc.area += area;
    acc.moment += first;
    let (own_cones, oth_cones) = match side {
        Side::Contactor => (&mut acc.cones_c, &mut acc.cones_t),
        Side::Target => (&mut acc.cones_t, &mut acc.cones_c),
    };
    own_cones.apex(own, k, v0.x, 0.0);
    let apex = oth_cones.apex(other, m, v0.x, v0.bo[m]);
    if also != 0 {
        let j = also.trailing_zeros() as usize;
        oth_cones.apex(other, j, v0.x, v0.bo[j]);
    }
    let e_oth = (first / area - apex).dot(&n) * i_phi * 0.25;
    let (e_oth_sum, s_own, s_oth) = match side {
        Side::Contactor => (&mut acc.e_t, &mut acc.sc, &mut acc.st),
        Side::Target => (&mut acc.e_c, &mut acc.st, &mut acc.sc),
    };
    *e_oth_sum += e_oth;
    for q in 0..4 {
        s_own[q] += n * i_own[q];
        s_oth[q] -= n * i_oth[q];
    }
}
