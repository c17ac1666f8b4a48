//! Stage 7 — rigid bodies: six degrees of freedom per body, integrated on the same staggered
//! grid as the central difference of the deformable nodes.
//!
//! A rigid body keeps its tetrahedra and nodes in the shared arrays, so contact (stages 4–5)
//! and loads (stage 6) see it as any other body; stage 1 computes no force for its tets and
//! the nodes' positions and velocities are set here from the body's state. Per body:
//!
//! ```text
//! M  = ρ Σ_e V_e                              c₀ = Σ_e ρ V_e·x̄_e / M       (exact)
//! I₀ = Σ_e ρ [tr(S_e)·1 − S_e],  S_e = V_e/20·(Σ_i q_i q_iᵀ + s sᵀ), q_i = X_i − c₀, s = Σ_i q_i
//! F  = Σ_n f_n + M·(g + b),                    τ = Σ_n (x_n − c) × f_n       (at t)
//! V(t+dt/2) = [(1 − α dt̄/2)·V(t−dt/2) + dt̄·(F/M + α v_f)] / (1 + α dt̄/2)
//! L(t+dt/2) = [(1 − α dt̄/2)·L(t−dt/2) + dt̄·τ] / (1 + α dt̄/2)
//! c(t+dt)   = c(t) + dt·V(t+dt/2)
//! R(t+dt)   = Φ_dt[L(t+dt/2)] R(t)            (the free rigid-body rotation, split below)
//! x_n(t+dt) = c(t+dt) + R(t+dt)·(X_n − c₀),   v_n(t+dt/2) = (x_n(t+dt) − x_n(t))/dt
//! ```
//!
//! with dt̄ = (dt_prev + dt)/2 as for the nodes (so V(dt/2) = V(0) + dt/2·a(0) on the first
//! step and free fall is exact), g gravity, b the relative-frame body acceleration, α the
//! mass-proportional damping (its torque −α·I·ω is exactly −α·L in the world frame) and
//! v_f the frame velocity damping measures against.
//!
//! **Rotation.** Between kicks L is constant in the world frame, and R follows the free
//! rigid body with that L. Its Hamiltonian T = Σ_k Π_k²/(2I_k) (Π = RᵀL in the principal
//! axes a_k of I₀, moments I_k) is split into its three principal terms, each an exact
//! rotation about a body axis by h·Π_k/I_k (Π_k does not change under it), composed
//! symmetrically: k = 1 (dt/2), 2 (dt/2), 3 (dt), 2 (dt/2), 1 (dt/2) (Dullweber, Leimkuhler &
//! McLachlan 1997, J. Chem. Phys. 107, 5840). Every sub-step is a rotation, so R stays a
//! rotation (a unit quaternion, renormalised each step) and L is untouched: in free flight
//! the angular momentum is conserved to the last bit and the kinetic energy oscillates
//! within O(dt²) without drift (the scheme is symplectic and time-reversible).
//!
//! **Node velocity.** Rigid nodes carry the chord velocity (x(t+dt) − x(t))/dt =
//! V + ω×r̄ + O(dt²), so that x(t+dt) = x(t) + dt·v holds for every node of the model (contact
//! friction and output read v). Σ m_n v_n = M·V because the lumped masses ρV/4 have the
//! body's mass and centroid (Σ_e ρV_e/4·Σ_i X_i = Σ_e ρV_e·x̄_e).
//!
//! **Energy.** The kinetic energy is ½M·V(t−dt/2)·V(t+dt/2) + ½L(t−dt/2)·I(t)⁻¹L(t+dt/2)
//! with I(t)⁻¹ = R I₀⁻¹ Rᵀ, the form the staggered kick conserves, and the rigid nodes are
//! not counted again; gravity's work is M g·(c − c₀) = Σ m_n g·(x_n − X_n).
//!
//! **Constraints.** A body may be fixed, or have prescribed translational velocity
//! components V_k(t + dt/2) with free or fixed rotation. The constraint's force and torque
//! are reported: R_k = M·((V_new − V_old)_k/dt̄ − (g + b)_k) − F_nodes,k and
//! T = (L_new − L_old)/dt̄ − τ.
//!
//! Deterministic for any thread count: a large body's nodes are gathered in fixed chunks
//! summed in order, bodies one after another.

