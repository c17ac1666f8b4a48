//! Stage 5 kernel: the potential contact force between two tetrahedra, integrated exactly.
//!
//! **Potential.** Each tetrahedron carries φ(x) = 4·min_k λ_k(x) (Munjiza 2004, §2.4; the
//! 3D form of φ = min 3A_i/A): λ_k are the barycentric coordinates, so φ = 4V_k/V with V_k
//! the volume of the sub-tetrahedron spanned by x and face k. φ is 0 on the faces, 1 at the
//! centroid, and linear inside each of the four centroid-to-face sub-tetrahedra R_k.
//!
//! **Energy and forces.** For a contactor C and a target T the contact energy is
//!
//! ```text
//!   E = p · ∫_{C∩T} (φ_c + φ_t) dV                                   [J], p [Pa]
//! ```
//!
//! and every nodal force is its exact negative gradient, F_a = −∂E/∂x_a. For a rigid
//! translation this is Munjiza's resultant f_c = p·∫(∇φ_c − ∇φ_t) dV (divergence theorem);
//! for deforming elements, differentiating through the moving domain and the moving φ gives
//! (N_i the linear shape functions, g_i = ∇N_i, n_c and n_t outward face normals)
//!
//! ```text
//!   F_i^c = −p [ g_i^c E_c − ∫_{C∩∂T} φ_c N_i^c n_t dA + ∫_{∂C∩T} φ_t N_i^c n_c dA ]
//!   F_j^t = −p [ g_j^t E_t − ∫_{T∩∂C} φ_t N_j^t n_c dA + ∫_{∂T∩C} φ_c N_j^t n_t dA ]
//! ```
//!
//! with E_c = ∫_{C∩T} φ_c dV and E_t = ∫_{C∩T} φ_t dV (using ∂φ_c/∂x_i = −N_i ∇φ_c at a
//! fixed point and Reynolds' transport theorem with φ = 0 on each element's own boundary).
//! The forces sum to zero (action = reaction) and have zero moment; the pair conserves
//! energy exactly in the continuous limit.
//!
//! **Exact integration.** Only surface integrals are needed. Each face of C is clipped by T
//! (4 half-spaces λ_j^t ≥ 0) and split by T's sub-tetrahedra, where φ_t is linear; the
//! integrands φ·N are then quadratic, integrated exactly on a fan of triangles. The volume
//! integrals E_c, E_t are sums over the sub-tetrahedra R_m of one element, where φ = 4λ_m is
//! linear: ∫_{R_m∩Ω} φ = Σ over the boundary facets of cones from an apex a_m,
//! V·(¼φ(a_m) + ¾φ(facet centroid)), V = (x̄ − a_m)·n·A/3. The boundary of R_m ∩ Ω is made
//! of facets of ∂Ω and of the kink triangles λ_m = λ_j inside the other element.
//!
//! **Each region's apex lies on its own face plane** (λ_m = 0, where its φ vanishes), near
//! the overlap ([`RegionCones`]): a facet where φ vanishes adds nothing, whether the
//! clipping counted it once, twice or not at all, and cone heights are of the overlap's
//! size, so the energy of an overlap of depth d is accurate to about ulp(H)/d of itself and
//! symmetric in the two elements (docs/theory/contact.md tells the two apexes this replaced
//! and what each got wrong).
//!
//! **Coplanar faces** (blocks that touch exactly, the common start of masonry and cut boxes)
//! are robust: barycentric values within `SNAP` (1e-12) of a plane count as on it, so both
//! sides of a coincident face pair see the same polygon; both are kept (φ vanishes on them).

// Index loops over the 4 nodes / faces mirror the equations; iterators would obscure them.
#![allow(clippy::needless_range_loop)]

use crate::math::{Mat3, Real, Vec3};
use crate::mesh::TET_FACES;

/// Barycentric values this close to 0 count as on the plane. Small, because a facet clipped
/// a snap distance differently on the two sides costs about p·SNAP·L²·d of energy (a sliver
/// SNAP·H wide, where φ ≈ d/H, under cones of height L; d the overlap depth, L its extent),
/// against p·L²·d²/H for the whole overlap.
pub(crate) const SNAP: Real = 1e-12;
/// Polygon capacity: a triangle clipped by 4 + 3 planes has at most 3 + 7 = 10 vertices.
pub(crate) const MAX_POLY: usize = 10;

/// Geometry of one tetrahedron prepared for contact: barycentric gradients, centroid and
/// outward face normals.
#[derive(serde::Serialize, serde::Deserialize, Clone, Copy, Debug)]
pub struct TetGeom {
    pub x: [Vec3; 4],
    /// ∇λ_i [1/m].
    pub g: [Vec3; 4],
    pub centroid: Vec3,
    /// Outward unit normals of the faces opposite node k.
    pub normal: [Vec3; 4],
    /// Signed volume [m³].
    pub volume: Real,
    /// Height over each face, 1/|∇λ_k| [m].
    pub height: [Real; 4],
}

impl TetGeom {
    /// None for a degenerate (zero-volume) tetrahedron.
    #[inline]
    pub fn new(x: [Vec3; 4]) -> Option<Self> {
        let d = crate::math::Mat3::from_columns(&[x[1] - x[0], x[2] - x[0], x[3] - x[0]]);
        let det = d.determinant();
        if det.abs() <= Real::MIN_POSITIVE {
            return None;
        }
        let inv = d.try_inverse()?;
        let g1 = inv.row(0).transpose();
        let g2 = inv.row(1).transpose();
        let g3 = inv.row(2).transpose();
        let g = [-(g1 + g2 + g3), g1, g2, g3];
        // The outward normal of face k points against ∇λ_k (λ_k grows inwards from face k).
        let normal = g.map(|gk| {
            let n = gk.norm();
            -gk / n
        });
        Some(TetGeom {
            x,
            height: g.map(|gk| 1.0 / gk.norm()),
            g,
            centroid: (x[0] + x[1] + x[2] + x[3]) * 0.25,
            normal,
            volume: det / 6.0,
        })
    }

    /// The same tetrahedron with coordinates relative to `origin`.
    #[inline(always)]
    pub(crate) fn shifted(&self, origin: Vec3) -> Self {
        TetGeom {
            x: self.x.map(|x| x - origin),
            centroid: self.centroid - origin,
            ..*self
        }
    }

    /// Barycentric coordinates λ_0..λ_3 of `p`.
    #[inline(always)]
    pub fn bary(&self, p: &Vec3) -> [Real; 4] {
        let d = p - self.x[0];
        let l1 = self.g[1].dot(&d);
        let l2 = self.g[2].dot(&d);
        let l3 = self.g[3].dot(&d);
        [1.0 - l1 - l2 - l3, l1, l2, l3]
    }
}

/// Result of one pair: nodal forces on both elements, the contact energy and what friction
/// needs.
#[derive(Clone, Copy, Debug, Default)]
pub struct PairForces {
    /// Forces on the contactor's and the target's 4 nodes [N].
    pub fc: [Vec3; 4],
    pub ft: [Vec3; 4],
    /// E = p·∫(φ_c + φ_t) dV [J].
    pub energy: Real,
    /// Half the area of all clipped facets: the contact area for a thin overlap [m²].
    pub area: Real,
    /// Area-weighted centroid of the clipped facets: the contact point [m].
    pub point: Vec3,
    /// False when the elements do not overlap.
    pub touching: bool,
    /// Penetration depth [m]: the largest distance, over the vertices of the clipped facets,
    /// from a point of one element to the nearest face of the other.
    pub depth: Real,
}

/// A polygon vertex as the clipping sees it: interpolated exactly along the edges it cuts
/// (every coordinate is affine), never re-projected.
pub(crate) trait ClipVertex: Copy {
    fn lerp(&self, o: &Self, t: Real) -> Self;
    /// Barycentric coordinates in the other element: the clipping planes' values.
    fn bo(&self) -> &[Real; 4];
}

/// A polygon vertex with its barycentric coordinates in the other element (`bo`). The own
/// element's barycentrics are affine in `x` and are not carried: the surface integrals need
/// only ∫φ dA and ∫φ·x dA ([`integrate_piece`]).
#[derive(Clone, Copy)]
pub(crate) struct Vert {
    pub(crate) x: Vec3,
    pub(crate) bo: [Real; 4],
}

impl ClipVertex for Vert {
    #[inline(always)]
    fn lerp(&self, o: &Vert, t: Real) -> Vert {
        let mut bo = [0.0; 4];
        for k in 0..4 {
            bo[k] = self.bo[k] + (o.bo[k] - self.bo[k]) * t;
        }
        Vert {
            x: self.x + (o.x - self.x) * t,
            bo,
        }
    }
    #[inline(always)]
    fn bo(&self) -> &[Real; 4] {
        &self.bo
    }
}

/// A convex polygon of at most MAX_POLY vertices (uninitialised beyond `n`: no memset per
/// clip).
pub(crate) struct Poly<V> {
    /// One slot more than a polygon holds: the clip writes every candidate vertex and
    /// counts only those it keeps (see [`Poly::clip_into`]).
    v: [std::mem::MaybeUninit<V>; MAX_POLY + 1],
    pub(crate) n: usize,
}

impl<V: ClipVertex> Poly<V> {
    #[inline(always)]
    pub(crate) fn new() -> Self {
        Poly {
            v: [const { std::mem::MaybeUninit::uninit() }; MAX_POLY + 1],
            n: 0,
        }
    }

    #[inline(always)]
    pub(crate) fn get(&self, i: usize) -> &V {
        debug_assert!(i < self.n);
        // SAFETY: vertices 0..n are always written before n grows past them.
        unsafe { self.v[i].assume_init_ref() }
    }

    #[inline(always)]
    pub(crate) fn push(&mut self, v: V) {
        if self.n < MAX_POLY {
            self.v[self.n].write(v);
            self.n += 1;
        }
    }

