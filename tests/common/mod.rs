//! Helpers shared by the physics tests.
#![allow(dead_code)]

use fdem::material::{Formulation, Material};
use fdem::math::{Real, Vec3};
use fdem::mesh::{box_mesh, Region};
use fdem::pipeline::{Layout, Simulation};

/// A simulation holding one box body meshed with `div` cells.
pub fn box_sim(min: Vec3, max: Vec3, div: [usize; 3], mat: Material, layout: Layout) -> Simulation {
    let mut sim = Simulation::new();
    let m = sim.add_material(mat);
    sim.add_body("box", &box_mesh(min, max, div), m, layout)
        .unwrap();
    sim
}

pub fn material(f: Formulation, rho: Real, e: Real, nu: Real) -> Material {
    Material::new(f, rho, e, nu, 0.0).unwrap()
}

/// Nodes on the plane x = value (within 1e-9).
pub fn plane_x(sim: &Simulation, value: Real, outward: Real) -> Vec<u32> {
    sim.nodes_in(
        &Region::HalfSpace {
            point: Vec3::new(value, 0.0, 0.0),
            normal: Vec3::new(outward, 0.0, 0.0),
        },
        None,
    )
}
