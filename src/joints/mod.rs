//! Stage 2 — joints: cohesive elements between the faces of neighbouring tetrahedra
//! (Munjiza 2004, ch. 7). Reads positions; adds joint forces to `f`; updates each joint's
//! damage history.
//!
//! A joint holds two coincident triangular faces — face A of one tetrahedron, with its
//! outward vertex order, and face B of the neighbour, vertex i of B coinciding with vertex i
//! of A in the reference configuration. Kinematics are taken at the three node pairs
//! (vertex integration, tributary area A/3 each) in the current configuration: the
//! mid-surface of the two faces gives the unit normal n (pointing from A to B) and area A;
//! at pair i, Δ = x_Bi − x_Ai, opening δn = Δ·n, slip vector Δ − δn·n, slip δs its length.
//! Tractions from the law act on B as −σ·n − τ·ŝ and on A as the opposite, times A/3: the
//! joint forces are equal and opposite and follow large rotations.
//!
//! Guarantees: deterministic for any thread count. Joints are grouped in blocks of
//! consecutive joints, blocks are coloured so that blocks of a colour share no node, and
//! colours run one after another (blocks of a colour in parallel, each block in order on one
//! thread): every node receives its forces in a fixed order, with no atomics and no gather.
//! Each block is cut into work units of at most [`UNIT`] joints, each with its own partial
//! sums (energy, dissipation): a rank of a decomposed model computes only the units at its
//! nodes, and a node's forces still arrive in block order.

use crate::compiled;
pub mod audit;
pub mod bond;
pub mod law;

use crate::math::SyncPtr;
use crate::math::{Real, Vec3};
use crate::mesh::TET_FACES;
use crate::state::held::{Held, Slots};
use crate::state::{Body, Layout, Nodes};
use law::{
    Cohesive, CohesiveConsts, PointHistory, PointKinematics, PointState, PointTraction, RateEffects,
};
use rayon::prelude::*;
use std::collections::HashMap;

/// Smallest number of joints per parallel work item.
pub const CHUNK: usize = 1024;

/// Largest number of joints in one work unit: blocks (what a thread runs) are cut into units
/// of at most this many consecutive joints, each with its own partial sums, and a rank of a
/// decomposed model computes only the units with a joint at its nodes
/// ([`Joints::compute`]). A unit adds its forces in joint order within its block, so the
/// nodes' sums do not depend on the cut.
pub const UNIT: usize = 512;

/// Index of the block bucket that runs on one thread (blocks no parallel colour could take).
const SEQUENTIAL: usize = 63;

compiled::law_signature! {
    /// Inputs of a joint law written in Rhai, per integration point: opening δn and slip |δs|
    /// [m], their largest values so far [m], the joint size h [m] and the damage D [-].
    pub struct JointLawInputs { opening, slip, max_opening, max_slip, size, damage }
    /// A joint law: `fn law(j, p)` returning `#{ normal, shear, damage }` (σ, τ [Pa], D [-]).
    pub const JOINT_LAW = "joint law" -> ["normal", "shear", "damage"];
}

/// A joint constitutive law (registry name ↔ type).
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug)]
pub enum JointLaw {
    /// `"cohesive/munjiza"` and `"cohesive/linear"`: softening, breaking cohesion.
    Cohesive(Cohesive),
    /// `"tied"`: linear penalty springs that never break.
    Tied {
        normal_penalty: Real,
        tangential_penalty: Real,
    },
    /// `"script"`: a law written in Rhai, compiled to a closure tree ([`compiled`]).
    Script {
        law: std::sync::Arc<compiled::CompiledLaw>,
        normal_penalty: Real,
        tangential_penalty: Real,
    },
}

impl JointLaw {
    pub fn name(&self) -> &'static str {
        match self {
            JointLaw::Cohesive(c) => match c.softening {
                law::Softening::Munjiza => "cohesive/munjiza",
                law::Softening::Linear => "cohesive/linear",
            },
            JointLaw::Tied { .. } => "tied",
            JointLaw::Script { .. } => "script",
        }
    }

    /// (p_n, p_t) [Pa].
    pub fn penalties(&self) -> (Real, Real) {
        match self {
            JointLaw::Cohesive(c) => (c.normal_penalty, c.tangential_penalty),
            JointLaw::Tied {
                normal_penalty,
                tangential_penalty,
            }
            | JointLaw::Script {
                normal_penalty,
                tangential_penalty,
                ..
            } => (*normal_penalty, *tangential_penalty),
        }
    }

    /// The stiffest of the law's springs per unit area × h [Pa], for the time step: max(p_n, p_t),
    /// and for a dilatant law p_n·(1 + (μ + tan ψ)·tan ψ), the largest eigenvalue of a sliding,
    /// dilating point's (non-symmetric) stiffness: σ = k_n(δn − u_d(|q|)), |τ| = (μ + u_d')|σ|
    /// with d|q| = |ds| give, in (δn, s), k_n·[[1, u_d'], [μ + u_d', (μ + u_d')u_d']], of
    /// determinant 0 and trace k_n(1 + (μ + u_d')u_d').
    pub fn stiffest_penalty(&self) -> Real {
        let (pn, pt) = self.penalties();
        match self {
            JointLaw::Cohesive(c) if c.dilatancy.is_active() => {
                let t = c.dilatancy.tan_angle;
                pt.max(pn * (1.0 + (c.residual_friction + t) * t))
            }
            _ => pn.max(pt),
        }
    }

    /// Evaluate at one point (`consts` from [`Cohesive::consts`] for cohesive laws).
    #[inline]
    pub fn evaluate(
        &self,
        consts: &CohesiveConsts,
        k: &PointKinematics,
        inv_h: Real,
        s: &mut PointState,
        want_energy: bool,
    ) -> PointTraction {
        self.evaluate_in(
            &mut compiled::Frame::new(),
            consts,
            k,
            inv_h,
            s,
            want_energy,
        )
    }

    /// [`Self::evaluate`] with a reusable frame for script laws.
    #[inline]
    pub fn evaluate_in(
        &self,
        frame: &mut compiled::Frame,
        consts: &CohesiveConsts,
        k: &PointKinematics,
        inv_h: Real,
        s: &mut PointState,
        want_energy: bool,
    ) -> PointTraction {
        match self {
            JointLaw::Cohesive(c) => c.evaluate_with(consts, k, inv_h, s, want_energy),
            JointLaw::Tied {
                normal_penalty,
                tangential_penalty,
            } => {
                let (kn, kt) = (normal_penalty * inv_h, tangential_penalty * inv_h);
                PointTraction {
                    normal: kn * k.opening,
                    shear: kt * k.slip,
                    tangential: Vec3::zeros(),
                    energy: 0.5 * (kn * k.opening * k.opening + kt * k.slip * k.slip),
                    dissipated: 0.0,
                }
            }
            JointLaw::Script { law, .. } => {
                // The host keeps the maxima and makes damage non-decreasing and ≤ 1. A script
                // law has no energy function, so it reports neither stored energy nor
                // dissipation (the energy account then shows its work as a balance error).
                s.max_opening = s.max_opening.max(k.opening);
                s.max_slip = s.max_slip.max(k.slip);
                let inputs = JointLawInputs {
                    opening: k.opening,
                    slip: k.slip,
                    max_opening: s.max_opening,
                    max_slip: s.max_slip,
                    size: k.size,
                    damage: s.damage,
                };
                let [normal, shear, damage] = law.evaluate_in(frame, &inputs.to_slots());
                s.damage = s.damage.max(damage.min(1.0));
                PointTraction {
                    normal,
                    shear,
                    tangential: Vec3::zeros(),
                    energy: 0.0,
                    dissipated: 0.0,
                }
            }
        }
    }

    fn consts(&self) -> CohesiveConsts {
        match self {
            JointLaw::Cohesive(c) => c.consts(),
            JointLaw::Tied { .. } | JointLaw::Script { .. } => CohesiveConsts::default(),
        }
    }
}

