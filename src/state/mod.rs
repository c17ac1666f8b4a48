//! Structure-of-arrays state: nodes, tetrahedra, bodies.

pub mod held;

use crate::math::{Mat3, Real, Vec3};
use crate::mesh::BoundaryFace;
use std::ops::Range;

/// Nodal arrays (contiguous, indexed by node id).
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, Default)]
pub struct Nodes {
    /// Reference position X [m].
    pub x0: Vec<Vec3>,
    /// Current position x(t) [m].
    pub x: Vec<Vec3>,
    /// Velocity at the last half step v(t − dt/2) (v(0) before the first step) [m/s].
    pub v: Vec<Vec3>,
    /// Force accumulator for the current step [N]; zero between steps.
    pub f: Vec<Vec3>,
    /// Lumped mass [kg].
    pub m: Vec<Real>,
    /// Body id.
    pub body: Vec<u32>,
    /// Constrained components: bit 0 = x, 1 = y, 2 = z; [`RIGID_NODE`] marks a node moved by
    /// its rigid body (stage 7's central difference skips it).
    pub constraint: Vec<u8>,
    /// The nodes with a constrained component, their prescribed velocities and reactions.
    pub constrained: Constrained,
}

impl Nodes {
    pub fn len(&self) -> usize {
        self.x.len()
    }
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }
    pub(crate) fn push(&mut self, p: Vec3, body: u32) {
        self.x0.push(p);
        self.x.push(p);
        self.v.push(Vec3::zeros());
        self.f.push(Vec3::zeros());
        self.m.push(0.0);
        self.body.push(body);
        self.constraint.push(0);
    }

    /// Drop the spare capacity that building the model by `push` left (up to as much again
    /// as the arrays hold).
    pub(crate) fn shrink_to_fit(&mut self) {
        self.x0.shrink_to_fit();
        self.x.shrink_to_fit();
        self.v.shrink_to_fit();
        self.f.shrink_to_fit();
        self.m.shrink_to_fit();
        self.body.shrink_to_fit();
        self.constraint.shrink_to_fit();
    }

    /// List the nodes with a constrained component (bits 0–2 of [`Nodes::constraint`]) in
    /// [`Nodes::constrained`], keeping the prescribed velocity and reaction of those listed
    /// before; a node no longer constrained drops out (its reaction reads zero).
    pub(crate) fn index_constrained(&mut self) {
        let old = std::mem::take(&mut self.constrained);
        let mut c = Constrained::default();
        let mut at = 0;
        for (n, &mask) in self.constraint.iter().enumerate() {
            if mask & 0b111 == 0 {
                continue;
            }
            let n = n as u32;
            while at < old.node.len() && old.node[at] < n {
                at += 1;
            }
            let kept = (old.node.get(at) == Some(&n)).then_some(at);
            c.node.push(n);
            c.v_prescribed
                .push(kept.map_or(Vec3::zeros(), |i| old.v_prescribed[i]));
            c.reaction
                .push(kept.map_or(Vec3::zeros(), |i| old.reaction[i]));
        }
        self.constrained = c;
    }

    /// Sum of the reactions of `nodes` (zero for a node without a constrained component) [N].
    pub fn reaction_sum(&self, nodes: &[u32]) -> Vec3 {
        (nodes.iter())
            .filter_map(|&n| self.constrained.slot(n))
            .map(|s| self.constrained.reaction[s])
            .sum()
    }
}

/// The nodes with a constrained component (a fixed or prescribed-velocity component, or a
/// base motion), in node order, with what stages 6 and 7 keep for them: 52 B a constrained
/// node, where arrays over every node cost 48 B a node (most nodes are free). Listed again
/// when the constraints are ([`Nodes::index_constrained`], at prepare).
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, Default)]
pub struct Constrained {
    /// Node ids, ascending.
    pub node: Vec<u32>,
    /// Prescribed velocity of the constrained components at t + dt/2 [m/s] (set by stage 6).
    pub v_prescribed: Vec<Vec3>,
    /// Force the constraints exerted on the constrained components in the last step [N]
    /// (set by stage 7; zero on free components).
    pub reaction: Vec<Vec3>,
}

