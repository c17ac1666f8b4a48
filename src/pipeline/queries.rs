//! Read-only queries of a model's state: energies, means over node sets, reactions, stresses
//! of element sets, body volumes and masses, and filtered boundary faces. Each is what the
//! script query of the same name computes, callable from Rust. Node and element sets are
//! simulation ids (as `nodes_in`, `tets_in` return them).

use super::{Energy, Simulation};
use crate::elements;
use crate::material::StressMeasure;
use crate::math::{von_mises, Mat3, Real, Vec3};
use crate::mesh::{BoundaryFace, FaceFilter};

impl Simulation {
    /// Kinetic energy ½Σm|v|² from the current half-step velocities [J]; rigid bodies count
    /// as ½M|V|² + ½ω·L (their nodes are left out).
    pub fn kinetic_energy_now(&self) -> Real {
        let rigid = crate::state::Layout::Rigid;
        let nodes: Real = (0..self.nodes.len())
            .filter(|&n| self.bodies[self.nodes.body[n] as usize].layout != rigid)
            .map(|n| 0.5 * self.nodes.m[n] * self.nodes.v[n].norm_squared())
            .sum();
        nodes + self.rigid_kinetic_energy()
    }

    /// Strain energy of the current configuration [J].
    pub fn strain_energy_now(&self) -> Real {
        (0..self.tets.len())
            .map(|e| {
                let f = elements::deformation_gradient(&self.tets, &self.nodes.x, e);
                self.tets.vol0[e]
                    * self.materials[self.tets.material[e] as usize].energy_density(&f)
            })
            .sum()
    }

    /// Total mass of the model [kg] (valid after `prepare`).
    /// [`Energy::floor_of`] this model: ½·Σ E·V₀·(1e-7)² over its deformable tetrahedra and
    /// its bars (E·A·L₀) [J], summed in element order (the same bits for any thread count).
    pub fn energy_floor(&self) -> Real {
        let t = &self.tets;
        let tets: Real = (0..t.len())
            .filter(|&e| !t.rigid[e])
            .map(|e| self.materials[t.material[e] as usize].young * t.vol0[e])
            .sum();
        let b = &self.bars;
        let bars: Real = (0..b.len())
            .map(|i| self.steels[b.steel[i] as usize].young * b.area[i] * b.length0[i])
            .sum();
        Energy::floor_of(tets + bars)
    }

    pub fn total_mass(&self) -> Real {
        self.nodes.m.iter().sum()
    }

    /// Centroid of tet `e` at its current position [m].
    pub fn current_centroid(&self, e: usize) -> Vec3 {
        self.centroid_in(e, &self.nodes.x)
    }

    /// Centroid of tet `e` in the reference configuration [m].
    pub fn reference_centroid(&self, e: usize) -> Vec3 {
        self.centroid_in(e, &self.nodes.x0)
    }

    /// Centroid of tet `e` with its nodes at `places` [m].
    fn centroid_in(&self, e: usize, places: &[Vec3]) -> Vec3 {
        self.tets.nodes[e]
            .iter()
            .map(|&n| places[n as usize])
            .sum::<Vec3>()
            / 4.0
    }

    /// Mean displacement x − x₀ of `nodes` [m]; None for an empty set.
    pub fn mean_displacement(&self, nodes: &[u32]) -> Option<Vec3> {
        self.mean_of(nodes, |s, i| s.nodes.x[i] - s.nodes.x0[i])
    }

    /// Mean current position of `nodes` [m]; None for an empty set.
    pub fn mean_position(&self, nodes: &[u32]) -> Option<Vec3> {
        self.mean_of(nodes, |s, i| s.nodes.x[i])
    }

    /// Mean velocity of `nodes` at the last half step [m/s]; None for an empty set.
    pub fn mean_velocity(&self, nodes: &[u32]) -> Option<Vec3> {
        self.mean_of(nodes, |s, i| s.nodes.v[i])
    }

    /// Unweighted mean of a nodal vector over `nodes` (summed in the given order).
    fn mean_of(&self, nodes: &[u32], f: impl Fn(&Self, usize) -> Vec3) -> Option<Vec3> {
        if nodes.is_empty() {
            return None;
        }
        let sum: Vec3 = nodes.iter().map(|&i| f(self, i as usize)).sum();
        Some(sum / nodes.len() as Real)
    }

    /// Sum of the constraint forces (fixed and prescribed-velocity components) on `nodes` in
    /// the last step [N]; zero for an empty set.
    pub fn reaction_sum(&self, nodes: &[u32]) -> Vec3 {
        self.nodes.reaction_sum(nodes)
    }

    /// Cauchy stress of tet `e` at the current positions [Pa] (elastic part, as its
    /// material computes it).
    pub fn cauchy_stress(&self, e: usize) -> Mat3 {
        self.stress(e, StressMeasure::Cauchy)
    }

    /// Stress `measure` of tet `e` at the current positions [Pa]: its material's, from F; zero
    /// in a rigid body (it does not deform, and a law that is not objective, such as
    /// `elastic/small_strain`, would show its rotation as stress).
    pub fn stress(&self, e: usize, measure: StressMeasure) -> Mat3 {
        if self.bodies[self.tets.body[e] as usize].layout == crate::state::Layout::Rigid {
            return Mat3::zeros();
        }
        let f = elements::deformation_gradient(&self.tets, &self.nodes.x, e);
        self.materials[self.tets.material[e] as usize].stress(&f, measure)
    }

    /// Mean Cauchy stress of the tets `tets`, weighted by their reference volumes [Pa];
    /// None for an empty set.
    pub fn mean_stress(&self, tets: &[u32]) -> Option<Mat3> {
        if tets.is_empty() {
            return None;
        }
        let (mut sum, mut vol) = (Mat3::zeros(), 0.0);
        for &e in tets {
            let e = e as usize;
            sum += self.cauchy_stress(e) * self.tets.vol0[e];
            vol += self.tets.vol0[e];
        }
        Some(sum / vol)
    }

    /// Largest von Mises stress of the Cauchy stress over `tets` [Pa]; 0 for an empty set.
    pub fn max_von_mises(&self, tets: &[u32]) -> Real {
        tets.iter()
            .map(|&e| von_mises(&self.cauchy_stress(e as usize)))
            .fold(0.0, Real::max)
    }

    /// Reference volume of body `body` [m³].
    pub fn body_volume(&self, body: usize) -> Real {
        self.bodies[body]
            .tets
            .clone()
            .map(|e| self.tets.vol0[e])
            .sum::<Real>()
    }

    /// Mass of body `body`: reference volume × density [kg].
    pub fn body_mass(&self, body: usize) -> Real {
        let b = &self.bodies[body];
        self.body_volume(body) * self.materials[b.material as usize].density
    }

    /// The outer boundary faces of body `body` that pass `filter`, tested at the reference
    /// positions x₀, in the body's boundary order. Regions are tested with the model's
    /// [`Self::length_tolerance`].
    pub fn select_boundary(&self, body: usize, filter: &FaceFilter) -> Vec<BoundaryFace> {
        let x0 = &self.nodes.x0;
        let tol = self.length_tolerance();
        self.bodies[body]
            .boundary
            .iter()
            .filter(|f| filter.accepts(f, x0, tol))
            .copied()
            .collect()
    }
}