use super::{IntegrationSums, StepCoefficients, StepParams, CHUNK};
use crate::loads::TimeFunction;
use crate::math::{Mat3, Real, Vec3};
use crate::state::{Body, Nodes, Tets, RIGID_NODE};
use nalgebra::{Unit, UnitQuaternion};
use rayon::prelude::*;
use std::ops::Range;

/// Mass, centre of mass and inertia tensor of a set of tetrahedra of one density, integrated
/// exactly (constant density over each tet).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MassProperties {
    /// M = ρ Σ V_e [kg].
    pub mass: Real,
    /// c = Σ ρ V_e x̄_e / M [m].
    pub center: Vec3,
    /// I = ∫ρ (|r|²·1 − r rᵀ) dV about c [kg·m²].
    pub inertia: Mat3,
}

/// Mass properties of the tets `tets` (their reference volumes `vol`, corner positions from
/// `corners(e)`) of density `density` [kg/m³]. Two passes (mass and centroid, then the
/// second moment about the centroid) so that nothing cancels.
pub fn mass_properties(
    tets: Range<usize>,
    vol: &[Real],
    corners: impl Fn(usize) -> [Vec3; 4],
    density: Real,
) -> MassProperties {
    let (mut volume, mut first) = (0.0, Vec3::zeros());
    for e in tets.clone() {
        let p = corners(e);
        volume += vol[e];
        first += (p[0] + p[1] + p[2] + p[3]) * (vol[e] / 4.0);
    }
    let center = first / volume;
    let mut second = Mat3::zeros();
    for e in tets {
        let q = corners(e).map(|p| p - center);
        let s = q[0] + q[1] + q[2] + q[3];
        let mut m = s * s.transpose();
        for qi in &q {
            m += qi * qi.transpose();
        }
        second += m * (vol[e] / 20.0);
    }
    let second = second * density;
    MassProperties {
        mass: density * volume,
        center,
        inertia: Mat3::identity() * second.trace() - second,
    }
}

/// One rigid body: reference data, the state on the staggered grid, its constraint and the
/// results of the last step.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug)]
pub struct RigidBody {
    /// Body id.
    pub body: usize,
    /// Its nodes in the node arrays.
    pub nodes: Range<usize>,
    pub mass: Real,
    /// Centre of mass in the reference placement c₀ [m].
    pub center0: Vec3,
    /// Inertia tensor about the centre of mass in the reference placement I₀ [kg·m²].
    pub inertia0: Mat3,
    /// Principal moments I_k [kg·m²] and axes a_k of I₀ (reference frame).
    moments: Vec3,
    axes: [Unit<Vec3>; 3],
    /// X_n − c₀ of each node [m].
    offsets: Vec<Vec3>,
    /// Centre of mass c(t) [m].
    pub center: Vec3,
    /// Rotation from the reference placement R(t).
    pub orientation: UnitQuaternion<Real>,
    /// Velocity of the centre of mass V(t − dt/2) (V(0) before the first step) [m/s].
    pub velocity: Vec3,
    /// Angular momentum about the centre of mass L(t − dt/2), world frame [kg·m²/s].
    pub angular_momentum: Vec3,
    /// Prescribed velocity of the centre of mass per component (None: free) [m/s].
    pub translation: [Option<TimeFunction>; 3],
    /// The rotation is held (ω = 0).
    pub rotation_fixed: bool,
    /// Resultant of the nodal forces (contact, applied loads) in the last step [N].
    pub force: Vec3,
    /// Their moment about the centre of mass [N·m].
    pub torque: Vec3,
    /// Force and torque the constraint exerted in the last step [N], [N·m].
    pub reaction: Vec3,
    pub reaction_torque: Vec3,
    /// (V(t+dt/2) − V(t−dt/2))/dt̄ of the last step [m/s²].
    pub acceleration: Vec3,
    partials: Vec<(Vec3, Vec3)>,
}

