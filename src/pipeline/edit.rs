//! Edits of a model between runs: moving bodies in their reference placement, constraints,
//! prescribed velocities, applied forces and ground shaking (initial velocities and the
//! body-level edits are in `rigid.rs`). Each is what the script functions of the same name
//! do, callable from Rust.

use super::{SimError, Simulation};
use crate::loads::{
    GroundRecord, NodalForces, PrescribedVelocity, Shaking, ShakingKind, TimeFunction,
};
use crate::math::{edge_matrix, rotation_matrix, Real, Vec3};
use crate::mesh::BoundaryFace;
use std::sync::Arc;

impl Simulation {
    /// Translate body `body` by `d` [m]: its reference and current node positions and its
    /// mesh move together, so the body stays unstrained. Only before the first step (the
    /// reference configuration would change under a running model); an error otherwise.
    pub fn translate_body(&mut self, body: usize, d: Vec3) -> Result<(), SimError> {
        self.move_body(body, |p| p + d)
    }

    /// Rotate body `body` by `angle` [rad] about the axis through `center` [m] along `axis`
    /// (any non-zero length; right-hand rule). Like [`Self::translate_body`], only before the
    /// first step; the tets' reference data (D_m⁻¹) are rebuilt, volumes are unchanged.
    pub fn rotate_body(
        &mut self,
        body: usize,
        axis: Vec3,
        angle: Real,
        center: Vec3,
    ) -> Result<(), SimError> {
        let r = rotation_matrix(&axis, angle);
        self.move_body(body, |p| center + r * (p - center))
    }

    /// Apply the rigid motion `f` to a body's reference placement (nodes x₀ = x, its mesh) and
    /// rebuild its tets' D_m⁻¹. A rigid motion keeps every tet as it is in exact arithmetic;
    /// in floating point a move to 1e300 m leaves no digits for the tet's size, so the new
    /// placement is checked first and refused, with the body unchanged, if a tet becomes
    /// degenerate or a coordinate non-finite.
    fn move_body(&mut self, body: usize, f: impl Fn(Vec3) -> Vec3) -> Result<(), SimError> {
        if self.step > 0 {
            return Err(SimError::Invalid("bodies can be moved only before the first step (their reference configuration would change)".into()));
        }
        let nodes = self.bodies[body].nodes.clone();
        let moved: Vec<Vec3> = nodes.clone().map(|n| f(self.nodes.x0[n])).collect();
        let x0 = &self.nodes.x0;
        let at = |n: u32| {
            let n = n as usize;
            if nodes.contains(&n) {
                moved[n - nodes.start]
            } else {
                x0[n]
            }
        };
        let mut dm_inv = Vec::with_capacity(self.bodies[body].tets.len());
        for e in self.bodies[body].tets.clone() {
            let p = self.tets.nodes[e].map(at);
            let inverse = edge_matrix(&p[0], &p[1], &p[2], &p[3])
                .try_inverse()
                .filter(|m| m.iter().all(|x| x.is_finite()));
            match inverse {
                Some(m) if p.iter().all(|q| q.iter().all(|x| x.is_finite())) => dm_inv.push(m),
                _ => {
                    return Err(SimError::Invalid(format!(
                        "moving body '{}' would put tet {e} at ({:.6e}, {:.6e}, {:.6e}), where its size is lost in rounding (a degenerate tet); move it less far",
                        self.bodies[body].name, p[0].x, p[0].y, p[0].z
                    )))
                }
            }
        }
        for (n, p) in nodes.zip(&moved) {
            self.nodes.x0[n] = *p;
            self.nodes.x[n] = *p;
        }
        for p in &mut self.bodies[body].mesh.nodes {
            *p = f(*p);
        }
        // dm_inv changes under rotation: the tets' reference data, rebuilt above.
        for (e, m) in self.bodies[body].tets.clone().zip(dm_inv) {
            self.tets.dm_inv[e] = m;
        }
        self.rigid_moved(body);
        self.invalidate();
        Ok(())
    }

    /// Fix the displacement components of `nodes` marked in `components` [x, y, z] (a
    /// prescribed velocity of zero from now on); their current velocity components are set
    /// to zero too.
    pub fn fix(&mut self, nodes: &[u32], components: [bool; 3]) {
        self.loads.prescribed.push(PrescribedVelocity {
            nodes: nodes.to_vec(),
            components: components.map(|c| c.then_some(TimeFunction::Constant(0.0))),
        });
        for &i in nodes {
            for (k, _) in components.iter().enumerate().filter(|(_, &c)| c) {
                self.nodes.v[i as usize][k] = 0.0;
            }
        }
        self.invalidate();
    }

    /// Prescribe the velocity [m/s] of the given components of `nodes`, each a function of
    /// time (None leaves a component free). A later prescription wins per component; the
    /// constraint force is reported in `nodes.constrained.reaction`
    /// ([`crate::state::Nodes::reaction_sum`]).
    pub fn prescribe_velocity(&mut self, nodes: &[u32], components: [Option<TimeFunction>; 3]) {
        self.loads.prescribed.push(PrescribedVelocity {
            nodes: nodes.to_vec(),
            components,
        });
        self.invalidate();
    }

    /// Apply the force `force` [N] to each of `nodes`, scaled by `scale(t)`.
    pub fn add_nodal_force(&mut self, nodes: &[u32], force: Vec3, scale: TimeFunction) {
        self.loads.forces.push(NodalForces::new(
            nodes.to_vec(),
            vec![force; nodes.len()],
            scale,
        ));
    }

    /// Apply the traction `traction` [Pa] on the reference area of `faces` (a dead load,
    /// lumped as area/3 to each face node), scaled by `scale(t)`.
    pub fn add_traction(&mut self, faces: &[BoundaryFace], traction: Vec3, scale: TimeFunction) {
        let forces = NodalForces::traction(faces, &self.nodes.x0, traction, scale);
        self.loads.forces.push(forces);
    }

    /// Shake the model with ground-motion records (x, y, z; at least one) whose t = 0 falls
    /// at simulation time `start` (None: now), in one of the two ways of
    /// [`crate::loads::shaking`]: `ShakingKind::Base(nodes)` makes the nodes follow the
    /// ground in all three components (over any other prescription of theirs);
    /// `ShakingKind::Relative` loads every node with −m·a_g(t) (fix the base yourself).
    pub fn shake(
        &mut self,
        records: [Option<Arc<GroundRecord>>; 3],
        start: Option<Real>,
        kind: ShakingKind,
    ) -> Result<(), String> {
        if records.iter().all(|r| r.is_none()) {
            return Err("give at least one record (x, y or z)".into());
        }
        let start = start.unwrap_or(self.time);
        if !start.is_finite() || start < self.time - 1e-9 * self.dt.max(1e-300) {
            return Err(format!(
                "start = {start} s is before the current time t = {} s; a record can start now or later",
                self.time
            ));
        }
        if let ShakingKind::Base(nodes) = &kind {
            if nodes.is_empty() {
                return Err("the base node set is empty".into());
            }
        }
        self.loads.shaking.push(Shaking::new(records, start, kind));
        self.invalidate();
        Ok(())
    }
}
