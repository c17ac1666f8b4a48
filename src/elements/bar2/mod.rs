//! The bar2 element family (2-node bar, axial force only): reinforcing bars. Everything fdem
//! needs of it: the stage 1 force kernel, the lumped mass and the critical time step; its
//! steel is [`steel`].
//!
//! Kernel, for a bar from node i to node j with reference length L₀ and section A₀:
//!
//! ```text
//! d = x_j − x_i,  l = |d|,  e = d/l          (current axis: large rotations are exact)
//! ε = l/L₀ − 1,   ε̇ = e·(v_j − v_i)/L₀        (engineering strain of the chord and its rate)
//! σ = steel(ε, ε̇, history),  N = σ A₀
//! f_i = +N e,  f_j = −N e                      (tension pulls the nodes together)
//! ```
//!
//! The force is −∂U/∂x of U = A₀L₀·ψ(ε) for the elastic part, so a rigid motion gives none
//! and free vibration conserves energy. Lumped mass ρA₀L₀/2 at each node; the critical step
//! of the central difference for a lumped 2-node bar is L₀/c, c = √(E/ρ) (ω_max = 2c/L₀).
//! The bar ruptures at the steel's ε_u: it carries nothing from then on, and the elastic
//! energy it held is booked as dissipated.
//!
//! Guarantees: deterministic for any thread count (bars in parallel into a per-bar force,
//! then added to the nodes in bar order).

pub mod hinge;
pub mod steel;

use crate::math::{Real, Vec3};
use crate::state::{Bars, Nodes};
use rayon::prelude::*;
use steel::{Steel, SteelState};

/// Sums over the bars of one step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BarSums {
    /// Elastic energy Σ A₀L₀·½σ²/E [J] (only when energies are requested).
    pub strain_energy: Real,
    /// Bars that ruptured in this step.
    pub ruptured: usize,
}

/// Add the bars' lumped masses ρA₀L₀/2 to their nodes [kg].
pub fn lumped_masses(nodes: &mut Nodes, bars: &Bars, steels: &[Steel]) {
    for b in 0..bars.len() {
        let m = steels[bars.steel[b] as usize].density * bars.area[b] * bars.length0[b] / 2.0;
        for &n in &bars.nodes[b] {
            nodes.m[n as usize] += m;
        }
    }
}

/// The smallest critical step over the bars [s] and the bar that sets it (the lowest id among
/// equals); (∞, 0) without bars. Axially L₀/√(E/ρ); the bending hinges lower it by their
/// ω² bound ([`hinge::max_omega2`], with the nodes' lumped masses `mass`):
/// 2/√((2/Δt_axial)² + ω²_hinges).
pub fn critical_time_step(bars: &Bars, steels: &[Steel], mass: &[Real]) -> (Real, usize) {
    let (axial, bar) = (0..bars.len())
        .map(|b| {
            let s = &steels[bars.steel[b] as usize];
            (bars.length0[b] * (s.density / s.young).sqrt(), b)
        })
        .fold((Real::INFINITY, 0), |a, c| if c.0 < a.0 { c } else { a });
    let w2 = hinge::max_omega2(&bars.hinges, &bars.length0, mass);
    if w2 > 0.0 && w2.is_finite() {
        let w = 2.0 / axial;
        (2.0 / (w * w + w2).sqrt(), bar)
    } else {
        (axial, bar)
    }
}

/// Stage 1 for bars: axial forces from the steel law (advancing its history), added to
/// `nodes.f`. `force` is the stage's scratch (one vector per bar, sized here once).
pub fn add_bar_forces(
    nodes: &mut Nodes,
    bars: &mut Bars,
    steels: &[Steel],
    force: &mut Vec<Vec3>,
    time: Real,
    want_energy: bool,
) -> BarSums {
    if bars.is_empty() {
        return BarSums::default();
    }
    force.resize(bars.len(), Vec3::zeros());
    let (x, v) = (&nodes.x, &nodes.v);
    let reference = (&bars.nodes, &bars.length0, &bars.area, &bars.steel);
    let ruptured: usize = (
        force.par_iter_mut(),
        bars.plastic_strain.par_iter_mut(),
        bars.history.par_iter_mut(),
        bars.strain.par_iter_mut(),
        bars.stress.par_iter_mut(),
        bars.dissipated.par_iter_mut(),
        bars.ruptured_at.par_iter_mut(),
    )
        .into_par_iter()
        .enumerate()
        .map(|(b, (f, ep, hist, eps, sig, diss, rupt))| {
            let [i, j] = reference.0[b].map(|n| n as usize);
            let (l0, area) = (reference.1[b], reference.2[b]);
            let steel = &steels[reference.3[b] as usize];
            let d = x[j] - x[i];
            let l = d.norm();
            let e = d / l;
            *eps = l / l0 - 1.0;
            if !rupt.is_nan() {
                *f = Vec3::zeros();
                *sig = 0.0;
                return 0;
            }
            let rate = e.dot(&(v[j] - v[i])) / l0;
            let mut st = SteelState {
                plastic_strain: *ep,
                history: *hist,
            };
            let (sigma, work) = steel.stress(*eps, rate, &mut st);
            (*ep, *hist) = (st.plastic_strain, st.history);
            *diss += work * area * l0;
            if *eps >= steel.rupture_strain {
                *diss += steel.elastic_energy_density(sigma) * area * l0;
                *rupt = time;
                *f = Vec3::zeros();
                *sig = 0.0;
                return 1;
            }
            *sig = sigma;
            *f = e * (sigma * area);
            0
        })
        .sum();
    for (b, nb) in bars.nodes.iter().enumerate() {
        nodes.f[nb[0] as usize] += force[b];
        nodes.f[nb[1] as usize] -= force[b];
    }
    let bending_energy =
        hinge::add_hinge_forces(nodes, &mut bars.hinges, &bars.ruptured_at, want_energy);
    let strain_energy = bending_energy
        + if want_energy {
            (0..bars.len())
                .map(|b| {
                    let s = &steels[bars.steel[b] as usize];
                    s.elastic_energy_density(bars.stress[b]) * bars.area[b] * bars.length0[b]
                })
                .sum()
        } else {
            0.0
        };
    BarSums {
        strain_energy,
        ruptured,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bar rotated rigidly by a large angle carries no force: the chord strain is
    /// rotation-free (exact to round-off).
    #[test]
    fn rigid_rotation_gives_no_force() {
        let mut nodes = Nodes::default();
        nodes.push(Vec3::new(0.0, 0.0, 0.0), 0);
        nodes.push(Vec3::new(0.3, 0.0, 0.0), 0);
        let mut bars = Bars::default();
        bars.push([0, 1], 0.3, 1e-4, 0, 0);
        let steel = Steel {
            density: 7850.0,
            young: 200e9,
            yield_stress: 400e6,
            hardening: 0.0,
            rupture_strain: Real::INFINITY,
            rate: None,
            law: steel::SteelLaw::Bilinear,
        };
        let a: Real = 1.1;
        nodes.x[1] = Vec3::new(0.3 * a.cos(), 0.3 * a.sin(), 0.0);
        let mut scratch = Vec::new();
        add_bar_forces(&mut nodes, &mut bars, &[steel], &mut scratch, 0.0, true);
        assert!(nodes.f[0].norm() < 1e-6 && nodes.f[1].norm() < 1e-6);
        assert!(bars.strain[0].abs() < 1e-15);
    }
}