/// All joints of a simulation (structure of arrays).
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, Default)]
pub struct Joints {
    /// Face A and face B node ids, paired by index.
    pub faces: Vec<[[u32; 3]; 2]>,
    /// The tetrahedra that own faces A and B.
    pub tets: Vec<[u32; 2]>,
    pub law: Vec<u32>,
    /// Characteristic size h [m]: mean edge length of the face.
    pub size: Vec<Real>,
    /// 1/h [1/m], filled by `prepare`.
    inv_size: Vec<Real>,
    /// Reference area [m²].
    pub area0: Vec<Real>,
    /// Damage and maxima of the three integration points.
    pub state: Held<[PointHistory; 3]>,
    /// Anchors of the three points: a softening point's plastic slip, a broken point's
    /// friction anchor ([`PointState::anchor`]). Stored in the joint's own axes
    /// ([`joint_axes`]: components along t₁, t₂ and n), so that they turn with the joint: a
    /// joint spun about its normal carries its anchors along instead of straining its springs
    /// by the spin. Read and write them in global coordinates with [`Joints::anchor_global`]
    /// and [`Joints::set_anchor_global`].
    pub anchor: Held<[Vec3; 3]>,
    /// Each point's accumulated plastic slip [m]: of its cohesive shear while it softens, of
    /// its friction since it broke (see [`PointState::slid`]).
    #[serde(default)]
    pub slid: Held<[Real; 3]>,
    /// Each broken point's net plastic slip since it broke ([`PointState::offset`], the
    /// dilatancy's measure), in the joint's own axes as the anchors.
    #[serde(default)]
    pub offset: Held<[Vec3; 3]>,
    /// Each point's energy at the last step [J/m²]: ψ₀ while softening, the friction
    /// spring's ½k_t|e|² once broken and closed, NaN otherwise (see
    /// [`PointState::last_energy`]).
    #[serde(default)]
    pub last_energy: Held<[Real; 3]>,
    /// Broken joints of a dilatant law that still hold their faces (set by stage 2 each
    /// step): a point's asperities are within reach (it opened less than twice the law's
    /// `dilatancy_opening` beyond its dilation), so stage 5 does not take them over.
    #[serde(default)]
    pub keeps_faces: Vec<bool>,
    /// Set by stage 3 when every point is fully damaged.
    pub broken: Vec<bool>,
    /// A broken joint whose faces contact has taken over carries no force. Until then (and
    /// always without contact) it keeps resisting penetration and rubbing with its own law.
    pub handed_over: Vec<bool>,
    pub laws: Vec<JointLaw>,
    /// Strain rates and strength factors of every joint, when a law is rate-dependent
    /// (empty otherwise).
    pub rate: Held<RateState>,
    consts: Vec<CohesiveConsts>,
    /// Blocks of joints by colour: blocks of one colour share no node.
    color_blocks: Vec<Vec<std::ops::Range<usize>>>,
    /// Number of joints coloured and ordered (insertion after that re-colours).
    colored: usize,
    /// For each colour, the index of each block's first work unit ([`UNIT`]) in schedule
    /// order (derived from `color_blocks` by `prepare`).
    #[serde(skip)]
    first_unit: Vec<Vec<usize>>,
    /// The sums of every work unit in schedule order (colour by colour, block by block),
    /// this step's.
    #[serde(skip)]
    pub unit_partials: Vec<JointSums>,
    /// Which work units this process computes, in schedule order (empty: all). A rank of a
    /// decomposed model computes only the units with a joint at one of its nodes
    /// (crate::parallel).
    #[serde(skip)]
    pub compute: Vec<bool>,
    /// Scratch of stage 3: the joints of the units that counted a newly failed joint this
    /// step ([`Joints::units_with_new_failures`]).
    #[serde(skip)]
    failing_units: Vec<std::ops::Range<usize>>,
}

/// Loading-rate state of a joint whose law is rate-dependent ([`RateEffects`]).
///
/// A joint's strain is that of the material its traction stands for: its traction over
/// Young's modulus, ε_n = σ/E in tension and ε_c = |σ_c, τ|/E in compression and shear (the
/// largest of its three points, at the factors in use). Its loading rate is the
/// secant one, ε̇ = ε/(t − t₀), t₀ the last time that strain was below 1 % of the static
/// strength's (f_t/E, c/E): the rate of a constant-rate test, which is how the fib factors
/// were measured, and a ratio of smooth quantities. In a bar pulled at ε̇ it reads ε̇·E_eff/E
/// (E_eff the jointed mesh's modulus, 1/E_eff ≈ 1/E + K/p_n): the stress rate over E.
///
/// While the joint is undamaged its factors follow that rate, but a falling rate lowers them
/// only as far as keeps its tractions at [`HOLD`] (0.9) of its strengths. A hold at the
/// opening's peak instead (x = 1) lowered the traction at fixed opening, and a bar loaded fast
/// to 1.5·f_t and held broke.
///
/// Tried first and dropped: the instantaneous rate (the joint's opening rate, or its
/// tets' velocity gradients), averaged over 1–10 % of the loading time. Vibrations at the
/// scale of the time step swung it by more than its mean, and near the peak the strength
/// followed the swings: a bar pulled at 30 /s broke at 1.1 or 2.5 f_t against the factor's
/// 1.8.
#[derive(serde::Serialize, serde::Deserialize, Clone, Copy, Debug, PartialEq)]
pub struct RateState {
    /// t₀ of the tensile and of the compressive–shear loading [s].
    pub tension_start: Real,
    pub shear_start: Real,
    /// Dynamic increase factors of f_t and c in use: they follow the rates while the joint
    /// is undamaged and are frozen once a point is damaged.
    pub dif_t: Real,
    pub dif_c: Real,
}

impl RateState {
    /// At rest: loading not begun, static strengths.
    pub const STATIC: RateState = RateState {
        tension_start: 0.0,
        shear_start: 0.0,
        dif_t: 1.0,
        dif_c: 1.0,
    };
}

/// A rate-dependent joint's factors fall with its loading rate only as far as keeps its
/// tractions at this fraction of its strengths (see [`RateState`]): below 1, so a held joint
/// settles before its peak (at the peak, with zero stiffness, any vibration would break it).
const HOLD: Real = 0.9;

/// Per-step sums over joints.
#[derive(serde::Serialize, serde::Deserialize, Clone, Copy, Debug, Default, PartialEq)]
pub struct JointSums {
    /// Recoverable joint energy [J] (when requested).
    pub energy: Real,
    /// Energy dissipated by damage and friction in this step [J].
    pub dissipated: Real,
    /// Joints with every point at D = 1 that are not yet marked broken.
    pub newly_failed: usize,
    /// Joints retired (broken if they were not) in this step because their faces parted
    /// ([`faces_parted`]).
    pub parted: usize,
}