impl Constrained {
    pub fn len(&self) -> usize {
        self.node.len()
    }
    pub fn is_empty(&self) -> bool {
        self.node.is_empty()
    }
    /// Where node `n` is listed, if it has a constrained component.
    #[inline]
    pub fn slot(&self, n: u32) -> Option<usize> {
        self.node.binary_search(&n).ok()
    }
    /// The first slot of a node `n` or later.
    #[inline]
    pub fn first_from(&self, n: u32) -> usize {
        self.node.partition_point(|&m| m < n)
    }
}

/// Bit of [`Nodes::constraint`] set on the nodes of rigid bodies (by the rigid-body prepare;
/// a rigid body's nodes follow its 6 degrees of freedom, see `integration::rigid`).
pub const RIGID_NODE: u8 = 0b1000;

/// Tetrahedron arrays (contiguous, indexed by element id).
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, Default)]
pub struct Tets {
    pub nodes: Vec<[u32; 4]>,
    /// Inverse of the reference edge matrix [X1−X0, X2−X0, X3−X0]⁻¹ [1/m].
    pub dm_inv: Vec<Mat3>,
    /// Reference volume V₀ [m³].
    pub vol0: Vec<Real>,
    pub material: Vec<u32>,
    pub body: Vec<u32>,
    /// The tet belongs to a rigid body: stage 1 computes no force for it and it does not
    /// limit the time step.
    pub rigid: Vec<bool>,
}

impl Tets {
    pub fn len(&self) -> usize {
        self.nodes.len()
    }
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Drop the spare capacity that building the model left ([`Nodes::shrink_to_fit`]).
    pub(crate) fn shrink_to_fit(&mut self) {
        self.nodes.shrink_to_fit();
        self.dm_inv.shrink_to_fit();
        self.vol0.shrink_to_fit();
        self.material.shrink_to_fit();
        self.body.shrink_to_fit();
        self.rigid.shrink_to_fit();
    }
}

/// How a body's tetrahedra share nodes.
#[derive(serde::Serialize, serde::Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layout {
    /// Every tetrahedron owns its 4 nodes (node multiplicity): tets are held together only by
    /// joint elements, so the body can crack along any face between them.
    Jointed,
    /// Tetrahedra share nodes like ordinary FEM: unbreakable, with about 1/20 of the jointed
    /// layout's nodes on large meshes (a jointed body has 4 nodes per tet; a shared-node mesh
    /// has ~5–6 tets per node).
    Continuous,
    /// Shared nodes like `Continuous`, but the body does not deform: it moves with 6 degrees
    /// of freedom (`integration::rigid`); its tets only give it mass, inertia and a surface.
    Rigid,
}

impl Layout {
    pub fn name(self) -> &'static str {
        match self {
            Layout::Jointed => "jointed",
            Layout::Continuous => "continuous",
            Layout::Rigid => "rigid",
        }
    }
}

/// A body: a contiguous range of tets and of nodes, one material.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug)]
pub struct Body {
    pub name: String,
    pub layout: Layout,
    pub material: u32,
    pub tets: Range<usize>,
    pub nodes: Range<usize>,
    /// Outer boundary faces, with simulation node ids and outward orientation.
    pub boundary: Vec<BoundaryFace>,
    /// The body's mesh with shared nodes, in the current reference placement (tet i of the mesh
    /// is simulation tet `tets.start + i`).
    pub mesh: crate::mesh::Mesh,
}

/// Handle to a material in a simulation.
pub type MaterialId = u32;