    /// Write into `out` the part where `s(v) ≥ 0` (values within SNAP of 0 count as on the
    /// plane).
    #[inline(always)]
    fn clip_into(&self, out: &mut Poly<V>, s: impl Fn(&V) -> Real) {
        self.clip_n_into(self.n, out, s);
    }

    /// Both sides at once: into `above` the part where `s(v) ≥ 0`, into `below` the part
    /// where `s(v) ≤ 0` (values within SNAP of 0 go to both), branch-free as
    /// [`Poly::clip_into`], whose `above` it equals bit for bit; `below` equals the clip by
    /// −s (the crossing's t = a/(a − b) is the same number for −a, −b).
    #[inline(always)]
    fn split_into(&self, below: &mut Poly<V>, above: &mut Poly<V>, s: impl Fn(&V) -> Real) {
        let n = self.n;
        below.n = 0;
        above.n = 0;
        if n == 0 {
            return;
        }
        let mut sv = [0.0; MAX_POLY + 1];
        for i in 0..n {
            let x = s(self.get(i));
            sv[i] = if x.abs() <= SNAP { 0.0 } else { x };
        }
        sv[n] = sv[0];
        let (mut ma, mut mb) = (0, 0);
        for i in 0..n {
            let (a, b) = (sv[i], sv[i + 1]);
            let j = if i + 1 == n { 0 } else { i + 1 };
            let v = *self.get(i);
            above.v[ma].write(v);
            ma = (ma + usize::from(a >= 0.0)).min(MAX_POLY);
            below.v[mb].write(v);
            mb = (mb + usize::from(a <= 0.0)).min(MAX_POLY);
            let x = v.lerp(self.get(j), a / (a - b));
            let crosses = usize::from(a * b < 0.0);
            above.v[ma].write(x);
            ma = (ma + crosses).min(MAX_POLY);
            below.v[mb].write(x);
            mb = (mb + crosses).min(MAX_POLY);
        }
        above.n = ma;
        below.n = mb;
    }

    /// [`Poly::clip_into`] for a triangle: its loops' length is known when compiled, so
    /// their exits are not mispredicted (a polygon's first loop is: its length is data).
    #[inline(always)]
    fn clip_triangle_into(&self, out: &mut Poly<V>, s: impl Fn(&V) -> Real) {
        debug_assert_eq!(self.n, 3);
        self.clip_n_into(3, out, s);
    }

    /// The clip of the first `n` vertices (`n` = `self.n`).
    #[inline(always)]
    fn clip_n_into(&self, n: usize, out: &mut Poly<V>, s: impl Fn(&V) -> Real) {
        out.n = 0;
        if n == 0 {
            return;
        }
        let mut sv = [0.0; MAX_POLY + 1];
        for i in 0..n {
            let x = s(self.get(i));
            sv[i] = if x.abs() <= SNAP { 0.0 } else { x };
        }
        sv[n] = sv[0];
        // Branch-free: every vertex and every edge's crossing is written at the next free
        // slot and counted only when kept, so the data-dependent signs cost no mispredicted
        // branches (they did: a quarter of the crossing tests, measured by callgrind's
        // branch simulation). Past MAX_POLY vertices the count stops and later ones are
        // dropped, as a push would (a valid clip never gets there: 3 + 7 planes).
        let mut m = 0;
        for i in 0..n {
            let (a, b) = (sv[i], sv[i + 1]);
            let j = if i + 1 == n { 0 } else { i + 1 };
            out.v[m].write(*self.get(i));
            m = (m + usize::from(a >= 0.0)).min(MAX_POLY);
            // Opposite signs (nonzero values exceed SNAP, so the product cannot underflow);
            // t is garbage (even NaN) when they are not, and the vertex is not counted.
            out.v[m].write(self.get(i).lerp(self.get(j), a / (a - b)));
            m = (m + usize::from(a * b < 0.0)).min(MAX_POLY);
        }
        out.n = m;
    }
}

/// Which tetrahedron a facet belongs to.
#[derive(Clone, Copy, PartialEq)]
pub(crate) enum Side {
    Contactor,
    Target,
}

/// Accumulators for one pair (before multiplying by p).
struct Acc {
    /// Σ ±n ⊗ ∫φ_other·x dA over the facets, + for facets of ∂C inside T (φ_other = φ_t),
    /// − for facets of ∂T inside C. Since every N_i is affine, N_i(x) = ∇N_i·x + N_i(0),
    /// the contactor's surface integrals are
    /// ∫_{∂C∩T} φ_t N_i^c n_c dA − ∫_{C∩∂T} φ_c N_i^c n_t dA = flux·∇N_i^c + flux0·N_i^c(0),
    /// and the target's the same with the opposite sign and its own N_j.
    flux: Mat3,
    /// Σ ±n ∫φ_other dA, signed as `flux`.
    flux0: Vec3,
    e_c: Real,
    e_t: Real,
    area: Real,
    moment: Vec3,
    depth: Real,
    /// The cones' apexes for E_c and E_t, one per region ([`RegionCones`]).
    cones_c: RegionCones,
    cones_t: RegionCones,
}

/// The apexes of the cones that give E_own = Σ_m ∫_{R_m∩Ω} 4λ_m dV region by region
/// (Ω = C∩T, R_m the own element's sub-tetrahedron where φ_own = 4λ_m): region m's apex
/// a_m lies on the element's face plane m, where its φ vanishes, so a boundary facet F of
/// R_m∩Ω adds the cone (h·A/3)·¾·φ(x̄_F), h = (x̄_F − a_m)·n_F, and a facet where φ ≈ 0
/// adds ≈ 0 whether the clipping counted it once, twice or not at all. a_m is the first
/// facet vertex found in R_m, projected onto plane m: a point within ≈ the overlap's depth
/// of the overlap, so cone heights are of the overlap's size.
///
/// (Until 2026-11-30 one apex served every region: a point of the overlap, where the
/// linear extension 4λ_m of another region's φ can be of order 1. A facet of φ = 0 clipped
/// a snap distance differently on the two sides, as the flush faces of a small block corner
/// on a large floor tet are, then left a cone of the element's size in the energy:
/// ±4.73e-3 J for a pair of 4e-10 J on a settled stack, with spurious nodal forces of a
/// quarter of the largest, docs/theory/contact.md.)
#[derive(Clone, Copy)]
pub(crate) struct RegionCones {
    apex: [Vec3; 4],
    /// Bit m: region R_m holds a facet of ∂(C∩T) (its apex is set). A kink facet between
    /// R_m and R_j can only exist when both are set.
    pub(crate) regions: u8,
}

impl RegionCones {
    #[inline(always)]
    pub(crate) fn new() -> Self {
        RegionCones {
            apex: [Vec3::zeros(); 4],
            regions: 0,
        }
    }

    /// Region m holds a facet with vertex `x`, where λ_m = `lambda_m`: returns region m's
    /// apex, set on the first call to `x` projected onto plane λ_m = 0 of `geom`.
    #[inline(always)]
    pub(crate) fn apex(&mut self, geom: &TetGeom, m: usize, x: Vec3, lambda_m: Real) -> Vec3 {
        if self.regions & (1 << m) == 0 {
            // x − λ_m ∇λ_m/|∇λ_m|², with 1/|∇λ_m| = H_m.
            let h = geom.height[m];
            self.apex[m] = x - geom.g[m] * (lambda_m * h * h);
            self.regions |= 1 << m;
        }
        self.apex[m]
    }
}

/// The six edges of a tetrahedron (node pairs).
const TET_EDGES: [[usize; 2]; 6] = [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]];
/// Candidate separating axes of a pair: 4 face planes of the contactor, 4 of the target,
/// then the 36 cross products of an edge of each.
pub const N_AXES: u8 = 44;

/// Is candidate axis `axis` (0..[`N_AXES`]) a separating axis of `c` and `t`? Two convex
/// polyhedra whose interiors are disjoint are separated by a face plane of one of them or by
/// a plane spanned by an edge of each (the separating axis theorem), so some axis answers
/// yes exactly when the tetrahedra do not overlap. Overlaps thinner than `SNAP` times the
/// elements' extent along the axis count as separated, as in the kernel's snapping.
#[inline(always)]
fn separates(c: &TetGeom, t: &TetGeom, axis: u8) -> bool {
    let axis = axis as usize;
    if axis < 8 {
        // All vertices of one element outside (or on) face plane k of the other:
        // λ_k(x) = ∇λ_k · (x − x_r) with x_r a node of face k.
        let (own, other, k) = if axis < 4 {
            (c, t, axis)
        } else {
            (t, c, axis - 4)
        };
        let g = own.g[k];
        let r = own.x[(k + 1) & 3];
        return other.x.iter().all(|x| g.dot(&(x - r)) < SNAP);
    }
    let e = axis - 8;
    let (ec, et) = (TET_EDGES[e / 6], TET_EDGES[e % 6]);
    let n = (c.x[ec[1]] - c.x[ec[0]]).cross(&(t.x[et[1]] - t.x[et[0]]));
    // Parallel edges give no new axis.
    let scale = (c.x[ec[1]] - c.x[ec[0]]).norm_squared() * (t.x[et[1]] - t.x[et[0]]).norm_squared();
    if n.norm_squared() <= 1e-12 * scale {
        return false;
    }
    // Project relative to one contactor node (no cancellation far from the origin).
    let o = c.x[0];
    let (mut c_lo, mut c_hi) = (0.0 as Real, 0.0 as Real);
    for x in &c.x[1..] {
        let s = n.dot(&(x - o));
        c_lo = c_lo.min(s);
        c_hi = c_hi.max(s);
    }
    let (mut t_lo, mut t_hi) = (Real::INFINITY, Real::NEG_INFINITY);
    for x in &t.x {
        let s = n.dot(&(x - o));
        t_lo = t_lo.min(s);
        t_hi = t_hi.max(s);
    }
    let tol = SNAP * (c_hi - c_lo).min(t_hi - t_lo);
    c_hi <= t_lo + tol || t_hi <= c_lo + tol
}

