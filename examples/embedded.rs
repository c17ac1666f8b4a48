//! Using fdem as a library, without a script: a steel bar under gravity, clamped at one end,
//! damped to rest; the tip deflection and the stress at the clamp are compared with beam
//! theory, using the edits and queries a script has (`Simulation::fix`, `mean_displacement`,
//! `max_von_mises`).
//!
//! Run: `cargo run --release --example embedded`

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
    // Clamp the end: fix x, y and z of its nodes, as `sim.fix(nodes)` does in a script.
    sim.fix(&clamp, [true; 3]);
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
    // The mean displacement of a node set [m], as `s.displacement(nodes)` gives it to a
    // script (None for an empty set). The deflection is its downward component.
    let w = -sim.mean_displacement(&tip).ok_or("no nodes at the tip")?.z;
    // The largest von Mises stress over the tets of the layer of cells at the clamp [Pa], as
    // `s.max_von_mises(elements)` gives it; beam theory: M/W = (qL²/2) / (bh²/6).
    let root = sim.tets_in(
        &Region::Box {
            min: Vec3::zeros(),
            max: Vec3::new(l / 60.0, b, h),
        },
        None,
    );
    let sigma = sim.max_von_mises(&root);
    let sigma_beam = rho * g * b * h * l * l / 2.0 / (b * h * h / 6.0);
    // Uniform load q = ρgA: w = qL⁴/(8EI).
    let exact = rho * g * b * h * l.powi(4) / (8.0 * e * b * h.powi(3) / 12.0);
    println!("tip deflection {:.4e} m, Euler–Bernoulli {:.4e} m (ratio {:.3}; 6 linear tets through the depth are stiff)", w, exact, w / exact);
    println!("largest von Mises stress in the clamped cells {sigma:.4e} Pa, beam theory M/W {sigma_beam:.4e} Pa");
    for s in Stage::ALL {
        println!("{:<16} {:.3} s", s.name(), sim.timers.get(s));
    }
    Ok(())
}