/// Two-node bar elements (reinforcing bars): axial force only, lumped mass (stage 1,
/// [`crate::elements::bar2`]). Reference data, then the steel history and the results of the
/// last step, all indexed by bar id.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, Default)]
pub struct Bars {
    pub nodes: Vec<[u32; 2]>,
    /// Reference length L₀ [m].
    pub length0: Vec<Real>,
    /// Cross-section A₀ [m²].
    pub area: Vec<Real>,
    /// Index of the bar's steel in the simulation's steels.
    pub steel: Vec<u32>,
    /// Index of the rebar the bar belongs to.
    pub rebar: Vec<u32>,
    /// Plastic strain ε_p [-].
    pub plastic_strain: Vec<Real>,
    /// The steel law's history variable (accumulated plastic strain α for the built-in law).
    pub history: Vec<Real>,
    /// Strain ε = l/L₀ − 1 of the last step [-].
    pub strain: Vec<Real>,
    /// Nominal axial stress σ = N/A₀ of the last step [Pa] (0 once ruptured).
    pub stress: Vec<Real>,
    /// Plastic work and the elastic energy lost at rupture, summed over the run [J].
    pub dissipated: Vec<Real>,
    /// Time of rupture [s]; NaN while the bar is intact.
    pub ruptured_at: Vec<Real>,
    /// Bending hinges at the bar nodes where two bars of a rebar meet (dowel action).
    pub hinges: BarHinges,
}

/// Bending hinges of the rebars (stage 1, [`crate::elements::bar2`]): at a node where two
/// bars of one rebar meet, a rotational spring on the turning angle θ between them with an
/// elastic–perfectly plastic moment. Indexed by hinge id.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, Default)]
pub struct BarHinges {
    /// [previous, hinge, next] bar nodes.
    pub nodes: Vec<[u32; 3]>,
    /// The bars [previous → hinge, hinge → next].
    pub bars: Vec<[u32; 2]>,
    /// k = E·I/L̄ [N·m/rad]: I = πd⁴/64, L̄ the mean reference length of the two bars.
    pub stiffness: Vec<Real>,
    /// Plastic moment M_p = f_y·d³/6 of the solid circular section [N·m].
    pub plastic_moment: Vec<Real>,
    /// Turning angle θ₀ of the reference placement [rad] (0 along a straight bar).
    pub angle0: Vec<Real>,
    /// Plastic turning angle θ_p [rad].
    pub plastic_angle: Vec<Real>,
    /// Bending moment M = k(θ − θ₀ − θ_p) of the last step [N·m] (0 once a bar is broken).
    pub moment: Vec<Real>,
    /// Plastic work ∫M dθ_p and the elastic energy lost when a bar of the hinge ruptured [J].
    pub dissipated: Vec<Real>,
    /// Stage scratch: the forces of each hinge on its three nodes.
    #[serde(skip)]
    pub force: Vec<[Vec3; 3]>,
}

impl BarHinges {
    pub fn len(&self) -> usize {
        self.nodes.len()
    }
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }
    pub(crate) fn push(
        &mut self,
        nodes: [u32; 3],
        bars: [u32; 2],
        stiffness: Real,
        plastic_moment: Real,
        angle0: Real,
    ) {
        self.nodes.push(nodes);
        self.bars.push(bars);
        self.stiffness.push(stiffness);
        self.plastic_moment.push(plastic_moment);
        self.angle0.push(angle0);
        self.plastic_angle.push(0.0);
        self.moment.push(0.0);
        self.dissipated.push(0.0);
    }
}

impl Bars {
    pub fn len(&self) -> usize {
        self.nodes.len()
    }
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }
    pub(crate) fn push(
        &mut self,
        nodes: [u32; 2],
        length0: Real,
        area: Real,
        steel: u32,
        rebar: u32,
    ) {
        self.nodes.push(nodes);
        self.length0.push(length0);
        self.area.push(area);
        self.steel.push(steel);
        self.rebar.push(rebar);
        self.plastic_strain.push(0.0);
        self.history.push(0.0);
        self.strain.push(0.0);
        self.stress.push(0.0);
        self.dissipated.push(0.0);
        self.ruptured_at.push(Real::NAN);
    }
    /// Axial force N = σ·A₀ of bar `b` in the last step [N] (tension positive).
    pub fn axial_force(&self, b: usize) -> Real {
        self.stress[b] * self.area[b]
    }
}

/// A reinforcing bar laid along a polyline and embedded in a host body: a contiguous range of
/// bar nodes and of bars.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug)]
pub struct Rebar {
    pub name: String,
    /// Bar diameter d [m].
    pub diameter: Real,
    /// Body the bar is embedded in.
    pub host: usize,
    pub nodes: Range<usize>,
    pub bars: Range<usize>,
    /// Index of its steel.
    pub steel: u32,
}
