//! Rigid bodies in the model: creating their state when a body is added with the rigid
//! layout, checking the model before a run, and the body-level edits and queries that apply
//! to rigid and deformable bodies alike (velocity, spin, fixing, centre of mass). The
//! dynamics are stage 7's ([`crate::integration::rigid`]).

use super::{SimError, Simulation};
use crate::integration::rigid::RigidBody;
use crate::loads::TimeFunction;
use crate::math::{Real, Vec3};
use crate::state::Layout;

impl Simulation {
    /// Create the rigid state of body `id` (just added with [`Layout::Rigid`]): mass, centre
    /// of mass and inertia from its tets, at rest.
    pub(super) fn add_rigid(&mut self, id: usize) {
        let b = &self.bodies[id];
        let density = self.materials[b.material as usize].density;
        let rb = RigidBody::new(id, b, &self.tets, &self.nodes.x0, density);
        self.rigid.bodies.push(rb);
    }

    /// Recompute a rigid body's reference data after it was moved before the first step.
    pub(super) fn rigid_moved(&mut self, id: usize) {
        let b = &self.bodies[id];
        let density = self.materials[b.material as usize].density;
        if let Some(rb) = self.rigid.of_body_mut(id) {
            rb.reference(b, &self.tets, &self.nodes.x0, density);
        }
    }

    /// Before a run: mark the rigid bodies' nodes, refuse node-by-node constraints on them
    /// and joints that touch them (errors naming the body).
    pub(super) fn prepare_rigid(&mut self) -> Result<(), SimError> {
        if self.rigid.is_empty() {
            return Ok(());
        }
        self.rigid
            .prepare(&mut self.nodes, &self.bodies)
            .map_err(SimError::Invalid)?;
        if let Some(j) = (0..self.joints.len()).find(|&j| {
            self.joints.tets[j]
                .iter()
                .any(|&e| self.tets.rigid[e as usize])
        }) {
            let e = self.joints.tets[j]
                .into_iter()
                .find(|&e| self.tets.rigid[e as usize])
                .unwrap_or(0);
            return Err(SimError::Invalid(format!(
                "joint {j} touches body '{}', which is rigid: a rigid body takes no joints",
                self.bodies[self.tets.body[e as usize] as usize].name
            )));
        }
        Ok(())
    }

    /// The rigid state of body `body`, or an error naming the body when it is not rigid.
    pub fn rigid_body(&self, body: usize) -> Result<&RigidBody, SimError> {
        self.rigid.of_body(body).ok_or_else(|| {
            SimError::Invalid(format!(
                "body '{}' is {}, not rigid",
                self.bodies[body].name,
                self.bodies[body].layout.name()
            ))
        })
    }

    /// Centre of mass of body `body` now [m]: the rigid body's c, or Σ ρV_e·x̄_e/M over the
    /// deformed tets (exact for linear tets: x is affine in X over each).
    pub fn center_of_mass(&self, body: usize) -> Vec3 {
        if let Some(rb) = self.rigid.of_body(body) {
            return rb.center;
        }
        self.tet_mass_mean(body, &self.nodes.x)
    }

    /// Velocity of body `body`'s centre of mass at the last half step [m/s]: the rigid
    /// body's V, or Σ m_n v_n / M with the lumped masses ρV/4 of its tets.
    pub fn body_velocity(&self, body: usize) -> Vec3 {
        if let Some(rb) = self.rigid.of_body(body) {
            return rb.velocity;
        }
        self.tet_mass_mean(body, &self.nodes.v)
    }

    /// Σ_e V_e·(mean of `field` over tet e's corners) / Σ_e V_e over body `body`'s tets: the
    /// mass-weighted mean of a nodal field with the lumped masses ρV/4 (one density a body).
    fn tet_mass_mean(&self, body: usize, field: &[Vec3]) -> Vec3 {
        let (mut v, mut sum) = (0.0, Vec3::zeros());
        for e in self.bodies[body].tets.clone() {
            let s: Vec3 = self.tets.nodes[e].iter().map(|&n| field[n as usize]).sum();
            sum += s * (self.tets.vol0[e] / 4.0);
            v += self.tets.vol0[e];
        }
        sum / v
    }

    /// Give body `body` the velocity `v` [m/s] at every point now (no spin): a rigid body's
    /// V = v and L = 0, a deformable body's nodes v.
    pub fn set_body_velocity(&mut self, body: usize, v: Vec3) {
        self.set_body_motion(body, v, Vec3::zeros(), None);
    }