impl Joints {
    /// The joints of each work unit (at most [`UNIT`] consecutive joints of a block), in
    /// schedule order: the order of [`Joints::unit_partials`] and [`Joints::compute`]. Valid
    /// after `prepare`.
    pub fn units(&self) -> impl Iterator<Item = std::ops::Range<usize>> + '_ {
        self.color_blocks.iter().flatten().flat_map(units_of)
    }

    /// The joints of the work units whose stage 2 counted a newly failed joint
    /// ([`JointSums::newly_failed`] of this step's [`Joints::unit_partials`]), in joint order:
    /// where stage 3 looks for the joints to break, instead of at every joint. A unit this
    /// process did not compute has no count (a rank looks only at its own units, which hold
    /// every joint at its nodes). All the joints, as one range, when the partials are not
    /// this schedule's (stage 2 not run since the joints were prepared).
    ///
    /// Every joint that reaches D = 1 at every point does so in stage 2 (the laws' damage
    /// only grows there) and is counted in its unit in that step, so a joint failed and not
    /// yet broken is in one of these units; stage 3 breaks it in the same step (or a
    /// criterion keeps it on its own list).
    pub fn units_with_new_failures(&mut self) -> &[std::ops::Range<usize>] {
        let mut ranges = std::mem::take(&mut self.failing_units);
        ranges.clear();
        if self.unit_partials.len() == unit_count(&self.color_blocks) && self.colored == self.len()
        {
            ranges.extend(
                self.units()
                    .zip(&self.unit_partials)
                    .filter(|(_, s)| s.newly_failed > 0)
                    .map(|(u, _)| u),
            );
            ranges.sort_unstable_by_key(|u| u.start);
        } else {
            ranges.push(0..self.len());
        }
        self.failing_units = ranges;
        &self.failing_units
    }

    /// The stage's sums: the exact sums of the units' partial sums, rounded once (the same
    /// bits for any thread or rank count, [`crate::math::ExactSum`]).
    pub fn total(&self) -> JointSums {
        crate::math::exact_total(&self.unit_partials)
    }

    /// Move the per-step scratch buffers (not part of a checkpoint) from `from` into `self`.
    pub(crate) fn take_scratch(&mut self, from: &mut Self) {
        std::mem::swap(&mut self.unit_partials, &mut from.unit_partials);
        std::mem::swap(&mut self.compute, &mut from.compute);
    }

    pub fn len(&self) -> usize {
        self.faces.len()
    }
    /// Joints with damage D > 0 at one of their points or more (softening or broken).
    pub fn damaged(&self) -> usize {
        (0..self.len()).filter(|&j| self.is_damaged(j)).count()
    }

    /// The largest damage D of joint `j` over its points.
    pub fn largest_damage(&self, j: usize) -> Real {
        self.state[j].iter().map(|p| p.damage).fold(0.0, Real::max)
    }

    /// Joint `j` has damage D > 0 at one of its points or more.
    pub fn is_damaged(&self, j: usize) -> bool {
        self.state[j].iter().any(|p| p.damage > 0.0)
    }
    pub fn is_empty(&self) -> bool {
        self.faces.is_empty()
    }

    pub fn add_law(&mut self, law: JointLaw) -> u32 {
        self.laws.push(law);
        (self.laws.len() - 1) as u32
    }

    /// Insert a joint on every internal face of a jointed body whose centroid passes `keep`.
    /// Returns how many were inserted. Faces that already carry a joint are skipped.
    pub fn insert_in_body(
        &mut self,
        body: &Body,
        tet_nodes: &[[u32; 4]],
        x0: &[Vec3],
        law: u32,
        keep: impl Fn(&Vec3) -> bool,
    ) -> Result<usize, String> {
        if body.layout == Layout::Rigid {
            return Err(format!(
                "body '{}' is rigid: it does not deform or break, so it takes no joints (add it with #{{ layout: \"jointed\" }} to crack it)",
                body.name
            ));
        }
        if body.layout != Layout::Jointed {
            return Err(format!(
                "body '{}' is continuous: its tetrahedra share nodes and cannot be separated; add it with #{{ layout: \"jointed\" }} to insert joints",
                body.name
            ));
        }
        let existing: std::collections::HashSet<[u32; 2]> = self
            .tets
            .iter()
            .map(|t| [t[0].min(t[1]), t[0].max(t[1])])
            .collect();
        let mesh = &body.mesh;
        // Internal faces of the shared-node topology: sorted mesh node ids → (tet, local face).
        let mut seen: HashMap<[u32; 3], (usize, usize)> =
            HashMap::with_capacity(2 * mesh.tets.len());
        let mut inserted = 0;
        for (e, t) in mesh.tets.iter().enumerate() {
            for (l, f) in TET_FACES.iter().enumerate() {
                let mut key = [t[f[0]], t[f[1]], t[f[2]]];
                key.sort_unstable();
                let Some((e1, l1)) = seen.remove(&key) else {
                    seen.insert(key, (e, l));
                    continue;
                };
                let (ta, tb) = ((body.tets.start + e1) as u32, (body.tets.start + e) as u32);
                if existing.contains(&[ta.min(tb), ta.max(tb)]) {
                    continue;
                }
                let mesh_a = TET_FACES[l1].map(|c| mesh.tets[e1][c]);
                let face_a = TET_FACES[l1].map(|c| tet_nodes[ta as usize][c]);
                // Vertex i of B is the corner of tet e that is mesh node mesh_a[i].
                let face_b = mesh_a.map(|m| {
                    let c = mesh.tets[e]
                        .iter()
                        .position(|&q| q == m)
                        .expect("shared face");
                    tet_nodes[tb as usize][c]
                });
                let p = face_a.map(|n| x0[n as usize]);
                let centroid = (p[0] + p[1] + p[2]) / 3.0;
                if !keep(&centroid) {
                    continue;
                }
                self.push_joint([face_a, face_b], [ta, tb], law, &p);
                inserted += 1;
            }
        }
        Ok(inserted)
    }

    /// Append one joint: faces A and B (paired vertices), their tets, its law, and face A's
    /// reference vertices (for the area and the size h = mean edge length).
    fn push_joint(&mut self, faces: [[u32; 3]; 2], tets: [u32; 2], law: u32, p: &[Vec3; 3]) {
        // (A rank's model edited between steps: its histories whole again until the next
        // split; the joints it did not hold are shared to it before that split.)
        self.hold_all();
        self.faces.push(faces);
        self.tets.push(tets);
        self.law.push(law);
        self.size
            .push(((p[1] - p[0]).norm() + (p[2] - p[1]).norm() + (p[0] - p[2]).norm()) / 3.0);
        self.area0
            .push(0.5 * (p[1] - p[0]).cross(&(p[2] - p[0])).norm());
        self.state.push([PointHistory::default(); 3]);
        self.anchor.push([Vec3::zeros(); 3]);
        self.slid.push([0.0; 3]);
        self.offset.push([Vec3::zeros(); 3]);
        self.last_energy.push([Real::NAN; 3]);
        self.keeps_faces.push(false);
        self.broken.push(false);
    }

    /// Insert a joint on every pair of coincident boundary faces of two different bodies among
    /// `bodies` (mortar between blocks, a block glued to a base): faces whose three vertices
    /// match within `tol` [m]. Either body may be jointed or continuous. Face A keeps its
    /// outward order (normal from A to B); B's vertices are paired by position. Returns the
    /// number inserted; pairs that already carry a joint are skipped.
    pub fn insert_between(&mut self, bodies: &[&Body], x0: &[Vec3], law: u32, tol: Real) -> usize {
        let faces: Vec<(usize, &crate::mesh::BoundaryFace)> = bodies
            .iter()
            .enumerate()
            .flat_map(|(b, body)| body.boundary.iter().map(move |f| (b, f)))
            .collect();
        if faces.is_empty() {
            return 0;
        }
        let pts = |f: &crate::mesh::BoundaryFace| f.nodes.map(|n| x0[n as usize]);
        let min_edge = faces
            .iter()
            .map(|(_, f)| {
                let p = pts(f);
                (p[1] - p[0])
                    .norm()
                    .min((p[2] - p[1]).norm())
                    .min((p[0] - p[2]).norm())
            })
            .fold(Real::INFINITY, Real::min);
        let cell = (0.25 * min_edge).max(4.0 * tol).max(Real::MIN_POSITIVE);
        let key = |c: Vec3| {
            [
                (c.x / cell).floor() as i64,
                (c.y / cell).floor() as i64,
                (c.z / cell).floor() as i64,
            ]
        };
        let centroid = |f: &crate::mesh::BoundaryFace| {
            let p = pts(f);
            (p[0] + p[1] + p[2]) / 3.0
        };
        let mut grid: HashMap<[i64; 3], Vec<usize>> = HashMap::with_capacity(faces.len());
        for (i, (_, f)) in faces.iter().enumerate() {
            grid.entry(key(centroid(f))).or_default().push(i);
        }
        let existing: std::collections::HashSet<[u32; 2]> = self
            .tets
            .iter()
            .map(|t| [t[0].min(t[1]), t[0].max(t[1])])
            .collect();
        let mut used = vec![false; faces.len()];
        let mut inserted = 0;
        for i in 0..faces.len() {
            if used[i] {
                continue;
            }
            let (bi, fa) = faces[i];
            let (ca, pa) = (centroid(fa), pts(fa));
            let k = key(ca);
            let mut partner = None;
            'search: for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        for &m in grid
                            .get(&[k[0] + dx, k[1] + dy, k[2] + dz])
                            .map(Vec::as_slice)
                            .unwrap_or(&[])
                        {
                            let (bm, fb) = faces[m];
                            if bm == bi || used[m] || (centroid(fb) - ca).norm() > tol {
                                continue;
                            }
                            let pb = pts(fb);
                            let pairing: Option<Vec<usize>> = pa
                                .iter()
                                .map(|p| (0..3).find(|&v| (pb[v] - p).norm() <= tol))
                                .collect();
                            if let Some(pairing) = pairing {
                                partner = Some((m, pairing));
                                break 'search;
                            }
                        }
                    }
                }
            }
            let Some((m, pairing)) = partner else {
                continue;
            };
            let fb = faces[m].1;
            let pair = [fa.tet.min(fb.tet), fa.tet.max(fb.tet)];
            used[i] = true;
            used[m] = true;
            if existing.contains(&pair) {
                continue;
            }
            let face_b = [
                fb.nodes[pairing[0]],
                fb.nodes[pairing[1]],
                fb.nodes[pairing[2]],
            ];
            self.push_joint([fa.nodes, face_b], [fa.tet, fb.tet], law, &pa);
            inserted += 1;
        }
        inserted
    }

    /// Group the joints into blocks of consecutive joints (insertion order is spatially
    /// coherent) and colour the blocks so that no two blocks of a colour share a node. Stage 2
    /// runs the colours one after another, the blocks of a colour in parallel, each block's
    /// joints in order on one thread: every node receives its contributions in a fixed order.
    ///
    /// Blocks are as large as the colouring allows: 1/16 of the joints when that needs at most
    /// 3 colours (each colour then sweeps its own contiguous parts of the node arrays once),
    /// else 1/32, 1/64, else `CHUNK`. The choice depends on the mesh only, never on the thread
    /// count, so results stay bit-identical for any number of threads. On the 200k-tet
    /// jointed box, 16 blocks in 2 colours instead of 378 in 4 made stage 2 ~13 % faster.
    pub fn prepare(&mut self, n_nodes: usize) {
        self.handed_over.resize(self.len(), false);
        // (Checkpoints written before these existed.)
        self.slid.resize(self.len(), [0.0; 3]);
        self.offset.resize(self.len(), [Vec3::zeros(); 3]);
        self.last_energy.resize(self.len(), [Real::NAN; 3]);
        self.keeps_faces.resize(self.len(), false);
        let rate_dependent = self
            .laws
            .iter()
            .any(|l| matches!(l, JointLaw::Cohesive(c) if c.rate != RateEffects::None));
        if rate_dependent {
            self.rate.resize(self.len(), RateState::STATIC);
        }
        self.consts = self.laws.iter().map(JointLaw::consts).collect();
        self.inv_size = self.size.iter().map(|h| 1.0 / h).collect();
        if self.colored != self.faces.len() {
            self.colour(n_nodes);
        }
        self.index_units();
        self.shrink_to_fit();
    }

    /// Hold only the histories (damage, maxima, anchors, slips, last energies, rate factors)
    /// of the joints of the work units this process computes ([`Joints::compute`]), as a
    /// rank of a decomposed model does between splits: 264 B a joint (more with rate
    /// effects) for the joints of its part only. Every joint's on one process.
    pub fn hold_computed(&mut self) {
        if self.compute.is_empty()
            || self.colored != self.len()
            || self.compute.len() != unit_count(&self.color_blocks)
        {
            self.hold_all();
            return;
        }
        let mut keep = vec![false; self.len()];
        for (u, &c) in self.units().zip(&self.compute) {
            if c {
                keep[u].fill(true);
            }
        }
        if keep.iter().all(|&k| k) {
            self.hold_all();
            return;
        }
        let slots = Slots::keeping(self.len(), |j| keep[j]);
        let n = self.len();
        self.state.hold(&slots, n);
        self.anchor.hold(&slots, n);
        self.slid.hold(&slots, n);
        self.offset.hold(&slots, n);
        self.last_energy.hold(&slots, n);
        if !(self.rate.is_whole() && self.rate.is_empty()) {
            self.rate.hold(&slots, n);
        }
    }

    /// Every joint's history held again: those this process held kept, the others at
    /// their initial values until they are shared to it
    /// ([`Joints::hold_computed`]).
    pub fn hold_all(&mut self) {
        let n = self.len();
        self.state.make_whole(n, [PointHistory::default(); 3]);
        self.anchor.make_whole(n, [Vec3::zeros(); 3]);
        self.slid.make_whole(n, [0.0; 3]);
        self.offset.make_whole(n, [Vec3::zeros(); 3]);
        self.last_energy.make_whole(n, [Real::NAN; 3]);
        self.rate.make_whole(n, RateState::STATIC);
    }

    /// Drop the spare capacity that inserting joints one by one left (up to as much again as
    /// the arrays hold: about 190 B a joint).
    fn shrink_to_fit(&mut self) {
        self.faces.shrink_to_fit();
        self.tets.shrink_to_fit();
        self.law.shrink_to_fit();
        self.size.shrink_to_fit();
        self.area0.shrink_to_fit();
        self.state.shrink_to_fit();
        self.anchor.shrink_to_fit();
        self.slid.shrink_to_fit();
        self.offset.shrink_to_fit();
        self.last_energy.shrink_to_fit();
        self.keeps_faces.shrink_to_fit();
        self.broken.shrink_to_fit();
        self.handed_over.shrink_to_fit();
        self.rate.shrink_to_fit();
    }

    /// [`Joints::first_unit`] from the blocks (also after a restart, which does not store
    /// it).
    fn index_units(&mut self) {
        self.first_unit = self
            .color_blocks
            .iter()
            .scan(0, |next, blocks| {
                Some(
                    blocks
                        .iter()
                        .map(|b| {
                            *next += b.len().div_ceil(UNIT);
                            *next - b.len().div_ceil(UNIT)
                        })
                        .collect(),
                )
            })
            .collect();
    }

    /// Group and colour the joints (see [`Joints::prepare`]).
    fn colour(&mut self, n_nodes: usize) {
        let n = self.faces.len();
        let mut chosen = None;
        for parts in [16, 32, 64] {
            let block = n.div_ceil(parts);
            if block <= CHUNK {
                break;
            }
            let blocks = self.colour_blocks(n_nodes, block);
            if blocks.len() <= 3 {
                chosen = Some(blocks);
                break;
            }
        }
        let blocks = chosen.unwrap_or_else(|| self.colour_blocks(n_nodes, CHUNK));
        self.unit_partials = Vec::with_capacity(unit_count(&blocks));
        self.color_blocks = blocks;
        self.colored = n;
    }

    /// Greedy colouring of the blocks of `block` consecutive joints: each block takes the
    /// lowest colour none of its nodes has yet.
    fn colour_blocks(&self, n_nodes: usize, block: usize) -> Vec<Vec<std::ops::Range<usize>>> {
        let n_blocks = self.faces.len().div_ceil(block);
        let mut used = vec![0u64; n_nodes];
        let mut blocks: Vec<Vec<std::ops::Range<usize>>> = Vec::new();
        for b in 0..n_blocks {
            let range = b * block..((b + 1) * block).min(self.faces.len());
            let nodes = || self.faces[range.clone()].iter().flatten().flatten();
            let taken = nodes().fold(0u64, |m, &n| m | used[n as usize]);
            // Colours 0..63 run in parallel; a block that finds none free goes to the last
            // bucket, which runs on one thread after all the others (still deterministic).
            let c = ((!taken).trailing_zeros() as usize).min(SEQUENTIAL);
            if c < SEQUENTIAL {
                for &n in nodes() {
                    used[n as usize] |= 1 << c;
                }
            }
            if blocks.len() <= c {
                blocks.resize(c + 1, Vec::new());
            }
            blocks[c].push(range);
        }
        blocks
    }

    /// The anchor of point `p` of joint `j` in global coordinates at the positions `x`
    /// (stored in the joint's axes: [`Joints::anchor`]).
    pub fn anchor_global(&self, j: usize, p: usize, x: &[Vec3]) -> Vec3 {
        let (n, _, _) = joint_kinematics(&self.faces[j], x);
        anchor_to_global(&self.anchor[j][p], &joint_axes(&self.faces[j], x, &n), &n)
    }

    /// Set the anchor of point `p` of joint `j` to the global vector `a` at the positions `x`.
    pub fn set_anchor_global(&mut self, j: usize, p: usize, x: &[Vec3], a: Vec3) {
        let (n, _, _) = joint_kinematics(&self.faces[j], x);
        self.anchor[j][p] = anchor_to_axes(&a, &joint_axes(&self.faces[j], x, &n), &n);
    }

    /// Recoverable energy of joint `j` at the current positions [J] (its history unchanged).
    pub fn stored_energy(&self, j: usize, x: &[Vec3]) -> Real {
        let (n, area, pts) = joint_kinematics(&self.faces[j], x);
        let axes = joint_axes(&self.faces[j], x, &n);
        let (mut law, mut consts) = (
            self.laws[self.law[j] as usize].clone(),
            self.consts
                .get(self.law[j] as usize)
                .copied()
                .unwrap_or_default(),
        );
        if let (JointLaw::Cohesive(c), Some(r)) =
            (&law, (!self.rate.is_empty()).then(|| &self.rate[j]))
        {
            if c.rate != RateEffects::None {
                let scaled = c.scaled(r.dif_t, r.dif_c);
                consts = scaled.consts();
                law = JointLaw::Cohesive(scaled);
            }
        }
        let mut st: [PointState; 3] = std::array::from_fn(|p| {
            PointState::from_parts(
                self.state[j][p],
                anchor_to_global(&self.anchor[j][p], &axes, &n),
                (
                    self.slid[j][p],
                    anchor_to_global(&self.offset[j][p], &axes, &n),
                ),
                self.last_energy[j][p],
            )
        });
        pts.iter()
            .enumerate()
            .map(|(p, pt)| {
                let k = point_kinematics(n, self.size[j], pt);
                law.evaluate(&consts, &k, 1.0 / self.size[j], &mut st[p], true)
                    .energy
                    * area
                    / 3.0
            })
            .sum()
    }

    /// Stiffness of the joint springs at each node, Σ max(p_n, p_t)/h·A/3 [N/m] (for the
    /// critical time step).
    /// Broken joints whose faces contact took over (stage 5): stage 2 no longer evaluates
    /// their friction.
    pub fn hand_over(&mut self, joints: &[u32]) {
        for &j in joints {
            self.handed_over[j as usize] = true;
        }
    }

    /// This stage's share of the time-step limit: the joint springs add stiffness at their
    /// nodes, so by Weyl's inequality and a Gershgorin bound on the joint part
    /// ω² ≤ ω_elements² + max_n 2·Σk_joint/m_n. Returns (max_n 2·Σk/m_n [1/s²], that node).
    pub fn max_omega2(&self, mass: &[Real]) -> (Real, usize) {
        self.nodal_stiffness(mass.len())
            .iter()
            .zip(mass)
            .enumerate()
            .map(|(n, (k, m))| (2.0 * k / m, n))
            .fold((0.0, 0), |a, b| if b.0 > a.0 { b } else { a })
    }

    /// Σ of the joint spring stiffnesses at every node, k = p/h · A/3 per joint node with p
    /// the law's [`JointLaw::stiffest_penalty`] (max(p_n, p_t) without dilatancy) [N/m].
    pub fn nodal_stiffness(&self, n_nodes: usize) -> Vec<Real> {
        let mut k = vec![0.0; n_nodes];
        for j in 0..self.len() {
            let p = self.laws[self.law[j] as usize].stiffest_penalty();
            let kj = p / self.size[j] * self.area0[j] / 3.0;
            for side in &self.faces[j] {
                for &n in side {
                    k[n as usize] += kj;
                }
            }
        }
        k
    }
}