/// A separating axis of `c` and `t` if they do not overlap (see [`separates`]), trying
/// `hint` first: the axis that separated the pair last step almost always still does, so a
/// pair that stays apart costs one plane test (four dot products) per step.
/// A pair that overlapped last step (`hint` = [`OVERLAPPED`]) most likely still does: only
/// the 8 cheap face planes are tried, and a pair that separated across an edge–edge axis
/// goes through the exact kernel once (it finds no overlap) before its witness is found.
#[inline]
pub fn separating_axis(c: &TetGeom, t: &TetGeom, hint: u8) -> Option<u8> {
    if hint == OVERLAPPED {
        return (0..8).find(|&a| separates(c, t, a));
    }
    if hint < N_AXES && separates(c, t, hint) {
        return Some(hint);
    }
    (0..N_AXES).find(|&a| a != hint && separates(c, t, a))
}

/// Witness value of a pair that overlapped in the last step.
pub const OVERLAPPED: u8 = u8::MAX;

/// Contact forces of contactor `c` and target `t` with penalty `p` [Pa].
pub fn tet_tet(c: &TetGeom, t: &TetGeom, p: Real) -> PairForces {
    if separating_axis(c, t, 0).is_some() {
        return PairForces::default();
    }
    overlapping_tet_tet(c, t, p)
}

/// [`tet_tet`] for a pair no axis separates.
pub fn overlapping_tet_tet(c: &TetGeom, t: &TetGeom, p: Real) -> PairForces {
    let mut out = PairForces::default();
    // Facet geometry relative to a node of the pair: rounding then scales with the elements'
    // size, not with their distance from the origin (it sets the energy's noise floor).
    let origin = c.x[0];
    let (c, t) = (&c.shifted(origin), &t.shifted(origin));
    let bc: [[Real; 4]; 4] = t.x.map(|x| c.bary(&x)); // bc[v][k]: λ_k^c at target vertex v
    let bt: [[Real; 4]; 4] = c.x.map(|x| t.bary(&x));
    let mut acc = Acc {
        flux: Mat3::zeros(),
        flux0: Vec3::zeros(),
        e_c: 0.0,
        e_t: 0.0,
        area: 0.0,
        moment: Vec3::zeros(),
        depth: 0.0,
        cones_c: RegionCones::new(),
        cones_t: RegionCones::new(),
    };
    let (reach_c, reach_t) = (snap_reach(c), snap_reach(t));
    for k in 0..4 {
        for (own, other, b, b_other, reach_other, side) in [
            (c, t, &bt, &bc, reach_t, Side::Contactor),
            (t, c, &bc, &bt, reach_c, Side::Target),
        ] {
            if face_beyond_reach(own, k, b_other, reach_other) {
                continue;
            }
            face_pieces(own, k, b, Vert::of, |poly, m, also| {
                integrate_piece(own, other, poly, k, (m, also), side, &mut acc)
            });
        }
    }
    if acc.area <= 0.0 {
        return out;
    }
    acc.e_c += kink_energy(c, t, &bt, &acc.cones_c);
    acc.e_t += kink_energy(t, c, &bc, &acc.cones_t);
    // ∫ φ N_i n dA = Σ_facets n (∇λ_i·∫φx dA + λ_i(0)·∫φ dA): the flux sums give every node's
    // surface integral (contactor facets minus target facets, see `Acc::flux`).
    let (lc0, lt0) = (c.bary(&Vec3::zeros()), t.bary(&Vec3::zeros()));
    for i in 0..4 {
        let sc = acc.flux * c.g[i] + acc.flux0 * lc0[i];
        let st = -(acc.flux * t.g[i] + acc.flux0 * lt0[i]);
        out.fc[i] = -p * (c.g[i] * acc.e_c + sc);
        out.ft[i] = -p * (t.g[i] * acc.e_t + st);
    }
    out.energy = p * (acc.e_c + acc.e_t);
    out.area = 0.5 * acc.area;
    out.point = acc.moment / acc.area + origin;
    out.depth = acc.depth;
    out.touching = true;
    out
}

/// How far from an element the clipping's snap reaches [m]: a point within SNAP of one of
/// its planes in barycentric terms, SNAP·h for a plane at height h, counts as on it.
#[inline(always)]
fn snap_reach(g: &TetGeom) -> Real {
    SNAP * g.height.iter().fold(0.0, |a: Real, &h| a.max(h))
}

/// The other element lies wholly inside the plane of face `k` of `own`, farther from it
/// than the snap reaches on either side (`b_other_in_own[v][k]` = λ_k^own of the other's
/// vertex v, at distance λ_k·h_k from the plane; `reach_other` = [`snap_reach`] of the
/// other): the face meets nothing of the other, and its clip would come out empty. Tested
/// before the face is clipped, so the results are the same bits (−2.8 % instructions per
/// touching pair on the settled stack, docs/performance.md; test
/// `a_face_beyond_reach_has_no_pieces`).
#[inline(always)]
fn face_beyond_reach(
    own: &TetGeom,
    k: usize,
    b_other_in_own: &[[Real; 4]; 4],
    reach_other: Real,
) -> bool {
    let h = own.height[k];
    let gap = b_other_in_own
        .iter()
        .fold(Real::INFINITY, |a, bo| a.min(bo[k]))
        * h;
    gap > reach_other.max(SNAP * h)
}

impl Vert {
    /// Node `_v` of the own element, with its barycentric coordinates `bo` in the other.
    #[inline(always)]
    fn of(x: Vec3, _v: usize, bo: [Real; 4]) -> Vert {
        Vert { x, bo }
    }
}

/// Face k of `own` clipped by the other element and split by the other's sub-tetrahedra R_m (where
/// φ_other = 4λ_m is linear): calls `piece(polygon, m, also)` for each piece of at least a
/// triangle (`also`: 0, or the bit of a region that holds the piece too, through the kink
/// piece it lies on, [`split_regions`]). `b_own_in_other[v][j]` = λ_j^other(own vertex v);
/// `vertex(x, v, bo)` makes the polygon vertex of own node v.
#[inline(always)]
pub(crate) fn face_pieces<V: ClipVertex>(
    own: &TetGeom,
    k: usize,
    b_own_in_other: &[[Real; 4]; 4],
    vertex: impl Fn(Vec3, usize, [Real; 4]) -> V,
    mut piece: impl FnMut(&Poly<V>, usize, u8),
) {
    let f = TET_FACES[k];
    let tri_bo = f.map(|v| b_own_in_other[v]);
    let planes = PlaneMasks::of(&tri_bo);
    // A face lying in a plane of the other is kept, and so is its coincident partner (the
    // touching faces of two blocks, opposite normals; or the flush sides of matching meshes,
    // the same normal: that facet of the overlap is then counted twice). Both elements' φ
    // vanish there, so it adds nothing to the surface integrals, nor to the energy's cones
    // (their apexes lie where φ vanishes, `RegionCones`), whether one or both count it.
    if planes.outside() {
        return;
    }
    let mut a = Poly::new();
    let mut b = Poly::new();
    for (&v, bo) in f.iter().zip(tri_bo) {
        a.push(vertex(own.x[v], v, bo));
    }
    let Some(poly) = clip_to_other(&mut a, &mut b, planes.cut) else {
        return;
    };
    // Split by the other's regions R_m = {λ_m ≤ λ_j ∀j} ([`split_regions`]), skipping
    // first the regions one plane λ_j = λ_m leaves nothing of (decided from the vertex
    // values, with the clipping's own snapping). Range of λ_j − λ_m over the vertices, once
    // per unordered pair m < j (that of λ_m − λ_j is its exact negation).
    // (One loop over the vertices, the six kinks inside it: one data-dependent loop exit.)
    let mut lo6 = [Real::INFINITY; 6];
    let mut hi6 = [Real::NEG_INFINITY; 6];
    for i in 0..poly.n {
        let b = poly.get(i).bo();
        for (q, (m, j)) in KINKS.into_iter().enumerate() {
            let s = b[j] - b[m];
            lo6[q] = lo6[q].min(s);
            hi6[q] = hi6[q].max(s);
        }
    }
    let mut range = [[(0.0, 0.0); 4]; 4];
    for (q, (m, j)) in KINKS.into_iter().enumerate() {
        range[m][j] = (lo6[q], hi6[q]);
        range[j][m] = (-hi6[q], -lo6[q]);
    }
    // The regions one plane leaves nothing of; decided for all four at once, without a
    // branch per plane.
    let mut empty = 0u8;
    for m in 0..4 {
        for j in 0..4 {
            let (lo, hi) = range[m][j];
            let here = j != m;
            // Nothing of the polygon has λ_m ≤ λ_j.
            empty |= u8::from(here & (hi <= SNAP) & (lo < -SNAP)) << m;
        }
    }
    split_regions(
        poly,
        !empty & 0b1111,
        &b_own_in_other[k],
        (4, 0),
        &mut piece,
    );
}