    /// Spin body `body` at `w` [rad/s] about the axis through `centre` (None: its centre of
    /// mass), on top of the velocity of its centre of mass V before the call:
    /// v(x) = V + w × (x − centre). A rigid body gets L = I·w.
    pub fn set_body_spin(&mut self, body: usize, w: Vec3, centre: Option<Vec3>) {
        let v = self.body_velocity(body);
        self.set_body_motion(body, v, w, centre);
    }

    /// v(x) = v + w × (x − centre) on body `body` (centre None: the centre of mass).
    fn set_body_motion(&mut self, body: usize, v: Vec3, w: Vec3, centre: Option<Vec3>) {
        let c = self.center_of_mass(body);
        let centre = centre.unwrap_or(c);
        // Velocity of the centre of mass under the new field.
        let v_c = v + w.cross(&(c - centre));
        if let Some(rb) = self.rigid.of_body_mut(body) {
            rb.set_motion(v_c, w, &self.nodes.x, &mut self.nodes.v);
            return;
        }
        for n in self.bodies[body].nodes.clone() {
            self.nodes.v[n] = v + w.cross(&(self.nodes.x[n] - centre));
        }
    }

    /// Fix body `body`: a rigid body is held in place (translation and rotation, its
    /// velocity set to zero), a deformable body has all its nodes fixed.
    pub fn fix_body(&mut self, body: usize) {
        if let Some(rb) = self.rigid.of_body_mut(body) {
            rb.translation = [0, 1, 2].map(|_| Some(TimeFunction::Constant(0.0)));
            rb.rotation_fixed = true;
            rb.set_motion(
                Vec3::zeros(),
                Vec3::zeros(),
                &self.nodes.x,
                &mut self.nodes.v,
            );
            self.invalidate();
            return;
        }
        let nodes: Vec<u32> = self.bodies[body].nodes.clone().map(|n| n as u32).collect();
        self.fix(&nodes, [true; 3]);
    }

    /// Prescribe the velocity of a rigid body's centre of mass: each component a function of
    /// time [m/s] evaluated at t + dt/2 (None leaves it free; a later call wins per
    /// component), and the rotation held (`Some(true)`), freed (`Some(false)`) or left as it
    /// is (None). Held components' and the rotation's current velocity take the prescribed
    /// value at once. An error for a deformable body.
    pub fn prescribe_body_velocity(
        &mut self,
        body: usize,
        components: [Option<TimeFunction>; 3],
        rotation_fixed: Option<bool>,
    ) -> Result<(), SimError> {
        self.rigid_body(body)?;
        let t = self.time;
        let rb = self.rigid.of_body_mut(body).expect("checked rigid");
        let mut v = rb.velocity;
        for (k, c) in components.into_iter().enumerate() {
            if let Some(tf) = c {
                v[k] = tf.eval(t);
                rb.translation[k] = Some(tf);
            }
        }
        if let Some(fixed) = rotation_fixed {
            rb.rotation_fixed = fixed;
        }
        let w = if rb.rotation_fixed {
            Vec3::zeros()
        } else {
            rb.angular_velocity()
        };
        rb.set_motion(v, w, &self.nodes.x, &mut self.nodes.v);
        self.invalidate();
        Ok(())
    }

    /// Set the velocity of `nodes` to `v` [m/s] now (an initial condition before a run). A
    /// rigid body whose nodes are all in the set moves at `v` (no spin); a rigid body with
    /// only some of its nodes in the set is an error naming it.
    pub fn set_velocity(&mut self, nodes: &[u32], v: Vec3) -> Result<(), SimError> {
        let mut whole = Vec::new();
        for rb in &self.rigid.bodies {
            let mut seen = vec![false; rb.nodes.len()];
            for &n in nodes {
                if rb.nodes.contains(&(n as usize)) {
                    seen[n as usize - rb.nodes.start] = true;
                }
            }
            let count = seen.iter().filter(|&&s| s).count();
            if count == seen.len() {
                whole.push(rb.body);
            } else if count > 0 {
                return Err(SimError::Invalid(format!(
                    "body '{}' is rigid: a velocity for {count} of its {} nodes would deform it; give the whole body a velocity (body.set_velocity, body.set_spin)",
                    self.bodies[rb.body].name,
                    seen.len()
                )));
            }
        }
        for &i in nodes {
            self.nodes.v[i as usize] = v;
        }
        for b in whole {
            self.set_body_velocity(b, v);
        }
        Ok(())
    }

    /// Kinetic energy of the rigid bodies ½M|V|² + ½ω·L at the last half step [J].
    pub(super) fn rigid_kinetic_energy(&self) -> Real {
        self.rigid.kinetic_energy()
    }

    /// The body's layout is rigid.
    pub fn is_rigid(&self, body: usize) -> bool {
        self.bodies[body].layout == Layout::Rigid
    }
}