/// Kinematics of joint `j`: unit normal, mid-surface area, and per pair (opening, slip, slip direction).
#[inline(always)]
pub fn joint_kinematics(
    faces: &[[u32; 3]; 2],
    x: &[Vec3],
) -> (Vec3, Real, [(Real, Real, Vec3); 3]) {
    point_slips(joint_jumps(faces, x))
}

/// [`joint_kinematics`] from the joint's jumps ([`joint_jumps`]): each point's slip
/// normalised.
#[inline(always)]
fn point_slips(
    (n, area, dn, st): (Vec3, Real, [Real; 3], [Vec3; 3]),
) -> (Vec3, Real, [(Real, Real, Vec3); 3]) {
    let pts = std::array::from_fn(|i| {
        let ds = st[i].norm();
        let dir = if ds > 0.0 {
            st[i] * (1.0 / ds)
        } else {
            Vec3::zeros()
        };
        (dn[i], ds, dir)
    });
    (n, area, pts)
}

/// The joint's in-plane axes (t₁, t₂) at the current positions, for its unit normal `n`
/// ([`joint_kinematics`]): t₁ along the mid-surface's edge from its first to its second point,
/// t₂ = n × t₁. They turn with the joint, so the anchors kept in them
/// ([`Joints::anchor`]) are objective: a rigid rotation of the pair moves anchor and slip
/// alike. (A degenerate mid-surface gets any axes normal to `n`.)
#[inline(always)]
pub fn joint_axes(faces: &[[u32; 3]; 2], x: &[Vec3], n: &Vec3) -> (Vec3, Vec3) {
    let mid = |k: usize| (x[faces[0][k] as usize] + x[faces[1][k] as usize]) * 0.5;
    let e = mid(1) - mid(0);
    let e = e - n * e.dot(n);
    let len = e.norm();
    let t1 = if len > 0.0 {
        e * (1.0 / len)
    } else {
        // Any unit vector normal to n.
        let a = if n.x.abs() < 0.9 {
            Vec3::x()
        } else {
            Vec3::y()
        };
        let t = a - n * a.dot(n);
        t * (1.0 / t.norm().max(Real::MIN_POSITIVE))
    };
    (t1, n.cross(&t1))
}