/// Split `poly` among the other element's regions `cand` (bit m: R_m may hold a part of
/// it) and call `piece(part, m)` for each part of at least a triangle. Two candidates a < b
/// are compared by s = λ_b − λ_a over the vertices: one that is nowhere below the other
/// (beyond SNAP) is dropped, else the polygon is cut by s = 0 into the side where λ_a ≤ λ_b
/// (b dropped) and the side where λ_b ≤ λ_a (a dropped), each split on: one cut gives both
/// sides, where clipping each region by its own planes cuts twice (−5 % instructions and
/// −23 % mispredicted branches per touching pair, docs/performance.md). A polygon lying in
/// the plane (|s| ≤ SNAP throughout) goes to both, as clipping each region would. At most
/// three levels (four regions). Test: `the_region_split_equals_clipping_each_region`.
fn split_regions<V: ClipVertex>(
    poly: &Poly<V>,
    mut cand: u8,
    inward: &[Real; 4],
    mut also: (usize, u8),
    piece: &mut impl FnMut(&Poly<V>, usize, u8),
) {
    loop {
        if cand & cand.wrapping_sub(1) == 0 {
            if cand != 0 {
                let m = cand.trailing_zeros() as usize;
                piece(poly, m, if m == also.0 { also.1 } else { 0 });
            }
            return;
        }
        let a = cand.trailing_zeros() as usize;
        let b = (cand & (cand - 1)).trailing_zeros() as usize;
        let (mut lo, mut hi) = (Real::INFINITY, Real::NEG_INFINITY);
        for i in 0..poly.n {
            let bo = poly.get(i).bo();
            let s = bo[b] - bo[a];
            lo = lo.min(s);
            hi = hi.max(s);
        }
        match (lo >= -SNAP, hi <= SNAP) {
            // In the plane λ_a = λ_b (within SNAP): the overlap lies on one side of it, in
            // the region that holds the own element's opposite node (`inward`: λ_a ≤ λ_b
            // there, R_a). The facet goes to the other region, R_out, once; the kink
            // piece between the two (the same polygon, `kink_energy`) cancels its cone in
            // R_out and stands in for it in R_in, which is marked as holding a facet so
            // that the kink is clipped. Giving it to both counted it twice (+35 % energy
            // on a tet with a face in the other's kink plane).
            (true, true) => {
                let (inner, outer) = if inward[b] - inward[a] >= 0.0 {
                    (a, b)
                } else {
                    (b, a)
                };
                cand &= !(1 << inner);
                also = (outer, 1 << inner);
                continue;
            }
            (true, false) => {
                cand &= !(1 << b);
                continue;
            }
            (false, true) => {
                cand &= !(1 << a);
                continue;
            }
            (false, false) => {}
        }
        let mut below = Poly::new();
        let mut above = Poly::new();
        poly.split_into(&mut below, &mut above, |v| v.bo()[b] - v.bo()[a]);
        if above.n >= 3 {
            split_regions(&above, cand & !(1 << b), inward, also, piece);
        }
        if below.n >= 3 {
            split_regions(&below, cand & !(1 << a), inward, also, piece);
        }
        return;
    }
}

/// The kink facets' part of E_own = ∫_{C∩T} φ_own dV. E_own is summed region by region of
/// `own` (φ_own = 4λ_m on its sub-tetrahedron R_m, cones from apexes a_m on the face planes,
/// [`RegionCones`]), and the boundary of R_m ∩ (C∩T) includes the pieces of the kink
/// triangles λ_m = λ_j (the centroid and the edge shared by faces m and j) inside the other
/// element. A piece of area A and centroid x̄ lies in the plane with unit normal
/// ν = (g_m − g_j)/|g_m − g_j| (out of R_m); it bounds R_m and R_j with opposite normals
/// and equal φ = 4λ_m(x̄), so its two cones, (x̄ − a_m)·ν·A·λ_m(x̄) and
/// −(x̄ − a_j)·ν·A·λ_m(x̄), add A·λ_m(x̄)·(a_j − a_m)·ν. Only kinks between two regions that
/// hold facets of ∂(C∩T) are clipped: a piece of the overlap in R_m is bounded by some facet
/// of ∂(C∩T), since the kink planes alone meet only at the centroid.
/// (Closing each region's facets to get the kink areas without clipping was tried: it turns
/// every facet's rounding into kink area, a hundred times the energy of a thin wedge.)
pub(crate) fn kink_energy(
    own: &TetGeom,
    other: &TetGeom,
    b_own_in_other: &[[Real; 4]; 4],
    cones: &RegionCones,
) -> Real {
    let regions = cones.regions;
    let b_centroid = other.bary(&own.centroid);
    // The kinks between two regions that hold facets, decided for all six at once (a
    // branch each mispredicted often), walked by their set bits.
    let mut live = 0u8;
    for (i, (m, j)) in KINKS.into_iter().enumerate() {
        live |= ((regions >> m) & (regions >> j) & 1) << i;
    }
    let mut sum = 0.0;
    while live != 0 {
        let i = live.trailing_zeros() as usize;
        live &= live - 1;
        let ((m, j), (p, q)) = (KINKS[i], KINK_EDGES[i]);
        let tri_bo = [b_centroid, b_own_in_other[p], b_own_in_other[q]];
        let planes = PlaneMasks::of(&tri_bo);
        if planes.outside() {
            continue;
        }
        let nu = (own.g[m] - own.g[j]).normalize();
        let (area, first) =
            clipped_area([own.centroid, own.x[p], own.x[q]], tri_bo, planes.cut, &nu);
        if area == 0.0 {
            continue;
        }
        // A·λ_m(x̄) = ∫λ_m dA = g_m·(∫x dA) + λ_m(0)·A (λ_m affine).
        let lambda_m_area = own.g[m].dot(&(first - own.x[p] * area));
        sum += lambda_m_area * (cones.apex[j] - cones.apex[m]).dot(&nu);
    }
    sum
}

/// Area [m²] and first moment ∫x dA [m³] of the triangle `x` (barycentric coordinates
/// `bo` of its vertices in the other element, `cut` its [`PlaneMasks::cut`]) inside the
/// other element, measured along the triangle's normal `n`.
#[inline(always)]
fn clipped_area(x: [Vec3; 3], bo: [[Real; 4]; 3], cut: u8, n: &Vec3) -> (Real, Vec3) {
    let mut a = Poly::new();
    let mut b = Poly::new();
    for (x, bo) in x.into_iter().zip(bo) {
        a.push(Vert { x, bo });
    }
    let Some(p) = clip_to_other(&mut a, &mut b, cut) else {
        return (0.0, Vec3::zeros());
    };
    let v0 = p.get(0).x;
    let mut area = 0.0;
    let mut first = Vec3::zeros();
    for t in 1..p.n - 1 {
        let (xb, xc) = (p.get(t).x, p.get(t + 1).x);
        let at = 0.5 * (xb - v0).cross(&(xc - v0)).dot(n);
        area += at;
        first += (v0 + xb + xc) * (at / 3.0);
    }
    if area < 0.0 {
        (-area, -first)
    } else {
        (area, first)
    }
}

/// Where a triangle lies against the other element's four face planes λ_l = 0 (bit l),
/// from its vertex values (their barycentric coordinates in the other element), decided
/// without a branch per vertex or plane (short-circuit tests here were a tenth of the
/// kernel's mispredicted branches).
#[derive(Clone, Copy)]
struct PlaneMasks {
    /// Some vertex lies outside plane l (λ_l < −SNAP): the clipping must cut by it.
    cut: u8,
    /// No vertex lies inside plane l (every λ_l ≤ SNAP).
    not_inside: u8,
}

impl PlaneMasks {
    #[inline(always)]
    fn of(bo: &[[Real; 4]; 3]) -> Self {
        let (mut cut, mut not_inside) = (0u8, 0u8);
        for l in 0..4 {
            let (a, b, c) = (bo[0][l], bo[1][l], bo[2][l]);
            cut |= (u8::from(a < -SNAP) | u8::from(b < -SNAP) | u8::from(c < -SNAP)) << l;
            not_inside |= (u8::from(a <= SNAP) & u8::from(b <= SNAP) & u8::from(c <= SNAP)) << l;
        }
        PlaneMasks { cut, not_inside }
    }

    /// The triangle lies outside, or on, one plane of the other: nothing of it is inside.
    #[inline(always)]
    fn outside(&self) -> bool {
        self.cut & self.not_inside != 0
    }
}

/// The triangle in `a` clipped by the other element's planes that cut it (`cut`, bit l:
/// [`PlaneMasks::cut`]; a plane no vertex lies outside of keeps all, snapped values
/// included), ping-ponging between `a` and `b`; None when less than a triangle is left.
#[inline(always)]
fn clip_to_other<'p, V: ClipVertex>(
    a: &'p mut Poly<V>,
    b: &'p mut Poly<V>,
    cut: u8,
) -> Option<&'p Poly<V>> {
    let (mut cur, mut next) = (a, b);
    let mut planes = cut;
    while planes != 0 {
        let l = planes.trailing_zeros() as usize;
        let first = planes == cut;
        planes &= planes - 1;
        if first {
            cur.clip_triangle_into(next, |v| v.bo()[l]);
        } else {
            cur.clip_into(next, |v| v.bo()[l]);
        }
        std::mem::swap(&mut cur, &mut next);
        if cur.n < 3 {
            return None;
        }
    }
    Some(cur)
}

/// The six kink planes of a tetrahedron's φ: λ_m = λ_j for m < j.
const KINKS: [(usize, usize); 6] = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)];

/// For each kink plane of [`KINKS`], the two nodes other than m and j (the edge faces m
/// and j share).
const KINK_EDGES: [(usize, usize); 6] = [(2, 3), (1, 3), (1, 2), (0, 3), (0, 2), (0, 1)];