impl RigidBody {
    /// A rigid body at rest in its reference placement.
    pub fn new(id: usize, body: &Body, tets: &Tets, x0: &[Vec3], density: Real) -> Self {
        let mut rb = RigidBody {
            body: id,
            nodes: body.nodes.clone(),
            mass: 0.0,
            center0: Vec3::zeros(),
            inertia0: Mat3::zeros(),
            moments: Vec3::zeros(),
            axes: [Vec3::x_axis(), Vec3::y_axis(), Vec3::z_axis()],
            offsets: Vec::new(),
            center: Vec3::zeros(),
            orientation: UnitQuaternion::identity(),
            velocity: Vec3::zeros(),
            angular_momentum: Vec3::zeros(),
            translation: [None, None, None],
            rotation_fixed: false,
            force: Vec3::zeros(),
            torque: Vec3::zeros(),
            reaction: Vec3::zeros(),
            reaction_torque: Vec3::zeros(),
            acceleration: Vec3::zeros(),
            partials: Vec::with_capacity(body.nodes.len().div_ceil(CHUNK)),
        };
        rb.reference(body, tets, x0, density);
        rb
    }

    /// (Re)compute the reference data from the body's reference placement `x0` (after the
    /// body was moved before the first step): the body is at c₀ with R = 1.
    pub fn reference(&mut self, body: &Body, tets: &Tets, x0: &[Vec3], density: Real) {
        let mp = mass_properties(
            body.tets.clone(),
            &tets.vol0,
            |e| tets.nodes[e].map(|n| x0[n as usize]),
            density,
        );
        let eig = mp.inertia.symmetric_eigen();
        self.mass = mp.mass;
        self.center0 = mp.center;
        self.inertia0 = mp.inertia;
        self.moments = eig.eigenvalues;
        self.axes = [0, 1, 2].map(|k| Unit::new_normalize(eig.eigenvectors.column(k).into()));
        self.offsets = body.nodes.clone().map(|n| x0[n] - mp.center).collect();
        self.center = mp.center;
        self.orientation = UnitQuaternion::identity();
    }

    /// R(t) as a matrix.
    pub fn rotation(&self) -> Mat3 {
        self.orientation.to_rotation_matrix().into_inner()
    }

    /// Inertia tensor about the centre of mass in the current orientation R I₀ Rᵀ [kg·m²].
    pub fn inertia(&self) -> Mat3 {
        let r = self.rotation();
        r * self.inertia0 * r.transpose()
    }

    /// ω = R I₀⁻¹ Rᵀ L [rad/s] for the angular momentum `l` at the current orientation.
    pub fn omega_of(&self, l: &Vec3) -> Vec3 {
        let pi = self.orientation.inverse_transform_vector(l);
        let mut w = Vec3::zeros();
        for k in 0..3 {
            w += self.axes[k].into_inner() * (self.axes[k].dot(&pi) / self.moments[k]);
        }
        self.orientation.transform_vector(&w)
    }

    /// Angular velocity at the last half step [rad/s].
    pub fn angular_velocity(&self) -> Vec3 {
        self.omega_of(&self.angular_momentum)
    }

    /// Kinetic energy ½M|V|² + ½ω·L of the last half-step velocities [J].
    pub fn kinetic_energy(&self) -> Real {
        0.5 * self.mass * self.velocity.norm_squared()
            + 0.5 * self.angular_velocity().dot(&self.angular_momentum)
    }

    /// Set the velocity of the centre of mass `v` [m/s] and the angular velocity `w`
    /// [rad/s] (L = I ω) now, and the nodes' velocities to the rigid field V + ω×r.
    pub fn set_motion(&mut self, v: Vec3, w: Vec3, x: &[Vec3], node_v: &mut [Vec3]) {
        self.velocity = v;
        self.angular_momentum = self.inertia() * w;
        for n in self.nodes.clone() {
            node_v[n] = v + w.cross(&(x[n] - self.center));
        }
    }

    /// The smallest effective mass of the body at each of its nodes, for the contact
    /// penalty's time-step bound: 1/m = 1/M + max_|e|=1 (r×e)·I⁻¹(r×e), written into
    /// `m_eff` (the body's nodes only) when smaller than the lumped mass there.
    fn effective_masses(&self, m_eff: &mut [Real]) {
        let i_inv = self.inertia().try_inverse().unwrap_or_else(Mat3::zeros);
        let rot = self.rotation();
        for (k, n) in self.nodes.clone().enumerate() {
            let r = rot * self.offsets[k];
            let rx = r.cross_matrix();
            let worst = (rx.transpose() * i_inv * rx).symmetric_eigenvalues().max();
            m_eff[n] = m_eff[n].min(1.0 / (1.0 / self.mass + worst.max(0.0)));
        }
    }
}