/// An anchor kept in a joint's axes ([`joint_axes`]: components along t₁, t₂, n), in global
/// coordinates.
#[inline(always)]
fn anchor_to_global(a: &Vec3, (t1, t2): &(Vec3, Vec3), n: &Vec3) -> Vec3 {
    t1 * a.x + t2 * a.y + n * a.z
}

/// A global anchor in a joint's axes (the inverse of [`anchor_to_global`]).
#[inline(always)]
fn anchor_to_axes(a: &Vec3, (t1, t2): &(Vec3, Vec3), n: &Vec3) -> Vec3 {
    Vec3::new(a.dot(t1), a.dot(t2), a.dot(n))
}

/// Unit normal, mid-surface area, openings and tangential jump vectors of a joint (the
/// kinematics of [`joint_kinematics`] without normalising the slip).
#[inline(always)]
fn joint_jumps(faces: &[[u32; 3]; 2], x: &[Vec3]) -> (Vec3, Real, [Real; 3], [Vec3; 3]) {
    let a = faces[0].map(|n| x[n as usize]);
    let b = faces[1].map(|n| x[n as usize]);
    let m = [
        (a[0] + b[0]) * 0.5,
        (a[1] + b[1]) * 0.5,
        (a[2] + b[2]) * 0.5,
    ];
    let nv = (m[1] - m[0]).cross(&(m[2] - m[0]));
    let len = nv.norm();
    let n = if len > 0.0 {
        nv * (1.0 / len)
    } else {
        Vec3::zeros()
    };
    let mut dn = [0.0; 3];
    let mut st = [Vec3::zeros(); 3];
    for i in 0..3 {
        let d = b[i] - a[i];
        dn[i] = d.dot(&n);
        st[i] = d - n * dn[i];
    }
    (n, 0.5 * len, dn, st)
}

/// Whether a joint's two faces have parted for good: they no longer face each other
/// (their normals more than 90° apart, or the mid-surface, whose normal the joint's opening
/// and slip are measured along, shrunk below a quarter of the reference area `area0`), or
/// a point's jump is more than twice the joint's size `h`. Then the joint's kinematics no
/// longer describe a crack: a fragment folded back over its neighbour about one node makes
/// the mid-surface collapse and its normal swing from step to step, and a joint kept in
/// force there turned that swing into friction slip, booking dissipation that no force paid
/// for (8.95 J in 450 steps of the laminated-glass run, from two joints with two points
/// broken and the third, on the hinge node, at D = 0.58). Such a joint breaks (every point
/// to D = 1) and is handed over to contact for good.
fn faces_parted(
    faces: &[[u32; 3]; 2],
    x: &[Vec3],
    mid_area: Real,
    area0: Real,
    h: Real,
    pts: &[(Real, Real, Vec3); 3],
) -> bool {
    if mid_area < 0.25 * area0 {
        return true;
    }
    // |(δn, δs)| > 2h, squared (`hypot` was a few % of a fracturing run).
    if pts
        .iter()
        .any(|(dn, ds, _)| dn * dn + ds * ds > 4.0 * h * h)
    {
        return true;
    }
    let normal = |f: &[u32; 3]| {
        let [a, b, c] = f.map(|n| x[n as usize]);
        (b - a).cross(&(c - a))
    };
    normal(&faces[0]).dot(&normal(&faces[1])) < 0.0
}

/// A point's state for its law: its history, and where the law uses them (only cohesive
/// laws do; the others get zero) its anchor, accumulated slip and last energy.
#[inline(always)]
fn point_state(
    history: PointHistory,
    (anchor, slid, offset, last_energy): (Vec3, Real, Vec3, Real),
    cohesive: bool,
) -> PointState {
    if cohesive {
        PointState::from_parts(history, anchor, (slid, offset), last_energy)
    } else {
        PointState::from_parts(history, Vec3::zeros(), (0.0, Vec3::zeros()), Real::NAN)
    }
}

/// Kinematics of one integration point from [`joint_kinematics`]' (opening, slip, direction).
#[inline(always)]
fn point_kinematics(n: Vec3, size: Real, (dn, ds, dir): &(Real, Real, Vec3)) -> PointKinematics {
    PointKinematics {
        opening: *dn,
        slip: *ds,
        slip_vector: dir * *ds,
        normal: n,
        size,
    }
}

/// Update the loading rates and dynamic increase factors of an undamaged rate-dependent joint
/// (law `c`, state `r`, kinematics `pose` = (n, area, points), size h, the body's Young's
/// modulus, the step's time; see [`RateState`]). Returns the change of stored energy the new
/// factors make at the current kinematics, ΔΨ [J], which the caller books as −ΔΨ of
/// dissipation.
fn update_rate_factors(
    c: &Cohesive,
    r: &mut RateState,
    pose: &(Vec3, Real, [(Real, Real, Vec3); 3]),
    size: Real,
    young: Real,
    time: Real,
) -> Real {
    let (n, area, pts) = pose;
    let inv_h = 1.0 / size;
    let (kn, kt) = (c.normal_penalty * inv_h, c.tangential_penalty * inv_h);
    // The tractions at the factors in use (E × strain), and the factors that keep them at
    // HOLD of the strengths.
    let (ft, coh) = (c.tensile_strength * r.dif_t, c.cohesion * r.dif_c);
    let (mut sig_n, mut sig_c) = (0.0 as Real, 0.0 as Real);
    let (mut hold_t, mut hold_c) = (0.0 as Real, 0.0 as Real);
    for (dn, ds, _) in pts {
        let compression = -kn * dn.min(0.0);
        let fs = coh + compression * c.tan_friction;
        let tau = fs * law::prepeak(0.5 * kt * ds / fs);
        let sigma = ft * law::prepeak(0.5 * kn * dn.max(0.0) / ft);
        sig_n = sig_n.max(sigma);
        sig_c = sig_c.max(compression.hypot(tau));
        hold_t = hold_t.max(sigma / (HOLD * c.tensile_strength));
        hold_c = hold_c.max((tau / HOLD - compression * c.tan_friction) / c.cohesion);
    }
    if sig_n <= 0.01 * c.tensile_strength {
        r.tension_start = time;
    }
    if sig_c <= 0.01 * c.cohesion {
        r.shear_start = time;
    }
    let secant = |sig: Real, start: Real| {
        if time > start {
            sig / young / (time - start)
        } else {
            0.0
        }
    };
    // The factors follow the rates, but a falling rate lowers them only as far as keeps the
    // current tractions at HOLD of the strengths: a joint loaded fast and then held does not
    // break because its loading slowed (concrete's delayed fracture takes far longer).
    let dif = (
        law::dif_tension_fib2010(secant(sig_n, r.tension_start)).max(r.dif_t.min(hold_t)),
        law::dif_compression_fib2010(secant(sig_c, r.shear_start)).max(r.dif_c.min(hold_c)),
    );
    if dif == (r.dif_t, r.dif_c) {
        return 0.0;
    }
    let (old, new) = (c.scaled(r.dif_t, r.dif_c), c.scaled(dif.0, dif.1));
    (r.dif_t, r.dif_c) = dif;
    pts.iter()
        .map(|p| {
            let k = point_kinematics(*n, size, p);
            new.intact_energy(&k, inv_h) - old.intact_energy(&k, inv_h)
        })
        .sum::<Real>()
        * area
        / 3.0
}