/// One planar facet on face k of `own` (outward normal n_k), inside region m of `other`
/// (φ_other = 4λ_m): its area, first moment and depth, its surface integrals ∫φ_other dA
/// and ∫φ_other·x dA into the flux sums, and its cone from the other's apex of region m for
/// E_other (`also`: a region of `other` that holds the facet too, [`split_regions`]).
#[inline(always)]
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
    // Per vertex: φ_other, and the depth (distance to the nearest face of the other),
    // vertex c's inside the fan's loop (one loop: its exit is a mispredicted branch).
    let phi = |i: usize| 4.0 * poly.get(i).bo[m];
    let depth = |i: usize| {
        let bo = &poly.get(i).bo;
        (0..4)
            .map(|k| bo[k] * other.height[k])
            .fold(Real::INFINITY, Real::min)
    };
    acc.depth = acc.depth.max(depth(0)).max(depth(1));
    let x0 = poly.get(0).x;
    let pa = phi(0);
    let mut area = 0.0;
    let mut first = Vec3::zeros(); // ∫ x dA
    let mut i_phi = 0.0; // ∫ φ dA
    let mut i_phi_x = Vec3::zeros(); // ∫ φ x dA
    for tri in 1..poly.n - 1 {
        let (b, c) = (tri, tri + 1);
        acc.depth = acc.depth.max(depth(c));
        let (xb, xc) = (poly.get(b).x, poly.get(c).x);
        let at = 0.5 * (xb - x0).cross(&(xc - x0)).dot(&n);
        if at == 0.0 {
            continue;
        }
        area += at;
        let sx = x0 + xb + xc;
        first += sx * (at / 3.0);
        let (pb, pc) = (phi(b), phi(c));
        let sphi = pa + pb + pc;
        i_phi += at * sphi / 3.0;
        // ∫ f g = A/12 · (Σ f_v g_v + Σf · Σg) for linear f, g on a triangle.
        i_phi_x += (x0 * pa + xb * pb + xc * pc + sx * sphi) * (at / 12.0);
    }
    if area <= 0.0 {
        return;
    }
    acc.area += area;
    acc.moment += first;
    // The facet lies on face k of `own`, where φ_own = 0 (its cone adds nothing to E_own;
    // region k's apex is a vertex of it), and in region m of `other`, where
    // φ_other = 4λ_m: the cone from that region's apex a_m (φ_other(a_m) = 0) adds
    // (h·A/3)·¾·φ_other(x̄) = h·∫φ_other dA / 4, h = (x − a_m)·n for any x of the facet.
    let (own_cones, oth_cones, e_oth_sum, sign) = match side {
        Side::Contactor => (&mut acc.cones_c, &mut acc.cones_t, &mut acc.e_t, 1.0),
        Side::Target => (&mut acc.cones_t, &mut acc.cones_c, &mut acc.e_c, -1.0),
    };
    own_cones.apex(own, k, x0, 0.0);
    let apex = oth_cones.apex(other, m, x0, poly.get(0).bo[m]);
    if also != 0 {
        // The facet lies in the kink plane between R_m and region `also` (see
        // `split_regions`): that region holds it too, through the kink piece.
        let j = also.trailing_zeros() as usize;
        oth_cones.apex(other, j, x0, poly.get(0).bo[j]);
    }
    *e_oth_sum += (x0 - apex).dot(&n) * i_phi * 0.25;
    acc.flux += (n * sign) * i_phi_x.transpose();
    acc.flux0 += n * (sign * i_phi);
}

/// The kernel against the test oracle on one pair: (max_i |F_i − F_i^oracle| over the 8
/// nodes / the largest oracle force (0 when neither touches), |E − E^oracle| [J],
/// E^oracle [J]).
pub fn deviation(c: &TetGeom, t: &TetGeom, p: Real) -> (Real, Real, Real) {
    let (r, o) = (
        overlapping_tet_tet(c, t, p),
        super::oracle::overlapping_tet_tet(c, t, p),
    );
    let forces = |f: &PairForces| f.fc.into_iter().chain(f.ft);
    let scale = forces(&o).map(|f| f.norm()).fold(0.0, Real::max);
    let df = forces(&r)
        .zip(forces(&o))
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, Real::max);
    (
        if df == 0.0 { 0.0 } else { df / scale },
        (r.energy - o.energy).abs(),
        o.energy,
    )
}

/// The kernel on one pair against the same pair with contactor and target swapped (E is
/// symmetric in them; the clipping, the order of the facets and the cones' apexes are not):
/// (max_i |F_i − F_i^swapped| over the 8 nodes [N], max_i |F_i| [N], |E − E^swapped| [J],
/// E [J]).
pub fn swap_deviation(c: &TetGeom, t: &TetGeom, p: Real) -> (Real, Real, Real, Real) {
    let (r, s) = (overlapping_tet_tet(c, t, p), overlapping_tet_tet(t, c, p));
    let scale =
        r.fc.iter()
            .chain(&r.ft)
            .map(|f| f.norm())
            .fold(0.0, Real::max);
    let df =
        r.fc.iter()
            .zip(&s.ft)
            .chain(r.ft.iter().zip(&s.fc))
            .map(|(a, b)| (a - b).norm())
            .fold(0.0, Real::max);
    (df, scale, (r.energy - s.energy).abs(), r.energy)
}

/// Contact energy p·∫(φ_c + φ_t) dV by brute-force quadrature (for tests): φ sampled on a
/// regular grid of `n³` points over the contactor's bounding box.
pub fn energy_by_sampling(c: &TetGeom, t: &TetGeom, p: Real, n: usize) -> Real {
    let phi = |g: &TetGeom, x: &Vec3| {
        let b = g.bary(x);
        let m = b.iter().cloned().fold(Real::INFINITY, Real::min);
        if m >= 0.0 {
            Some(4.0 * m)
        } else {
            None
        }
    };
    let lo =
        c.x.iter()
            .fold(Vec3::repeat(Real::INFINITY), |a, x| a.inf(x));
    let hi =
        c.x.iter()
            .fold(Vec3::repeat(Real::NEG_INFINITY), |a, x| a.sup(x));
    let h = (hi - lo) / n as Real;
    let dv = h.x * h.y * h.z;
    let mut sum = 0.0;
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let x = lo
                    + Vec3::new(
                        (i as Real + 0.5) * h.x,
                        (j as Real + 0.5) * h.y,
                        (k as Real + 0.5) * h.z,
                    );
                if let (Some(a), Some(b)) = (phi(c, &x), phi(t, &x)) {
                    sum += a + b;
                }
            }
        }
    }
    p * sum * dv
}

#[cfg(test)]
mod tests {
    use super::*;

    fn geom(x: [[Real; 3]; 4]) -> TetGeom {
        let mut p = x.map(|a| Vec3::new(a[0], a[1], a[2]));
        if crate::math::tet_volume(&p[0], &p[1], &p[2], &p[3]) < 0.0 {
            p.swap(1, 2);
        }
        TetGeom::new(p).unwrap()
    }

