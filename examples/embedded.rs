//! Using fdem as a library, without a script: a steel bar under gravity, clamped at one end,
//! damped to rest; the tip deflection is compared with beam theory.
//!
//! Run: `cargo run --release --example embedded`

use fdem::loads::{PrescribedVelocity, TimeFunction};
use fdem::material::{Formulation, Material};
use fdem::math::Vec3;
use fdem::mesh::{box_mesh, Region};
use fdem::{Layout, Simulation, Stage};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (l, b, h, e, rho, g) = (1.0_f64, 0.1, 0.1, 200e9, 7850.0, 9.81);
    let mut sim = Simulation::new();
    let steel = sim.add_material(Material::new(Formulation::Munjiza, rho, e, 0.0, 0.0)?);
    sim.add_body(
        "bar",
        &box_mesh(Vec3::zeros(), Vec3::new(l, b, h), [60, 2, 6]),
        steel,
        Layout::Continuous,
    )?;
    let clamp = sim.nodes_in(
        &Region::HalfSpace {
            point: Vec3::zeros(),
            normal: -Vec3::x(),
        },
        None,
    );
    sim.loads.prescribed.push(PrescribedVelocity {
        nodes: clamp,
        components: std::array::from_fn(|_| Some(TimeFunction::Constant(0.0))),
    });
    sim.loads.gravity = Vec3::new(0.0, 0.0, -g);
    // Critical damping of the first bending mode: ω₁ = 1.875²·√(EI/(ρAL⁴)).
    let omega1 = 1.875_f64.powi(2) * (e * b * h.powi(3) / 12.0 / (rho * b * h * l.powi(4))).sqrt();
    sim.settings.mass_damping = 2.0 * omega1;
    sim.prepare()?;
    println!("{}", sim.dt_info.as_ref().unwrap());
    while sim.time < 5.0 * std::f64::consts::TAU / omega1 {
        sim.step()?;
    }
    let tip = sim.nodes_in(
        &Region::HalfSpace {
            point: Vec3::new(l, 0.0, 0.0),
            normal: Vec3::x(),
        },
        None,
    );
    let w: f64 = tip
        .iter()
        .map(|&n| sim.nodes.x0[n as usize].z - sim.nodes.x[n as usize].z)
        .sum::<f64>()
        / tip.len() as f64;
    // Uniform load q = ρgA: w = qL⁴/(8EI).
    let exact = rho * g * b * h * l.powi(4) / (8.0 * e * b * h.powi(3) / 12.0);
    println!("tip deflection {:.4e} m, Euler–Bernoulli {:.4e} m (ratio {:.3}; 6 linear tets through the depth are stiff)", w, exact, w / exact);
    for s in Stage::ALL {
        println!("{:<16} {:.3} s", s.name(), sim.timers.get(s));
    }
    Ok(())
}