/// The work units of a block: its joints cut into runs of at most [`UNIT`].
/// How many work units ([`UNIT`] joints at most, none across a block's end) the blocks hold.
fn unit_count(color_blocks: &[Vec<std::ops::Range<usize>>]) -> usize {
    (color_blocks.iter().flatten())
        .map(|b| b.len().div_ceil(UNIT))
        .sum()
}

fn units_of(block: &std::ops::Range<usize>) -> impl Iterator<Item = std::ops::Range<usize>> {
    let end = block.end;
    (block.start..end)
        .step_by(UNIT)
        .map(move |s| s..(s + UNIT).min(end))
}

/// Stage 2: add the joint forces of every intact or broken joint to `nodes.f`.
///
/// Colour by colour (see [`Joints::prepare`]), blocks of joints add their nodal forces
/// straight into `f`; the result does not depend on the number of threads.
///
/// A rate-dependent law ([`RateEffects`]) is evaluated with its strengths scaled by the
/// joint's dynamic increase factors ([`RateState`], updated here at the step's `time`). When the factors change at fixed
/// kinematics (an undamaged joint), its stored energy changes by Δψ with no work done; that
/// change is booked in the step's dissipation (−Δψ) so the energy account stays closed.
///
/// Kept whole: the hot loop over each colour block's joints, one pass per joint (kinematics,
/// rate factors, law, damage, energy, scatter into `f`); split, a joint's state would be
/// threaded through several functions per step.
pub fn add_joint_forces(
    joints: &mut Joints,
    nodes: &mut Nodes,
    time: Real,
    want_energy: bool,
) -> JointSums {
    if joints.is_empty() {
        return JointSums::default();
    }
    if joints.first_unit.len() != joints.color_blocks.len() {
        joints.index_units();
    }
    let Joints {
        faces,
        law,
        size,
        inv_size,
        area0,
        state,
        anchor,
        slid,
        offset,
        last_energy,
        keeps_faces,
        handed_over,
        laws,
        rate,
        consts,
        color_blocks,
        first_unit,
        unit_partials,
        compute,
        ..
    } = joints;
    let n_handed = handed_over.len();
    let hp = SyncPtr(handed_over.as_mut_ptr());
    let x = &nodes.x;
    let fp = SyncPtr(nodes.f.as_mut_ptr());
    let sp = SyncPtr(state.as_mut_slice().as_mut_ptr());
    let ap = SyncPtr(anchor.as_mut_slice().as_mut_ptr());
    let slp = SyncPtr(slid.as_mut_slice().as_mut_ptr());
    let op = SyncPtr(offset.as_mut_slice().as_mut_ptr());
    let lp = SyncPtr(last_energy.as_mut_slice().as_mut_ptr());
    let kp = SyncPtr(keeps_faces.as_mut_ptr());
    let rp = SyncPtr(rate.as_mut_slice().as_mut_ptr());
    let has_rate = !rate.is_empty();
    // Where joint j's history is stored: at j + `base` within a unit this process computes
    // (a rank holds the histories of its units only, packed in joint order).
    let slots = state.slots().clone();
    debug_assert!(
        [
            anchor.slots(),
            slid.slots(),
            offset.slots(),
            last_energy.slots()
        ]
        .iter()
        .all(|s| **s == slots)
            && (rate.is_empty() || *rate.slots() == slots),
        "the joint history arrays share one slot map"
    );
    let base_of = |start: usize| slots.at(start) as isize - start as isize;
    let audit = audit::on().then(|| audit::Recorder::begin(faces.len()));
    let n_units = unit_count(color_blocks);
    unit_partials.clear();
    unit_partials.resize(n_units, JointSums::default());
    let pp = SyncPtr(unit_partials.as_mut_ptr());
    // A block's joints in order on one thread; at each unit's end its sums go to its place
    // in `unit_partials` (units of a block are consecutive there), and a unit this process
    // does not compute is skipped.
    let run_block = |range: &std::ops::Range<usize>, first_unit: usize| {
        if range.is_empty() {
            return;
        }
        let mut s = JointSums::default();
        let mut frame = compiled::Frame::new();
        let mut scaled: (JointLaw, CohesiveConsts);
        let mut unit = first_unit;
        let mut unit_end = (range.start + UNIT).min(range.end);
        let mut skip = !*compute.get(unit).unwrap_or(&true);
        let mut base = if skip { 0 } else { base_of(range.start) };
        for j in range.clone() {
            if j == unit_end {
                // SAFETY: unit `unit` belongs to this block alone.
                unsafe { *pp.get().add(unit) = std::mem::take(&mut s) };
                unit += 1;
                unit_end = (j + UNIT).min(range.end);
                skip = !*compute.get(unit).unwrap_or(&true);
                base = if skip { 0 } else { base_of(j) };
            }
            if skip {
                continue;
            }
            // Joint j's history slot.
            let h = (j as isize + base) as usize;
            #[cfg(target_arch = "x86_64")]
            if let Some(ahead) = faces.get(j + 8) {
                use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
                for side in ahead {
                    let n = side[0] as usize;
                    // SAFETY: a prefetch is a hint; the address is inside the arrays.
                    unsafe {
                        _mm_prefetch::<_MM_HINT_T0>(x.as_ptr().add(n).cast::<i8>());
                        _mm_prefetch::<_MM_HINT_T0>(fp.get().add(n).cast::<i8>());
                    }
                }
            }
            // SAFETY: as for the state (each joint is read and written by its block only).
            if j < n_handed && unsafe { *hp.get().add(j) } {
                continue;
            }
            // SAFETY: blocks are disjoint ranges of joints, so each state is
            // borrowed by one iteration only.
            let st = unsafe { &mut *sp.get().add(h) };
            let (mut lw, mut cs) = (&laws[law[j] as usize], &consts[law[j] as usize]);
            let inv_h = inv_size[j];
            if let (true, JointLaw::Cohesive(c)) = (has_rate, lw) {
                if let RateEffects::Fib2010 { young } = c.rate {
                    // SAFETY: as for the state.
                    let r = unsafe { &mut *rp.get().add(h) };
                    if st.iter().all(|p| p.damage == 0.0) {
                        let pose = joint_kinematics(&faces[j], x);
                        let dr = update_rate_factors(c, r, &pose, size[j], young, time);
                        s.dissipated -= dr;
                        if let Some(a) = audit {
                            // SAFETY: joint j is this block's.
                            unsafe { a.dissipated(j, -dr, false) };
                        }
                    }
                    let c = c.scaled(r.dif_t, r.dif_c);
                    let consts = c.consts();
                    scaled = (JointLaw::Cohesive(c), consts);
                    (lw, cs) = (&scaled.0, &scaled.1);
                }
            }
            // Fast path: an undamaged cohesive joint below its peak whose mid-surface has
            // not collapsed (else the general path checks whether its faces parted). Taken on
            // sampled steps too (with the energies), so that the motion does not depend on
            // how often energies are sampled; not while auditing (it records every point).
            // (A damaged joint goes to the general path without computing its jumps twice;
            // one that declines the fast path hands them over.)
            let mut jumps = None;
            if let (JointLaw::Cohesive(c), true, true) =
                (lw, audit.is_none(), !st.iter().any(|p| p.damage > 0.0))
            {
                let (n, area, dn, tj) = *jumps.insert(joint_jumps(&faces[j], x));
                let mut psi = [0.0; 3];
                let fast = if area >= 0.25 * area0[j] {
                    c.intact_tractions(cs, inv_h, &n, &dn, &tj, st, want_energy.then_some(&mut psi))
                } else {
                    None
                };
                if let Some(t) = fast {
                    if want_energy {
                        s.energy += (psi[0] + psi[1] + psi[2]) * (area / 3.0);
                    }
                    for p in 0..3 {
                        let on_b = -t[p] * (area / 3.0);
                        // SAFETY: as below.
                        unsafe {
                            *fp.get().add(faces[j][0][p] as usize) -= on_b;
                            *fp.get().add(faces[j][1][p] as usize) += on_b;
                        }
                    }
                    continue;
                }
            }
            let (n, area, pts) = point_slips(jumps.unwrap_or_else(|| joint_jumps(&faces[j], x)));
            let was_failed = st.iter().all(|p| p.damage >= 1.0);
            // Only cohesive laws use the anchors (plastic slip, friction anchors): other laws
            // neither read nor write them.
            let cohesive = matches!(lw, JointLaw::Cohesive(_));
            // SAFETY: as for the state.
            let anchors = unsafe { &mut *ap.get().add(h) };
            // SAFETY: as for the state.
            let (slids, keeps) = unsafe { (&mut *slp.get().add(h), &mut *kp.get().add(j)) };
            // SAFETY: as for the state.
            let lasts = unsafe { &mut *lp.get().add(h) };
            // SAFETY: as for the state.
            let offsets = unsafe { &mut *op.get().add(h) };
            // The anchors in global coordinates for the law, and back into the joint's axes
            // after it (objective: they turn with the joint).
            let axes = joint_axes(&faces[j], x, &n);
            let global = anchors.map(|a| anchor_to_global(&a, &axes, &n));
            let offsets_global = offsets.map(|q| anchor_to_global(&q, &axes, &n));
            if j < n_handed && faces_parted(&faces[j], x, area, area0[j], size[j], &pts) {
                // A joint whose faces no longer face each other breaks (if it has not) and
                // lets go: what its springs hold at these kinematics is booked as dissipated
                // (as on re-opening, or as a fracture criterion's break), and it acts no more.
                for (p, pt) in pts.iter().enumerate() {
                    let k = point_kinematics(n, size[j], pt);
                    let mut ps = point_state(
                        st[p],
                        (global[p], slids[p], offsets_global[p], lasts[p]),
                        cohesive,
                    );
                    let t = lw.evaluate_in(&mut frame, cs, &k, inv_h, &mut ps, true);
                    s.dissipated += (t.dissipated + t.energy) * area / 3.0;
                    if let Some(a) = audit {
                        // SAFETY: joint j is this block's.
                        unsafe { a.dissipated(j, (t.dissipated + t.energy) * area / 3.0, true) };
                    }
                    st[p].damage = 1.0;
                }
                if !was_failed {
                    s.newly_failed += 1;
                }
                // SAFETY: as for the state.
                unsafe { *hp.get().add(j) = true };
                *keeps = false;
                s.parted += 1;
                continue;
            }
            for (p, pt) in pts.iter().enumerate() {
                let k = point_kinematics(n, size[j], pt);
                let dir = pt.2;
                let mut ps = point_state(
                    st[p],
                    (global[p], slids[p], offsets_global[p], lasts[p]),
                    cohesive,
                );
                let t = lw.evaluate_in(&mut frame, cs, &k, inv_h, &mut ps, want_energy);
                st[p] = ps.history();
                if cohesive {
                    anchors[p] = anchor_to_axes(&ps.anchor, &axes, &n);
                    slids[p] = ps.slid;
                    offsets[p] = anchor_to_axes(&ps.offset, &axes, &n);
                    lasts[p] = ps.last_energy;
                }
                let on_b = -(n * t.normal + dir * t.shear + t.tangential) * (area / 3.0);
                // SAFETY: blocks of one colour share no node, and a block runs on
                // one thread, so no two concurrent writes alias; `f` outlives this.
                unsafe {
                    *fp.get().add(faces[j][0][p] as usize) -= on_b;
                    *fp.get().add(faces[j][1][p] as usize) += on_b;
                }
                s.dissipated += t.dissipated * area / 3.0;
                if want_energy {
                    s.energy += t.energy * area / 3.0;
                }
                if let Some(a) = audit {
                    let closed = t.normal < 0.0 || t.tangential != Vec3::zeros();
                    let regime = audit::Regime::of_point(st[p].damage, closed);
                    let (e, d) = (t.energy * area / 3.0, t.dissipated * area / 3.0);
                    // SAFETY: joint j is this block's.
                    unsafe { a.point(j, p, on_b, e, d, regime) };
                    if Some(j) == audit::traced() {
                        eprintln!(
                            "audit t={time:.6e} joint {j} point {p}: D {:.6} δn {:.4e} δs {:.4e} σ {:.4e} τ {:.4e} |f| {:.4e} Ψ {e:.4e} D {d:.4e}",
                            st[p].damage, pt.0, pt.1, t.normal, t.shear, t.tangential.norm()
                        );
                    }
                }
            }
            let failed = st.iter().all(|p| p.damage >= 1.0);
            if !was_failed && failed {
                s.newly_failed += 1;
            }
            if let (true, JointLaw::Cohesive(c)) = (failed, lw) {
                if c.dilatancy.is_active() {
                    // While a point is within its asperities' reach the joint keeps its faces
                    // from contact; it lets go once every point is open beyond it, holding
                    // no energy then (a dilated point can be compressed with its faces apart,
                    // so contact could otherwise take a joint over from under a loaded point).
                    let reach = 2.0 * c.dilatancy.max_opening;
                    *keeps = pts
                        .iter()
                        .zip(offsets.iter())
                        .any(|((dn, _, _), q)| *dn < c.dilatancy.opening(q.xy().norm()).0 + reach);
                }
            }
        }
        // SAFETY: as above.
        unsafe { *pp.get().add(unit) = s };
    };
    for (colour, blocks) in color_blocks.iter().enumerate() {
        let first = &first_unit[colour];
        if colour == SEQUENTIAL {
            blocks.iter().zip(first).for_each(|(b, &f)| run_block(b, f));
        } else {
            blocks
                .par_iter()
                .zip(first)
                .for_each(|(b, &f)| run_block(b, f));
        }
    }
    crate::math::exact_total(unit_partials)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The block colouring is a valid schedule: every joint is in exactly one block, and no
    /// two blocks of a parallel colour share a node (so concurrent blocks never write the
    /// same node). Joints of a structured chain of tets, large enough for the big-block path.
    #[test]
    fn colour_blocks_partition_the_joints_without_shared_nodes() {
        let mut joints = Joints::default();
        // A chain of prisms: joint j connects nodes 3j..3j+2 to 3j+3..3j+5, plus every 50th
        // joint reaches 600 nodes back (a "previous layer" neighbour).
        let n_joints = 40_000u32;
        for j in 0..n_joints {
            let a = if j % 50 == 0 && j >= 200 {
                3 * (j - 200)
            } else {
                3 * j
            };
            let faces = [[a, a + 1, a + 2], [3 * j + 3, 3 * j + 4, 3 * j + 5]];
            let p = [Vec3::zeros(), Vec3::x(), Vec3::y()];
            joints.push_joint(faces, [j, j + 1], 0, &p);
        }
        let n_nodes = 3 * n_joints as usize + 6;
        joints.prepare(n_nodes);
        let blocks = &joints.color_blocks;
        assert!(blocks.len() <= 3, "{} colours", blocks.len());
        let mut seen = vec![0u8; n_joints as usize];
        for (c, colour) in blocks.iter().enumerate() {
            let mut owner = vec![usize::MAX; n_nodes];
            for (b, range) in colour.iter().enumerate() {
                for j in range.clone() {
                    seen[j] += 1;
                    for &n in joints.faces[j].iter().flatten() {
                        let o = &mut owner[n as usize];
                        assert!(
                            c == SEQUENTIAL || *o == usize::MAX || *o == b,
                            "colour {c}: node {n} in blocks {} and {b}",
                            *o
                        );
                        *o = b;
                    }
                }
            }
        }
        assert!(seen.iter().all(|&k| k == 1));
        // Big blocks were chosen (1/16 of the joints).
        assert_eq!(blocks[0][0].len(), (n_joints as usize).div_ceil(16));
    }

    /// A decomposed model's ranks skip work units (at most [`UNIT`] joints of a block): a
    /// unit it does not compute leaves its partial sums zero and its joints' nodes alone,
    /// and the units it computes give the bits they give when every unit is computed. The
    /// joints (tied) are a chain of flat prisms under a small stretch, with energies.
    #[test]
    fn skipped_units_change_nothing_in_the_units_computed() {
        let n_joints = 20_000u32;
        let mut joints = Joints::default();
        joints.laws.push(JointLaw::Tied {
            normal_penalty: 1e9,
            tangential_penalty: 1e9,
        });
        let mut x0 = Vec::new();
        for j in 0..=n_joints {
            let z = j as Real * 0.01;
            x0.extend([
                Vec3::new(0.0, 0.0, z),
                Vec3::new(0.01, 0.0, z),
                Vec3::new(0.0, 0.01, z),
            ]);
        }
        for j in 0..n_joints {
            let a = 3 * j;
            // Both faces at the same place in the reference configuration (a joint's two
            // sides), the b side one layer up in node numbering only.
            let faces = [[a, a + 1, a + 2], [a + 3, a + 4, a + 5]];
            let p = [x0[a as usize], x0[a as usize + 1], x0[a as usize + 2]];
            joints.push_joint(faces, [j, j + 1], 0, &p);
        }
        let mut nodes = Nodes {
            x: x0
                .iter()
                .enumerate()
                .map(|(i, p)| p + Vec3::new(1e-7 * (i % 7) as Real, 0.0, 2e-7 * (i % 5) as Real))
                .collect(),
            f: vec![Vec3::zeros(); x0.len()],
            ..Default::default()
        };
        joints.prepare(x0.len());
        let units: Vec<_> = joints.units().collect();
        assert!(units.len() > 40, "{} units", units.len());
        assert!(units.iter().all(|u| !u.is_empty() && u.len() <= UNIT));
        let mut seen = vec![0u8; n_joints as usize];
        units
            .iter()
            .flat_map(|u| u.clone())
            .for_each(|j| seen[j] += 1);
        assert!(seen.iter().all(|&k| k == 1));

        let all = add_joint_forces(&mut joints, &mut nodes, 0.0, true);
        let (f_all, partials_all) = (nodes.f.clone(), joints.unit_partials.clone());
        assert!(all.energy > 0.0);
        // Every third unit skipped.
        joints.compute = (0..units.len()).map(|u| u % 3 != 1).collect();
        nodes.f.iter_mut().for_each(|f| *f = Vec3::zeros());
        add_joint_forces(&mut joints, &mut nodes, 0.0, true);
        let mut touched_by_skipped = vec![false; x0.len()];
        for (u, unit) in units.iter().enumerate() {
            if joints.compute[u] {
                assert_eq!(joints.unit_partials[u], partials_all[u], "unit {u}");
            } else {
                assert_eq!(joints.unit_partials[u], JointSums::default(), "unit {u}");
                for j in unit.clone() {
                    for &n in joints.faces[j].iter().flatten() {
                        touched_by_skipped[n as usize] = true;
                    }
                }
            }
        }
        let mut compared = 0;
        for (n, touched) in touched_by_skipped.iter().enumerate() {
            if !touched {
                assert_eq!(nodes.f[n], f_all[n], "node {n}");
                compared += 1;
            }
        }
        assert!(compared > x0.len() / 2, "{compared} nodes compared");
    }

    /// A chain of `n_joints` joints of a soft cohesive law between node layers (joint j
    /// between layers j and j + 1), all at z = 0 in the reference configuration (joints of
    /// zero thickness: the chain's layers are shared, so its blocks alternate colours).
    /// Layer i is lifted by 1 cm for every `pulled` joint below it: the pulled joints open by
    /// 1 cm (their softening length is ~2 mm), the others not at all. Joint `already_broken`
    /// is broken before.
    fn pulled_chain(n_joints: usize, pulled: &[usize], already_broken: usize) -> (Joints, Nodes) {
        let mut joints = Joints::default();
        joints.laws.push(JointLaw::Cohesive(Cohesive {
            softening: law::Softening::Munjiza,
            calibration: law::Calibration::Exact,
            tensile_strength: 1e3,
            cohesion: 2e3,
            tan_friction: 0.5,
            g_i: 1.0,
            g_ii: 4.0,
            normal_penalty: 1e9,
            tangential_penalty: 1e9,
            residual_friction: 0.5,
            rate: law::RateEffects::None,
            dilatancy: law::Dilatancy::NONE,
        }));
        let mut x = Vec::new();
        for i in 0..=n_joints {
            let lift = 0.01 * pulled.iter().filter(|&&j| j < i).count() as Real;
            for (a, b) in [(0.0, 0.0), (0.01, 0.0), (0.0, 0.01)] {
                x.push((Vec3::new(a, b, 0.0), Vec3::new(a, b, lift)));
            }
        }
        for j in 0..n_joints as u32 {
            let a = 3 * j;
            let faces = [[a, a + 1, a + 2], [a + 3, a + 4, a + 5]];
            let p = [x[a as usize].0, x[a as usize + 1].0, x[a as usize + 2].0];
            joints.push_joint(faces, [j, j + 1], 0, &p);
        }
        let nodes = Nodes {
            x: x.iter().map(|p| p.1).collect(),
            f: vec![Vec3::zeros(); x.len()],
            ..Default::default()
        };
        joints.prepare(x.len());
        joints.broken[already_broken] = true;
        joints.state[already_broken]
            .iter_mut()
            .for_each(|p| p.damage = 1.0);
        (joints, nodes)
    }

    /// The joints failed and not broken that a look at every joint finds (the rule before
    /// stage 3 looked at units), in joint order.
    fn failed_by_a_look_at_every_joint(joints: &Joints, relevant: &[bool]) -> Vec<usize> {
        (0..joints.len())
            .filter(|&j| {
                relevant[j] && !joints.broken[j] && joints.state[j].iter().all(|p| p.damage >= 1.0)
            })
            .collect()
    }

    /// Stage 2 then stage 3 on the chain; the joints stage 3 broke, in event order.
    fn stage_2_and_3(
        joints: &mut Joints,
        nodes: &mut Nodes,
        mask: Option<&crate::fracture::JointMask>,
    ) -> (JointSums, Vec<usize>, Vec<usize>) {
        let sums = add_joint_forces(joints, nodes, 0.0, false);
        let all = vec![true; joints.len()];
        let relevant = mask.map_or(&all[..], |m| &m.relevant[..]);
        let expected = failed_by_a_look_at_every_joint(joints, relevant);
        let mut events = Vec::new();
        let tet_body = vec![0u32; joints.len() + 1];
        crate::fracture::break_joints(
            joints,
            &nodes.x,
            &tet_body,
            0.0,
            1,
            sums.newly_failed,
            None,
            &mut events,
            mask,
        );
        (sums, expected, events.iter().map(|e| e.joint).collect())
    }

    /// Stage 3 looks for the joints to break only in the work units that counted a newly
    /// failed joint in stage 2. Reference: a look at every joint (the rule before), which
    /// must find the same joints in the same order (joint order: the break events' order).
    /// A chain of 20 000 joints, 9 of them pulled open far past their softening length in
    /// one step, in units that are not in joint order in the schedule (the chain's blocks
    /// alternate colours), two in one unit, two either side of a unit's end, and one
    /// already broken before; then the same with every third unit not computed, as on a
    /// rank (it must break the failed joints of its own units only).
    #[test]
    fn stage_3_finds_the_failed_joints_in_the_units_that_counted_them() {
        let n_joints = 20_000usize;
        let pulled = [5, 6, 511, 512, 700, 4097, 9000, 15000, 19_999];

        // One process.
        let (mut joints, mut nodes) = pulled_chain(n_joints, &pulled, 3);
        let schedule: Vec<_> = joints.units().map(|u| u.start).collect();
        assert!(
            schedule.windows(2).any(|w| w[1] < w[0]),
            "the units' schedule should not be in joint order"
        );
        let (sums, expected, broke) = stage_2_and_3(&mut joints, &mut nodes, None);
        assert_eq!(sums.newly_failed, pulled.len());
        assert_eq!(expected, pulled);
        assert_eq!(broke, expected);
        assert!(pulled.iter().all(|&j| joints.broken[j]));

        // A rank computing two units in three: it looks at the joints of its units only.
        let (mut joints, mut nodes) = pulled_chain(n_joints, &pulled, 3);
        let units: Vec<_> = joints.units().collect();
        joints.compute = (0..units.len()).map(|u| u % 3 != 1).collect();
        let mut relevant = vec![false; n_joints];
        for (u, unit) in units.iter().enumerate() {
            if joints.compute[u] {
                unit.clone().for_each(|j| relevant[j] = true);
            }
        }
        let mask = crate::fracture::JointMask {
            designated: relevant.clone(),
            relevant,
        };
        let (sums, expected, broke) = stage_2_and_3(&mut joints, &mut nodes, Some(&mask));
        assert!(
            !expected.is_empty() && expected.len() < pulled.len(),
            "{expected:?}"
        );
        assert_eq!(sums.newly_failed, expected.len());
        assert_eq!(broke, expected);
    }
}