    /// Deterministic pseudo-random numbers (xorshift), so the cases are reproducible.
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> Real {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 11) as Real / (1u64 << 53) as Real
        }
        fn tet(&mut self, centre: Vec3, size: Real) -> TetGeom {
            loop {
                let x = [(); 4].map(|_| {
                    centre
                        + Vec3::new(self.next() - 0.5, self.next() - 0.5, self.next() - 0.5) * size
                });
                let v = crate::math::tet_volume(&x[0], &x[1], &x[2], &x[3]).abs();
                // Reasonably shaped only (volume ≥ 1 % of the cube of the size).
                if v > 0.01 * size.powi(3) {
                    return geom(x.map(|p| [p.x, p.y, p.z]));
                }
            }
        }
    }

    /// The plane masks decide as the plain definitions do, on values at and around the
    /// snapping bounds ±SNAP, 0 and ±1 (the masks replaced short-circuit `any`/`all` tests,
    /// so any slip in a comparison or a bit would show here): for every one of 7⁶ triangles
    /// of two planes' values and a random pair of planes, cut = some vertex < −SNAP,
    /// not_inside = every vertex ≤ SNAP, outside = both for
    /// one plane.
    #[test]
    fn plane_masks_match_their_definitions() {
        let values = [-1.0, -2.0 * SNAP, -SNAP, 0.0, SNAP, 2.0 * SNAP, 1.0];
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let mut outside_seen = [0usize; 2];
        for code in 0..values.len().pow(6) {
            let (l1, l2) = (
                (rng.next() * 4.0) as usize % 4,
                (rng.next() * 4.0) as usize % 4,
            );
            let mut bo = [[0.5; 4]; 3];
            let mut c = code;
            for v in &mut bo {
                v[l1] = values[c % 7];
                c /= 7;
                v[l2] = values[c % 7];
                c /= 7;
            }
            let m = PlaneMasks::of(&bo);
            for l in 0..4 {
                let bit = |mask: u8| mask & (1 << l) != 0;
                assert_eq!(bit(m.cut), bo.iter().any(|b| b[l] < -SNAP), "{bo:?} {l}");
                assert_eq!(
                    bit(m.not_inside),
                    bo.iter().all(|b| b[l] <= SNAP),
                    "{bo:?} {l}"
                );
            }
            let outside =
                (0..4).any(|l| bo.iter().all(|b| b[l] <= SNAP) && bo.iter().any(|b| b[l] < -SNAP));
            assert_eq!(m.outside(), outside, "{bo:?}");
            outside_seen[usize::from(outside)] += 1;
        }
        // Both answers occur often (the test is not vacuous).
        assert!(outside_seen.iter().all(|&n| n > 1000), "{outside_seen:?}");
    }

    /// Random overlapping pairs: the exact energy agrees with brute-force quadrature of
    /// p∫(φ_c + φ_t) over a 160³ grid. The midpoint rule on a discontinuous (at the overlap
    /// boundary) integrand converges as O(1/n): 2 % covers it for overlaps that are not tiny.
    #[test]
    fn energy_matches_quadrature() {
        let mut rng = Rng(0x9e3779b97f4a7c15);
        let mut checked = 0;
        while checked < 6 {
            let c = rng.tet(Vec3::zeros(), 1.0);
            let t = rng.tet(Vec3::new(0.3, 0.1, -0.2), 1.0);
            let exact = tet_tet(&c, &t, 1.0).energy;
            // Skip overlaps too small for the grid to resolve.
            if exact < 1e-3 * c.volume.abs() {
                continue;
            }
            let sampled = energy_by_sampling(&c, &t, 1.0, 160);
            assert!(
                (exact - sampled).abs() < 0.02 * sampled,
                "exact {exact:.6e} sampled {sampled:.6e}"
            );
            checked += 1;
        }
    }

    /// Every nodal force is −∂E/∂x by central differences (h = 1e-7 of the size, relative
    /// error 1e-5: E is smooth away from measure-zero configurations, and the difference
    /// error is O(h²·E''') ≈ 1e-12 against forces of order 1e-2).
    #[test]
    fn forces_are_the_energy_gradient() {
        let mut rng = Rng(12345);
        let mut checked = 0;
        while checked < 20 {
            let c = rng.tet(Vec3::zeros(), 1.0);
            let t = rng.tet(Vec3::new(0.25, -0.2, 0.15), 1.0);
            let r = tet_tet(&c, &t, 1.0);
            if r.energy < 1e-4 {
                continue;
            }
            let scale =
                r.fc.iter()
                    .chain(&r.ft)
                    .map(|f| f.norm())
                    .fold(0.0, Real::max);
            let h = 1e-7;
            for (which, node, dim) in
                (0..2).flat_map(|w| (0..4).flat_map(move |n| (0..3).map(move |d| (w, n, d))))
            {
                let energy = |delta: Real| {
                    let (mut xc, mut xt) = (c.x, t.x);
                    if which == 0 {
                        xc[node][dim] += delta;
                    } else {
                        xt[node][dim] += delta;
                    }
                    tet_tet(&TetGeom::new(xc).unwrap(), &TetGeom::new(xt).unwrap(), 1.0).energy
                };
                let fd = -(energy(h) - energy(-h)) / (2.0 * h);
                let f = if which == 0 {
                    r.fc[node][dim]
                } else {
                    r.ft[node][dim]
                };
                assert!(
                    (fd - f).abs() < 1e-5 * scale,
                    "pair {checked}, {} node {node} dim {dim}: force {f:.9e}, −dE/dx {fd:.9e}",
                    if which == 0 { "contactor" } else { "target" }
                );
            }
            checked += 1;
        }
    }

    /// The separating-axis rejection agrees with the exact kernel: a pair is rejected exactly
    /// when the overlap energy is zero (to the snapping tolerance), whichever witness is tried
    /// first. Random pairs at distances where face–face, edge–edge and overlapping
    /// configurations all occur; the kernel alone is the reference.
    #[test]
    fn separating_axis_agrees_with_the_kernel() {
        let mut rng = Rng(4242);
        let (mut separated, mut overlapping, mut by_edges) = (0, 0, 0);
        for case in 0..4000 {
            let c = rng.tet(Vec3::zeros(), 1.0);
            let off = Vec3::new(rng.next() - 0.5, rng.next() - 0.5, rng.next() - 0.5) * 1.4;
            let t = rng.tet(off, 1.0);
            let r = overlapping_tet_tet(&c, &t, 1.0);
            let hint = (case % (N_AXES as usize + 1)) as u8; // every axis, and OVERLAPPED
            let hint = if hint == N_AXES { OVERLAPPED } else { hint };
            let sep = separating_axis(&c, &t, hint);
            let full = separating_axis(&c, &t, 0);
            // OVERLAPPED tries face planes only, so it may miss an edge–edge separation.
            if hint != OVERLAPPED {
                assert_eq!(
                    sep.is_some(),
                    full.is_some(),
                    "case {case}: hint changed the answer"
                );
            }
            match full {
                Some(axis) => {
                    separated += 1;
                    if axis >= 8 {
                        by_edges += 1;
                    }
                    assert!(
                        r.energy <= 1e-12,
                        "case {case}: axis {axis} separates, but the overlap energy is {:e}",
                        r.energy
                    );
                }
                None => {
                    overlapping += 1;
                    assert!(
                        r.touching && r.energy > 0.0,
                        "case {case}: no separating axis, no overlap"
                    );
                }
            }
        }
        println!(
            "{separated} separated ({by_edges} by an edge–edge axis), {overlapping} overlapping"
        );
        assert!(separated > 500 && overlapping > 500 && by_edges > 20);
    }

    /// Action = reaction and no net moment, to rounding.
    #[test]
    fn forces_balance() {
        let mut rng = Rng(777);
        for _ in 0..50 {
            let c = rng.tet(Vec3::zeros(), 1.0);
            let t = rng.tet(Vec3::new(0.3, 0.3, 0.0), 1.0);
            let r = tet_tet(&c, &t, 1.0);
            let scale = r.fc.iter().map(|f| f.norm()).sum::<Real>() + 1e-300;
            let sum: Vec3 = r.fc.iter().chain(&r.ft).sum();
            let moment: Vec3 = (0..4)
                .map(|i| c.x[i].cross(&r.fc[i]) + t.x[i].cross(&r.ft[i]))
                .sum();
            assert!(sum.norm() < 1e-12 * scale, "{sum:?}");
            assert!(moment.norm() < 1e-11 * scale, "{moment:?}");
        }
    }

    /// Two tets sharing a face exactly (the start of every cut box): no energy, no force,
    /// whichever is the contactor. Pushed together by d, E grows as 2pA·d²·(1/H_c + 1/H_t)
    /// for a thin slab (φ = 4·dist/H near each face), so small d gives a small, continuous
    /// force.
    #[test]
    fn coincident_faces_touch_without_force() {
        let a = geom([
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ]);
        let b = geom([
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.2, 0.3, -1.0],
        ]);
        for (c, t) in [(&a, &b), (&b, &a)] {
            let r = tet_tet(c, t, 1.0);
            assert!(r.energy.abs() < 1e-14, "{}", r.energy);
            for f in r.fc.iter().chain(&r.ft) {
                assert!(f.norm() < 1e-12);
            }
        }
        // Push b up by d: the overlap is a prism-like slab under the shared face.
        let (h_a, h_b) = (1.0, 1.0); // heights over the shared face (z = 0): a's apex z = 1, b's −1
        let area = 0.5;
        for d in [1e-6, 1e-4, 1e-3] {
            let bx = b.x.map(|p| p + Vec3::new(0.0, 0.0, d));
            let r = tet_tet(&a, &TetGeom::new(bx).unwrap(), 1.0);
            let slab = 2.0 * area * d * d * (1.0 / h_a + 1.0 / h_b);
            assert!(
                (r.energy - slab).abs() < 0.02 * slab,
                "d = {d}: E = {:.6e}, slab {slab:.6e}",
                r.energy
            );
            let f: Vec3 = r.ft.iter().sum();
            let slab_force = 4.0 * area * d * (1.0 / h_a + 1.0 / h_b);
            assert!(
                (f.z + slab_force).abs() < 0.03 * slab_force,
                "d = {d}: F = {f:?} vs {slab_force}"
            );
        }
    }

    /// A thin overlap between parallel faces, as a block resting under gravity at the default
    /// penalty makes (d/H ≈ σ/(8p), 1e-8 to 1e-6): the contactor's face sinks d below the
    /// target's face, the two triangles coincident (matching meshes: every lateral plane
    /// shared) or offset (non-matching), away from the origin. Away from the overlap's
    /// edges φ_c = 4s/H_c and φ_t = 4(d − s)/H_t across the layer, so
    /// E = 2p·A·d²·(1/H_c + 1/H_t) (A the overlap area); the edges change it by O(d/H).
    /// Tolerance 1e-3 at d/H ≤ 1e-4, where the edge correction is below 1e-3, and the
    /// rounding of the facets' heights over the apexes (≈ ulp(H)/d relative) is below 1e-6.
    /// Before the cones were taken from a point of the overlap (they came from each element's
    /// centroid, cancelling to (d/H)² of their size) the coincident case gave 1e6 times
    /// the energy at d/H = 1e-7.
    #[test]
    fn thin_overlaps_have_the_thin_layer_energy() {
        let origin = Vec3::new(1.3, -0.7, 2.1);
        let h = 0.05;
        let tri = |o: Vec3, z: Real| {
            [
                o + Vec3::new(0.0, 0.0, z),
                o + Vec3::new(h, 0.0, z),
                o + Vec3::new(0.0, h, z),
            ]
        };
        for offset in [Vec3::zeros(), Vec3::new(0.013, 0.007, 0.0)] {
            for rel in [1e-4, 1e-5, 1e-6, 1e-7] {
                let d = rel * h;
                let t = tri(origin, 0.0);
                let target = geom(
                    [t[0], t[1], t[2], origin + Vec3::new(0.0, 0.0, -h)].map(|p| [p.x, p.y, p.z]),
                );
                let c = tri(origin + offset, -d);
                let contactor = geom(
                    [c[0], c[1], c[2], origin + offset + Vec3::new(0.0, 0.0, h)]
                        .map(|p| [p.x, p.y, p.z]),
                );
                // Overlap of the two right triangles of legs h, the second shifted by (a, b).
                let (a, b) = (offset.x, offset.y);
                let leg = h - a - b;
                let area = 0.5 * leg * leg;
                let expected = 2.0 * area * d * d * (2.0 / h);
                for (x, y) in [(&contactor, &target), (&target, &contactor)] {
                    let r = tet_tet(x, y, 1.0);
                    assert!(
                        (r.energy - expected).abs() < 1e-3 * expected,
                        "offset {:?}, d/H = {rel:e}: E = {:e}, thin layer {expected:e}",
                        offset.as_slice(),
                        r.energy
                    );
                    let f: Real = r.fc.iter().map(|f| f.z).sum::<Real>().abs();
                    let f_layer = 4.0 * area * d * (2.0 / h);
                    assert!((f - f_layer).abs() < 1e-3 * f_layer, "{f:e} vs {f_layer:e}");
                }
            }
        }
    }

    /// The wedge a contactor edge cuts into a target face (from a block resting on a
    /// non-matching base: one node 1.65e-8 m under the face, the other 2.6e-9 m above it,
    /// the contactor's faces at the edge vertical and at 45°). E = p∫(φ_c + φ_t) over the
    /// wedge is below p·V·8·depth/H_min, V ≤ area·depth. It used to be 8.7e-7 J at p = 1e9
    /// (a hundred million times the bound): a point of the target face within the snap
    /// distance of both contactor planes closed the facets inconsistently, and centroid
    /// cones turned that into energy.
    #[test]
    fn an_edge_grazing_a_face_has_a_wedge_energy() {
        let t = geom([
            [0.0, 0.05, -0.05],
            [0.0, 0.1, 0.0],
            [0.0, 0.05, 0.0],
            [0.05, 0.1, 0.0],
        ]);
        let c = geom([
            [
                0.012999767019656308,
                0.05699980359554877,
                -1.6515953525504632e-8,
            ],
            [
                0.012999767258052825,
                0.1069998865027984,
                2.635831430937902e-9,
            ],
            [
                0.013000010198471397,
                0.10699992776457226,
                0.04999971108143207,
            ],
            [
                0.06300001309575988,
                0.10699996191731223,
                0.049999580784970965,
            ],
        ]);
        let p = 1e9;
        for (x, y) in [(&c, &t), (&t, &c)] {
            let r = tet_tet(x, y, p);
            let h_min = x
                .height
                .iter()
                .chain(&y.height)
                .fold(1.0 as Real, |a, &b| a.min(b));
            let bound = 8.0 * p * r.area * r.depth * r.depth / h_min;
            assert!(r.touching);
            assert!(
                r.energy >= 0.0 && r.energy <= bound,
                "E = {:e} J, bound {bound:e} J",
                r.energy
            );
        }
    }

    /// A block's corner tet resting on a floor tet (two pairs of a settled stack, p = 1e10):
    /// the overlap is a layer 0.4–1.5 nm thin under the block tet's bottom face, and both
    /// elements have a face in the plane x = y (or x − y = −0.2) with the same outward
    /// normal, the block's (0.03 m) within SNAP of the floor tet's plane, the floor tet's
    /// (0.1 m) not within SNAP of the block's. References: the thin-layer energy
    /// E = 2p∫d²dA·(1/H_c + 1/H_t) over the block tet's bottom triangle, d linear between
    /// its nodes' depths (5 %: the layer's edges change it by O(d/L) and the tilt of the
    /// bottom face by its slope²), and the same pair with the roles of contactor and
    /// target swapped (E is symmetric in them): the forces on every node agree to 1e-8 of
    /// the largest. Cones from one apex for all regions gave E = −4.73e-3 J as (c, t) for
    /// the first pair and +4.73e-3 J for the second with the flush-face rule changed, and
    /// nodal forces 0.15 N off against 0.55 N.
    #[test]
    fn a_nearly_flush_face_pair_is_the_same_either_way_round() {
        let tet = |x: [[Real; 3]; 4]| TetGeom::new(x.map(|a| Vec3::new(a[0], a[1], a[2]))).unwrap();
        let pairs = [
            (
                [
                    [0.09999999999999998, 0.09999999999999998, -0.1],
                    [0.09999999999999998, 0.09999999999999998, 0.0],
                    [0.19999999999999998, 0.09999999999999998, 0.0],
                    [0.19999999999999998, 0.19999999999999998, 0.0],
                ],
                [
                    [
                        0.10000000000016403,
                        0.10000000000018484,
                        -1.5382791911724457e-9,
                    ],
                    [
                        0.13333333333529387,
                        0.100000000002302,
                        -1.2351410704881635e-9,
                    ],
                    [
                        0.13333333333818448,
                        0.13333333333818054,
                        -3.775487902806805e-10,
                    ],
                    [
                        0.13333333332941222,
                        0.13333333332941236,
                        0.04999999473309036,
                    ],
                ],
            ),
            (
                [
                    [0.09999999999999998, 0.29999999999999993, -0.1],
                    [0.09999999999999998, 0.29999999999999993, 0.0],
                    [0.19999999999999998, 0.29999999999999993, 0.0],
                    [0.19999999999999998, 0.3999999999999999, 0.0],
                ],
                [
                    [
                        0.10000000000017911,
                        0.3000000000001719,
                        -1.538297007730977e-9,
                    ],
                    [
                        0.13333333333530042,
                        0.30000000000220284,
                        -1.2351790708252008e-9,
                    ],
                    [
                        0.13333333333818456,
                        0.3333333333382333,
                        -3.774872746106322e-10,
                    ],
                    [0.1333333333294123, 0.33333333332941284, 0.04999999473309021],
                ],
            ),
        ];
        let p = 1e10;
        for (n, (xc, xt)) in pairs.into_iter().enumerate() {
            let (c, t) = (tet(xc), tet(xt));
            // Thin layer: ∫d² over a triangle with d linear = A·(Σd_i² + Σ_{i<j} d_i d_j)/6.
            let d = [0, 1, 2].map(|i| -t.x[i].z);
            let area = 0.5 * (t.x[1] - t.x[0]).cross(&(t.x[2] - t.x[0])).norm();
            let d2 = area
                * (d[0] * d[0]
                    + d[1] * d[1]
                    + d[2] * d[2]
                    + d[0] * d[1]
                    + d[0] * d[2]
                    + d[1] * d[2])
                / 6.0;
            let layer = 2.0 * p * d2 * (1.0 / c.height[0] + 1.0 / t.height[3]);
            let (a, b) = (tet_tet(&c, &t, p), tet_tet(&t, &c, p));
            for (what, e) in [("(c, t)", a.energy), ("(t, c)", b.energy)] {
                assert!(
                    (e - layer).abs() <= 0.05 * layer,
                    "pair {n} as {what}: E = {e:e} J, thin layer {layer:e} J"
                );
            }
            let largest =
                a.fc.iter()
                    .chain(&a.ft)
                    .map(|f| f.norm())
                    .fold(0.0, Real::max);
            for i in 0..4 {
                let (dc, dt) = ((a.fc[i] - b.ft[i]).norm(), (a.ft[i] - b.fc[i]).norm());
                assert!(
                    dc <= 1e-8 * largest && dt <= 1e-8 * largest,
                    "pair {n}, node {i}: forces differ by {:e} (c), {:e} (t) of {largest:e} N",
                    dc / largest,
                    dt / largest
                );
            }
        }
    }

    /// Area and first moment ∫x dA of each of the other element's regions' part of face k
    /// of `own`, as [`face_pieces`] splits it.
    fn region_parts(own: &TetGeom, k: usize, b: &[[Real; 4]; 4]) -> [(Real, Vec3); 4] {
        let mut parts = [(0.0, Vec3::zeros()); 4];
        face_pieces(own, k, b, Vert::of, |poly: &Poly<Vert>, m, _| {
            parts[m] = add_polygon(parts[m], poly, own.normal[k]);
        });
        parts
    }

    /// The same by the definition: face k clipped by the other element, then for each
    /// region m clipped by every plane λ_j − λ_m ≥ 0, j ≠ m (no plane skipped, no tree).
    fn region_parts_by_clipping(own: &TetGeom, k: usize, b: &[[Real; 4]; 4]) -> [(Real, Vec3); 4] {
        let mut parts = [(0.0, Vec3::zeros()); 4];
        let mut face = Poly::new();
        for v in TET_FACES[k] {
            face.push(Vert {
                x: own.x[v],
                bo: b[v],
            });
        }
        for l in 0..4 {
            let mut next = Poly::new();
            face.clip_into(&mut next, |v: &Vert| v.bo[l]);
            face = next;
        }
        if face.n < 3 {
            return parts;
        }
        for m in 0..4 {
            let mut part = Poly::new();
            face.clip_into(&mut part, |_: &Vert| 1.0); // a copy
            for j in (0..4).filter(|&j| j != m) {
                let mut next = Poly::new();
                part.clip_into(&mut next, |v: &Vert| v.bo[j] - v.bo[m]);
                part = next;
            }
            if part.n >= 3 {
                parts[m] = add_polygon(parts[m], &part, own.normal[k]);
            }
        }
        parts
    }

    fn add_polygon((area, first): (Real, Vec3), poly: &Poly<Vert>, n: Vec3) -> (Real, Vec3) {
        let x0 = poly.get(0).x;
        let (mut a, mut f) = (area, first);
        for i in 1..poly.n - 1 {
            let (xb, xc) = (poly.get(i).x, poly.get(i + 1).x);
            let at = 0.5 * (xb - x0).cross(&(xc - x0)).dot(&n);
            a += at;
            f += (x0 + xb + xc) * (at / 3.0);
        }
        (a, f)
    }

    /// The kernel's region split (a tree of two-sided cuts, `split_regions`) gives each
    /// region of the other element the same part of every face as clipping the face by
    /// that region's three planes: area and first moment within 1e-12 of the face's area
    /// (and its size) on 2 000 random overlapping pairs, every face of both elements. Both
    /// cut along the same planes from the same vertex values; they differ in the order of
    /// the cuts, so by rounding only. (A face lying in a kink plane, which random pairs do
    /// not produce, goes to one region in the split and to both here:
    /// `a_face_in_the_other_elements_kink_plane_counts_once`.)
    #[test]
    fn the_region_split_equals_clipping_each_region() {
        let mut rng = Rng(77);
        let (mut faces, mut split_faces, mut worst) = (0, 0, 0.0 as Real);
        while faces < 8 * 2000 {
            let c = rng.tet(Vec3::new(0.3, -0.2, 0.1), 1.0);
            let shift = Vec3::new(rng.next(), rng.next(), rng.next()) * 0.5;
            let t = rng.tet(Vec3::new(0.3, -0.2, 0.1) + shift, 1.0);
            if separating_axis(&c, &t, 0).is_some() {
                continue;
            }
            let bt: [[Real; 4]; 4] = c.x.map(|x| t.bary(&x));
            let bc: [[Real; 4]; 4] = t.x.map(|x| c.bary(&x));
            for (own, b) in [(&c, &bt), (&t, &bc)] {
                for k in 0..4 {
                    faces += 1;
                    let f = TET_FACES[k];
                    let face_area = 0.5
                        * (own.x[f[1]] - own.x[f[0]])
                            .cross(&(own.x[f[2]] - own.x[f[0]]))
                            .norm();
                    let size = (own.x[f[1]] - own.x[f[0]]).norm();
                    let (a, r) = (region_parts(own, k, b), region_parts_by_clipping(own, k, b));
                    split_faces += usize::from(r.iter().filter(|p| p.0 > 0.0).count() > 1);
                    for m in 0..4 {
                        let da = (a[m].0 - r[m].0).abs() / face_area;
                        let df = (a[m].1 - r[m].1).norm() / (face_area * size);
                        worst = worst.max(da).max(df);
                        assert!(
                            da <= 1e-12 && df <= 1e-12,
                            "region {m}: area {:e} vs {:e}",
                            a[m].0,
                            r[m].0
                        );
                    }
                }
            }
        }
        println!("{split_faces} of {faces} faces span two regions or more; worst {worst:e}");
        assert!(
            split_faces > faces / 4,
            "the split is exercised: {split_faces} of {faces}"
        );
    }

    /// A target with a face in the contactor's kink plane x = y (the unit tetrahedron's
    /// λ_1 = λ_2), deep inside it (found in review): the facet lies in two regions of the
    /// contactor at once. Reference: the same pair with the target moved 1e-9 m off the
    /// plane to either side, where the split is ordinary; E is continuous, so the three
    /// agree to 1e-6 (the shift changes E by ≈ 1e-9/L of itself), forces to 1e-6 of the
    /// largest, either element as contactor; and quadrature on a 160³ grid, 2 %. Giving the
    /// facet to both regions gave +35 % (E = 2.13e-3 against 1.57e-3 J).
    #[test]
    fn a_face_in_the_other_elements_kink_plane_counts_once() {
        let c = geom([
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ]);
        let t_at = |d: Real| {
            let s = Vec3::new(1.0, -1.0, 0.0) * (d / Real::sqrt(2.0));
            geom(
                [
                    [0.1, 0.1, 0.1],
                    [0.3, 0.3, 0.1],
                    [0.1, 0.1, 0.4],
                    [0.3, 0.1, 0.15],
                ]
                .map(|x| [x[0] + s.x, x[1] + s.y, x[2] + s.z]),
            )
        };
        let t = t_at(0.0);
        let quadrature = energy_by_sampling(&t, &c, 1.0, 160);
        for (x, y, flip) in [(&c, &t, false), (&t, &c, true)] {
            let exact = tet_tet(x, y, 1.0);
            assert!(
                (exact.energy - quadrature).abs() <= 0.02 * quadrature,
                "E = {:e}, quadrature {quadrature:e}",
                exact.energy
            );
            for d in [-1e-9, 1e-9] {
                let moved = t_at(d);
                let r = if flip {
                    tet_tet(&moved, &c, 1.0)
                } else {
                    tet_tet(&c, &moved, 1.0)
                };
                assert!(
                    (r.energy - exact.energy).abs() <= 1e-6 * r.energy,
                    "E = {:e} in the plane, {:e} moved {d:e} m off it",
                    exact.energy,
                    r.energy
                );
                let largest =
                    r.fc.iter()
                        .chain(&r.ft)
                        .map(|f| f.norm())
                        .fold(0.0, Real::max);
                for (a, b) in exact
                    .fc
                    .iter()
                    .chain(&exact.ft)
                    .zip(r.fc.iter().chain(&r.ft))
                {
                    assert!((a - b).norm() <= 1e-6 * largest, "{a:?} vs {b:?}");
                }
            }
        }
    }

    /// The kernel agrees with the test oracle (the kernel of 2026-11-28, which integrated
    /// every node's surface integral on every facet) to 1e-12 of the largest force of every
    /// pair, issue 14's bound: random overlapping pairs of every kind, far from the origin
    /// too, and the thin overlaps of resting contact (parallel faces sunk by d/H = 1e-4 to
    /// 1e-8, coincident and offset). Both integrate the same polygons; they differ only in
    /// rounding, ~1e-16 of the forces. The energy differs by the rounding of the facets'
    /// heights over the apexes (from a vertex here, from the centroid there), ulp(H)/d of
    /// the energy: ≤ 1e-6 relative for d/H ≥ 1e-8.
    /// A face [`face_beyond_reach`] skips has no pieces: over random pairs of mixed sizes
    /// (the other element 1e-3 to 1e3 times the own one) placed to overlap or nearly, and
    /// faces just inside and outside the reach (the other element moved off the face plane
    /// by 0.5 to 2 times it), every face the test skips gives `face_pieces` nothing, so the
    /// kernel's bits are those of clipping every face.
    #[test]
    fn a_face_beyond_reach_has_no_pieces() {
        let mut rng = Rng(77);
        let (mut skipped, mut kept) = (0, 0);
        let mut check = |own: &TetGeom, other: &TetGeom| {
            let b_own: [[Real; 4]; 4] = own.x.map(|x| other.bary(&x));
            let b_other: [[Real; 4]; 4] = other.x.map(|x| own.bary(&x));
            for k in 0..4 {
                let mut pieces = 0;
                face_pieces(own, k, &b_own, Vert::of, |_: &Poly<Vert>, _, _| pieces += 1);
                if face_beyond_reach(own, k, &b_other, snap_reach(other)) {
                    skipped += 1;
                    assert_eq!(pieces, 0, "a skipped face has {pieces} pieces");
                } else {
                    kept += 1;
                }
            }
        };
        for case in 0..4000 {
            let scale: Real = [1e-3, 1e-1, 1.0, 10.0, 1e3][case % 5];
            let own = rng.tet(Vec3::zeros(), 1.0);
            let off = Vec3::new(rng.next() - 0.5, rng.next() - 0.5, rng.next() - 0.5);
            let other = rng.tet(off * scale.min(1.0), scale);
            check(&own, &other);
            check(&other, &own);
            // Around the test's threshold: the other moved just off a face plane of own,
            // inside it, by a multiple of the reach; and a flush face (the other's face
            // parallel to own's face k, a little inside it: matching meshes side by side),
            // where the snap keeps the face below the reach.
            let k = case % 4;
            let n = own.normal[k];
            let plane = own.x[TET_FACES[k][0]];
            let nearest = (other.x.iter())
                .map(|x| (x - plane).dot(&n))
                .fold(Real::NEG_INFINITY, Real::max);
            let factor = [0.5, 0.99, 1.01, 2.0][(case / 4) % 4];
            let by = snap_reach(&other).max(SNAP * own.height[k]) * factor;
            let moved = TetGeom::new(other.x.map(|x| x - n * (nearest + by))).unwrap();
            check(&own, &moved);
            let f = TET_FACES[k].map(|v| own.x[v]);
            let centre = (f[0] + f[1] + f[2]) / 3.0;
            let depth = own.height[k] * (0.3 + 0.7 * rng.next()) * scale.clamp(0.1, 10.0);
            let face = f.map(|p| centre + (p - centre) * 0.8);
            let mut x = [face[0], face[1], face[2], centre - n * depth];
            if crate::math::tet_volume(&x[0], &x[1], &x[2], &x[3]) < 0.0 {
                x.swap(1, 2);
            }
            let flush = TetGeom::new(x).unwrap();
            let by = snap_reach(&flush).max(SNAP * own.height[k]) * factor;
            let flush = TetGeom::new(flush.x.map(|p| p - n * by)).unwrap();
            check(&own, &flush);
        }
        println!("{skipped} faces skipped, {kept} clipped");
        assert!(skipped > 1000 && kept > 1000);
    }

    #[test]
    fn oracle_agrees_with_the_kernel() {
        let mut rng = Rng(2026);
        let (mut worst_f, mut worst_e, mut pairs) = (0.0 as Real, 0.0 as Real, 0);
        let mut check = |c: &TetGeom, t: &TetGeom, what: &str| {
            let (df, de, e) = deviation(c, t, 1e9);
            let de = if de == 0.0 { 0.0 } else { de / e };
            assert!(
                df <= 1e-12,
                "{what}: forces differ by {df:e} of the largest"
            );
            assert!(de <= 1e-6, "{what}: energies differ by {de:e}");
            worst_f = worst_f.max(df);
            worst_e = worst_e.max(de);
        };
        for case in 0..3000 {
            let far = if case % 2 == 0 {
                Vec3::zeros()
            } else {
                Vec3::new(812.5, -1093.25, 47.0)
            };
            let c = rng.tet(far, 1.0);
            let off = Vec3::new(rng.next() - 0.5, rng.next() - 0.5, rng.next() - 0.5) * 0.9;
            let t = rng.tet(far + off, 1.0);
            if separating_axis(&c, &t, 0).is_none() {
                pairs += 1;
                check(&c, &t, &format!("random pair {case}"));
                check(&t, &c, &format!("random pair {case}, swapped"));
            }
        }
        let origin = Vec3::new(1.3, -0.7, 2.1);
        let h = 0.05;
        for offset in [
            Vec3::zeros(),
            Vec3::new(0.013, 0.007, 0.0),
            Vec3::new(-0.02, 0.011, 0.0),
        ] {
            for rel in [1e-4, 1e-5, 1e-6, 1e-7, 1e-8] {
                let d = rel * h;
                let base = [
                    Vec3::zeros(),
                    Vec3::new(h, 0.0, 0.0),
                    Vec3::new(0.0, h, 0.0),
                ];
                let target = geom(
                    [base[0], base[1], base[2], Vec3::new(0.0, 0.0, -h)]
                        .map(|p| origin + p)
                        .map(|p| [p.x, p.y, p.z]),
                );
                let contactor = geom(
                    [base[0], base[1], base[2], Vec3::new(0.01, 0.02, h)]
                        .map(|p| origin + offset + p + Vec3::new(0.0, 0.0, -d))
                        .map(|p| [p.x, p.y, p.z]),
                );
                pairs += 2;
                check(&contactor, &target, &format!("thin, d/H {rel:e}"));
                check(&target, &contactor, &format!("thin, d/H {rel:e}, swapped"));
            }
        }
        println!("{pairs} pairs: forces within {worst_f:e}, energies within {worst_e:e}");
        assert!(pairs > 1000);
    }
}