/// The rigid bodies of a model (in body order) and the masses the contact time-step bound
/// uses for their nodes.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, Default)]
pub struct RigidBodies {
    pub bodies: Vec<RigidBody>,
    contact_mass: Vec<Real>,
}

impl RigidBodies {
    pub fn is_empty(&self) -> bool {
        self.bodies.is_empty()
    }

    /// The rigid body of body `body`, if it is rigid.
    pub fn of_body(&self, body: usize) -> Option<&RigidBody> {
        self.bodies.iter().find(|r| r.body == body)
    }
    pub fn of_body_mut(&mut self, body: usize) -> Option<&mut RigidBody> {
        self.bodies.iter_mut().find(|r| r.body == body)
    }

    /// Mark the rigid bodies' nodes ([`RIGID_NODE`]) after the constraint masks were rebuilt.
    /// A node constraint (fix, prescribed velocity, base motion) on a rigid body's node is an
    /// error naming the body: its motion is prescribed on the body. Also sizes the masses of
    /// the contact bound.
    pub fn prepare(&mut self, nodes: &mut Nodes, bodies: &[Body]) -> Result<(), String> {
        for rb in &self.bodies {
            let held = nodes.constraint[rb.nodes.clone()]
                .iter()
                .filter(|&&c| c != 0)
                .count();
            if held > 0 {
                return Err(format!(
                    "body '{}' is rigid: {held} of its {} nodes are fixed or given a velocity node by node (sim.fix, sim.prescribe_velocity or sim.shake_base); a rigid body's motion is prescribed on the body: use body.fix() or body.prescribe_velocity(#{{ x, y, z, rotation }})",
                    bodies[rb.body].name,
                    rb.nodes.len()
                ));
            }
            nodes.constraint[rb.nodes.clone()]
                .iter_mut()
                .for_each(|c| *c = RIGID_NODE);
        }
        self.contact_mass.clear();
        if !self.bodies.is_empty() {
            self.contact_mass.extend_from_slice(&nodes.m);
            for rb in &self.bodies {
                rb.effective_masses(&mut self.contact_mass);
            }
        }
        Ok(())
    }

    /// Nodal masses for the contact penalty's time-step bound: the lumped masses, lowered at
    /// rigid bodies' nodes to the body's smallest effective mass there (a point of a rigid
    /// body can be lighter than its lumped mass: I from the tets is smaller than the lumped
    /// second moment). Valid after [`Self::prepare`].
    pub fn contact_masses<'a>(&'a self, m: &'a [Real]) -> &'a [Real] {
        if self.contact_mass.len() == m.len() {
            &self.contact_mass
        } else {
            m
        }
    }

    /// ½M|V|² + ½ω·L summed over the rigid bodies, at the last half step [J].
    pub fn kinetic_energy(&self) -> Real {
        self.bodies.iter().map(RigidBody::kinetic_energy).sum()
    }
}

/// Stage 7 for the rigid bodies, first half: each body's resultant force and torque from its
/// nodes' forces (which are cleared), into `force` and `torque`. On a decomposed model only
/// the rank owning a body's nodes has all their forces; it shares the two vectors
/// (`Parallel::share_rigid_loads`) before [`advance`].
pub fn gather_loads(rigid: &mut RigidBodies, nodes: &mut Nodes) {
    for rb in &mut rigid.bodies {
        gather(rb, nodes);
    }
}

/// Stage 7 for the rigid bodies, second half: advance each body one step under the force
/// and torque of [`gather_loads`], and place its nodes. `time` is t at the start of the step.
/// The sums (kinetic energy, gravity work, constraint work, damping, momentum) are added to
/// `sums`, after the nodes' (the same order on any number of ranks).
pub fn advance(
    rigid: &mut RigidBodies,
    nodes: &mut Nodes,
    p: StepParams,
    time: Real,
    sums: &mut IntegrationSums,
) {
    for rb in &mut rigid.bodies {
        let (w_old, w_new) = kick(rb, p, time, sums);
        if p.sample {
            let l_new = rb.angular_momentum;
            let first = p.dt_prev == 0.0;
            let w_minus = if first && !rb.rotation_fixed {
                2.0 * w_old - w_new
            } else {
                w_old
            };
            sums.kinetic += 0.5 * l_new.dot(&w_minus);
            sums.gravity_work += rb.mass * p.gravity.dot(&(rb.center - rb.center0));
        }
        rb.center += rb.velocity * p.dt;
        rotate(rb, p.dt);
        place_nodes(rb, nodes, p.dt);
        sums.momentum += rb.velocity * rb.mass;
        let finite = rb.center.iter().chain(rb.velocity.iter()).sum::<Real>()
            + rb.angular_momentum.sum()
            + rb.orientation.coords.sum();
        sums.non_finite += usize::from(!finite.is_finite());
    }
}

/// F = Σ f_n and τ = Σ (x_n − c) × f_n over the body's nodes (fixed chunks, summed in
/// order), into `rb.force`, `rb.torque`; the nodes' forces are cleared.
fn gather(rb: &mut RigidBody, nodes: &mut Nodes) {
    let c = rb.center;
    let r = rb.nodes.clone();
    let (xs, fs) = (&nodes.x[r.clone()], &mut nodes.f[r]);
    let chunk = |x: &[Vec3], f: &mut [Vec3]| {
        let (mut force, mut torque) = (Vec3::zeros(), Vec3::zeros());
        for (x, f) in x.iter().zip(f.iter_mut()) {
            force += *f;
            torque += (x - c).cross(f);
            *f = Vec3::zeros();
        }
        (force, torque)
    };
    if xs.len() <= CHUNK {
        (rb.force, rb.torque) = chunk(xs, fs);
        return;
    }
    xs.par_chunks(CHUNK)
        .zip(fs.par_chunks_mut(CHUNK))
        .map(|(x, f)| chunk(x, f))
        .collect_into_vec(&mut rb.partials);
    (rb.force, rb.torque) = rb
        .partials
        .iter()
        .fold((Vec3::zeros(), Vec3::zeros()), |a, b| {
            (a.0 + b.0, a.1 + b.1)
        });
}

/// The kick: V and L from t − dt/2 to t + dt/2 under F, τ, gravity, the body force, mass
/// damping and the constraint (whose force and torque are recorded), with the constraint
/// work and damping booked as the nodes book theirs. Returns ω(t−dt/2) and ω(t+dt/2), both
/// with R(t).
fn kick(rb: &mut RigidBody, p: StepParams, time: Real, s: &mut IntegrationSums) -> (Vec3, Vec3) {
    let StepCoefficients {
        dt_bar,
        c_old,
        c_inv,
        first,
        half_before,
        half_after,
        body,
    } = p.coefficients();
    let m = rb.mass;
    let v_old = rb.velocity;
    let acc = rb.force / m + body;
    let mut v_new = (v_old * c_old + (acc + p.frame_velocity * p.mass_damping) * dt_bar) * c_inv;
    let mut reaction = Vec3::zeros();
    let mut held = [false; 3];
    for k in 0..3 {
        if let Some(tf) = &rb.translation[k] {
            held[k] = true;
            v_new[k] = tf.eval(time + 0.5 * p.dt);
            reaction[k] = m * ((v_new[k] - v_old[k]) / dt_bar - body[k]) - rb.force[k];
        }
    }
    let l_old = rb.angular_momentum;
    let (l_new, reaction_torque) = if rb.rotation_fixed {
        (Vec3::zeros(), -l_old / dt_bar - rb.torque)
    } else {
        ((l_old * c_old + rb.torque * dt_bar) * c_inv, Vec3::zeros())
    };
    let (w_old, w_new) = (rb.omega_of(&l_old), rb.omega_of(&l_new));
    // Constraint work: the force at V, the torque at ω, each half step (a jump at t = 0
    // works at the mean velocity, as for the nodes).
    let (v_after, w_after) = if first {
        ((v_old + v_new) * 0.5, (w_old + w_new) * 0.5)
    } else {
        (v_new, w_new)
    };
    s.reaction_work_before += (reaction.dot(&v_old) + reaction_torque.dot(&w_old)) * half_before;
    s.reaction_work_after += (reaction.dot(&v_after) + reaction_torque.dot(&w_after)) * half_after;
    if p.mass_damping > 0.0 {
        let mut fd = ((v_old + v_new) * 0.5 - p.frame_velocity) * (p.mass_damping * m);
        for k in (0..3).filter(|&k| held[k]) {
            fd[k] = 0.0;
        }
        let td = if rb.rotation_fixed {
            Vec3::zeros()
        } else {
            (l_old + l_new) * (0.5 * p.mass_damping)
        };
        s.damping_before += (fd.dot(&v_old) + td.dot(&w_old)) * half_before;
        s.damping_after += (fd.dot(&v_new) + td.dot(&w_new)) * half_after;
    }
    if p.sample {
        let mut v_minus = v_old;
        if first {
            for k in (0..3).filter(|&k| !held[k]) {
                v_minus[k] = 2.0 * v_old[k] - v_new[k];
            }
        }
        s.kinetic += 0.5 * m * v_minus.dot(&v_new);
    }
    rb.acceleration = (v_new - v_old) / dt_bar;
    rb.velocity = v_new;
    rb.angular_momentum = l_new;
    rb.reaction = reaction;
    rb.reaction_torque = reaction_torque;
    (w_old, w_new)
}

/// R(t+dt) from R(t) under the free rotation with the angular momentum L(t+dt/2): the
/// symmetric split 1(h/2) 2(h/2) 3(h) 2(h/2) 1(h/2), each an exact rotation about a
/// principal axis of the body by h·Π_k/I_k, Π = RᵀL.
fn rotate(rb: &mut RigidBody, dt: Real) {
    if rb.angular_momentum == Vec3::zeros() {
        return;
    }
    for (k, h) in [(0, 0.5), (1, 0.5), (2, 1.0), (1, 0.5), (0, 0.5)] {
        let pi = rb
            .orientation
            .inverse_transform_vector(&rb.angular_momentum);
        let angle = h * dt * rb.axes[k].dot(&pi) / rb.moments[k];
        rb.orientation *= UnitQuaternion::from_axis_angle(&rb.axes[k], angle);
    }
    rb.orientation.renormalize();
}

/// x_n = c + R·(X_n − c₀) and v_n = (x_n(t+dt) − x_n(t))/dt for the body's nodes.
fn place_nodes(rb: &mut RigidBody, nodes: &mut Nodes, dt: Real) {
    let (c, rot) = (rb.center, rb.rotation());
    let r = rb.nodes.clone();
    let (xs, vs) = (&mut nodes.x[r.clone()], &mut nodes.v[r]);
    let offsets = &rb.offsets;
    let chunk = |i0: usize, x: &mut [Vec3], v: &mut [Vec3]| {
        for (i, (x, v)) in x.iter_mut().zip(v.iter_mut()).enumerate() {
            let x_new = c + rot * offsets[i0 + i];
            *v = (x_new - *x) / dt;
            *x = x_new;
        }
    };
    if xs.len() <= CHUNK {
        chunk(0, xs, vs);
        return;
    }
    xs.par_chunks_mut(CHUNK)
        .zip(vs.par_chunks_mut(CHUNK))
        .enumerate()
        .for_each(|(k, (x, v))| chunk(k * CHUNK, x, v));
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The unit cube split into 6 tets (Kuhn) has M = ρ, c = (½,½,½) and I = ρ/6·1 exactly.
    #[test]
    fn unit_cube_mass_properties() {
        let mesh = crate::mesh::box_mesh(Vec3::zeros(), Vec3::repeat(1.0), [1, 1, 1]);
        let vol: Vec<Real> = (0..mesh.tets.len())
            .map(|e| {
                let p = mesh.tet_points(e);
                crate::math::tet_volume(&p[0], &p[1], &p[2], &p[3]).abs()
            })
            .collect();
        let mp = mass_properties(0..mesh.tets.len(), &vol, |e| mesh.tet_points(e), 2.0);
        assert!((mp.mass - 2.0).abs() < 1e-14);
        assert!((mp.center - Vec3::repeat(0.5)).norm() < 1e-15);
        assert!((mp.inertia - Mat3::identity() * (2.0 / 6.0)).norm() < 1e-15);
    }
}
