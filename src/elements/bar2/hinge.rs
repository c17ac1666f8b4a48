//! Stage 1 for rebars, bending: a hinge at each node where two bars of a rebar meet resists
//! the change of the turning angle between them, so a bar crossing a sliding crack bends
//! (dowel action) instead of folding at a pin.
//!
//! At hinge b between bars a→b and b→c (e₁ = x_b − x_a, e₂ = x_c − x_b, uᵢ = eᵢ/lᵢ):
//!
//! ```text
//! cos θ = u₁·u₂,  sin θ = |u₁ × u₂|,  θ = atan2(sin θ, cos θ)     turning angle [rad]
//! M = k (θ − θ₀ − θ_p),  |M| ≤ M_p                              moment [N·m]
//! U = ½ M²/k,  k = E I / L̄,  I = π d⁴/64,  L̄ = ½(L₁ + L₂)       (discrete Euler–Bernoulli)
//! f_a = −(M/sin θ)(u₂ − cos θ u₁)/l₁,  f_c = (M/sin θ)(u₁ − cos θ u₂)/l₂,  f_b = −f_a − f_c
//! ```
//!
//! The forces are −∂U/∂x (θ depends only on the two chords, so rigid motions give none, and
//! they sum to zero with zero moment). With the bending energy ½ E I κ² L̄ of the curvature
//! κ = θ/L̄ over the node's tributary length, k = EI/L̄ makes a chain of hinges converge to
//! the Euler–Bernoulli beam as the bars shorten (tested against a cantilever, PL³/3EI).
//! Along a straight bar θ₀ = 0 and M/sin θ → k as θ → 0.
//!
//! Plasticity: elastic–perfectly plastic in M with the full plastic moment of a solid circle,
//! M_p = f_y d³/6 (the steel's f_y; no hardening, no rate factor): a trial moment beyond ±M_p
//! moves θ_p, and M_p|Δθ_p| is dissipated. θ is a scalar angle: a plastic kink remembers its
//! size, not its plane, which is exact for bending in one plane and approximate when the
//! plane of bending turns. A hinge whose bar has ruptured carries nothing; its elastic energy
//! is booked as dissipated.
//!
//! Guarantees: deterministic for any thread count (hinges in parallel into per-hinge forces,
//! added to the nodes in hinge order).

use crate::math::{Real, Vec3};
use crate::state::{BarHinges, Nodes};
use rayon::prelude::*;

/// Below this sin θ the bend has no defined plane (a straight bar): the force factor M/sin θ
/// takes its limit k for an unkinked hinge, and 0 for a kinked one straightened exactly.
const STRAIGHT: Real = 1e-12;

/// Turning angle θ between e₁ = b − a and e₂ = c − b, its sine, the unit chords and lengths.
#[inline(always)]
fn turning(a: &Vec3, b: &Vec3, c: &Vec3) -> (Real, Real, Vec3, Vec3, Real, Real) {
    let (e1, e2) = (b - a, c - b);
    let (l1, l2) = (e1.norm(), e2.norm());
    let (u1, u2) = (e1 / l1, e2 / l2);
    let cos = u1.dot(&u2).clamp(-1.0, 1.0);
    let sin = u1.cross(&u2).norm();
    (sin.atan2(cos), sin, u1, u2, l1, l2)
}

/// The turning angle θ [rad] at b of the polyline a, b, c.
pub fn turning_angle(a: &Vec3, b: &Vec3, c: &Vec3) -> Real {
    turning(a, b, c).0
}

/// Forces of the hinges on their nodes (advancing θ_p), added to `nodes.f`; returns the
/// elastic energy Σ ½M²/k [J] (0 unless `want_energy`). `ruptured_at` is the bars' time of
/// rupture (NaN while intact).
pub fn add_hinge_forces(
    nodes: &mut Nodes,
    hinges: &mut BarHinges,
    ruptured_at: &[Real],
    want_energy: bool,
) -> Real {
    if hinges.is_empty() {
        return 0.0;
    }
    let x = &nodes.x;
    hinges.force.resize(hinges.nodes.len(), [Vec3::zeros(); 3]);
    let reference = (
        &hinges.nodes,
        &hinges.bars,
        &hinges.stiffness,
        &hinges.plastic_moment,
        &hinges.angle0,
    );
    (
        hinges.force.par_iter_mut(),
        hinges.plastic_angle.par_iter_mut(),
        hinges.moment.par_iter_mut(),
        hinges.dissipated.par_iter_mut(),
    )
        .into_par_iter()
        .enumerate()
        .for_each(|(h, (f, theta_p, moment, diss))| {
            let k = reference.2[h];
            let [b1, b2] = reference.1[h];
            if !ruptured_at[b1 as usize].is_nan() || !ruptured_at[b2 as usize].is_nan() {
                *diss += 0.5 * *moment * *moment / k;
                *moment = 0.0;
                *f = [Vec3::zeros(); 3];
                return;
            }
            let [a, b, c] = reference.0[h].map(|n| x[n as usize]);
            let (theta, sin, u1, u2, l1, l2) = turning(&a, &b, &c);
            let (mp, theta0) = (reference.3[h], reference.4[h]);
            let mut m = k * (theta - theta0 - *theta_p);
            if m.abs() > mp {
                let step = (m.abs() - mp) / k * m.signum();
                *theta_p += step;
                *diss += mp * step.abs();
                m = mp * m.signum();
            }
            *moment = m;
            let factor = if sin > STRAIGHT {
                m / sin
            } else if theta0 + *theta_p == 0.0 {
                k
            } else {
                0.0
            };
            let cos = u1.dot(&u2);
            let fa = -(u2 - u1 * cos) * (factor / l1);
            let fc = (u1 - u2 * cos) * (factor / l2);
            *f = [fa, -fa - fc, fc];
        });
    for (h, n) in hinges.nodes.iter().enumerate() {
        for (i, &node) in n.iter().enumerate() {
            nodes.f[node as usize] += hinges.force[h][i];
        }
    }
    if want_energy {
        (0..hinges.len())
            .map(|h| 0.5 * hinges.moment[h] * hinges.moment[h] / hinges.stiffness[h])
            .sum()
    } else {
        0.0
    }
}

/// An upper bound of ω² [1/s²] the hinges add to the lumped system, for the time step.
/// A hinge's stiffness is rank one in each bending plane, k·g gᵀ with |g| = (1/L₁, 1/L₁ + 1/L₂,
/// 1/L₂) over its nodes, so it adds ω² = k Σ g²/m; a node belongs to at most three hinges of
/// a rebar, which split into three sets of disjoint hinges, hence ω² ≤ 3 max over hinges.
pub fn max_omega2(hinges: &BarHinges, length0: &[Real], mass: &[Real]) -> Real {
    (0..hinges.len())
        .map(|h| {
            let [b1, b2] = hinges.bars[h].map(|b| length0[b as usize]);
            let g = [1.0 / b1, 1.0 / b1 + 1.0 / b2, 1.0 / b2];
            let m = hinges.nodes[h].map(|n| mass[n as usize]);
            3.0 * hinges.stiffness[h] * (0..3).map(|i| g[i] * g[i] / m[i]).sum::<Real>()
        })
        .fold(0.0, Real::max)
}

#[cfg(test)]
// Index loops over a hinge's three nodes and the chain's nodes mirror the equations.
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;

    fn hinge_at(points: [Vec3; 3], k: Real, mp: Real) -> (Nodes, BarHinges, Vec<Real>) {
        let mut nodes = Nodes::default();
        for p in points {
            nodes.push(p, 0);
        }
        let mut h = BarHinges::default();
        h.push(
            [0, 1, 2],
            [0, 1],
            k,
            mp,
            turning_angle(&points[0], &points[1], &points[2]),
        );
        (nodes, h, vec![Real::NAN; 2])
    }

    fn energy_at(points: [Vec3; 3], x: &[Vec3], k: Real) -> Real {
        let (mut nodes, mut h, r) = hinge_at(points, k, Real::INFINITY);
        nodes.x.copy_from_slice(x);
        add_hinge_forces(&mut nodes, &mut h, &r, true)
    }

    /// The forces are −∂U/∂x: central differences of the energy (step 1e-7 of a 1 m bar; the
    /// difference error is O(h²) ≈ 1e-12 relative, so 1e-6 of the largest force is safe),
    /// for a straight and for a bent (stirrup-corner) reference, each bent further.
    #[test]
    fn forces_are_the_energy_gradient() {
        let k = 3.0;
        for refs in [
            [
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(2.0, 0.0, 0.0),
            ],
            [
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(1.0, 0.8, 0.0),
            ],
        ] {
            let bent = [
                refs[0],
                refs[1] + Vec3::new(0.05, 0.2, -0.1),
                refs[2] + Vec3::new(-0.1, 0.1, 0.3),
            ];
            let (mut nodes, mut h, r) = hinge_at(refs, k, Real::INFINITY);
            nodes.x.copy_from_slice(&bent);
            add_hinge_forces(&mut nodes, &mut h, &r, false);
            let fmax = nodes.f.iter().map(|f| f.norm()).fold(0.0, Real::max);
            assert!(fmax > 0.1);
            let d = 1e-7;
            for n in 0..3 {
                for c in 0..3 {
                    let (mut p, mut q) = (bent, bent);
                    p[n][c] += d;
                    q[n][c] -= d;
                    let grad = (energy_at(refs, &p, k) - energy_at(refs, &q, k)) / (2.0 * d);
                    assert!(
                        (nodes.f[n][c] + grad).abs() < 1e-6 * fmax,
                        "node {n} comp {c}: f {} vs −dU/dx {}",
                        nodes.f[n][c],
                        -grad
                    );
                }
            }
            // Action and reaction, and no moment about the origin.
            let sum: Vec3 = nodes.f.iter().sum();
            let moment: Vec3 = (0..3).map(|n| bent[n].cross(&nodes.f[n])).sum();
            assert!(sum.norm() < 1e-12 * fmax && moment.norm() < 1e-12 * fmax);
        }
    }

    /// A bent hinge rotated rigidly by large angles about two axes keeps its moment and
    /// carries no force when its reference shape is restored (exact to round-off).
    #[test]
    fn rigid_rotation_gives_no_moment() {
        let refs = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.3, 0.0, 0.0),
            Vec3::new(0.3, 0.3, 0.1),
        ];
        let r = nalgebra::Rotation3::from_euler_angles(1.1, -0.7, 2.3);
        let (mut nodes, mut h, rup) = hinge_at(refs, 1e4, 50.0);
        for n in 0..3 {
            nodes.x[n] = r * refs[n] + Vec3::new(5.0, -2.0, 1.0);
        }
        add_hinge_forces(&mut nodes, &mut h, &rup, false);
        assert!(h.moment[0].abs() < 1e-9, "{}", h.moment[0]);
        assert!(nodes.f.iter().all(|f| f.norm() < 1e-8));
    }

    /// Past M_p the moment stays at M_p and the plastic work is M_p·Δθ_p; unloading is
    /// elastic (slope k) and leaves the plastic angle.
    #[test]
    fn the_moment_is_bounded_by_the_plastic_moment() {
        let (k, mp) = (100.0, 2.0);
        let refs = [
            Vec3::new(-1.0, 0.0, 0.0),
            Vec3::zeros(),
            Vec3::new(1.0, 0.0, 0.0),
        ];
        let (mut nodes, mut h, r) = hinge_at(refs, k, mp);
        let bend = |theta: Real, nodes: &mut Nodes, h: &mut BarHinges| {
            nodes.x[2] = Vec3::new(theta.cos(), theta.sin(), 0.0);
            nodes.f.iter_mut().for_each(|f| *f = Vec3::zeros());
            add_hinge_forces(nodes, h, &r, true)
        };
        bend(0.01, &mut nodes, &mut h);
        assert!((h.moment[0] - 1.0).abs() < 1e-12);
        bend(0.05, &mut nodes, &mut h);
        assert!((h.moment[0] - mp).abs() < 1e-12);
        assert!((h.plastic_angle[0] - (0.05 - mp / k)).abs() < 1e-12);
        assert!((h.dissipated[0] - mp * (0.05 - mp / k)).abs() < 1e-12);
        // Unload by 0.01 rad: M drops by k·0.01, θ_p stays.
        let e = bend(0.04, &mut nodes, &mut h);
        assert!((h.moment[0] - (mp - k * 0.01)).abs() < 1e-9);
        assert!((e - 0.5 * 1.0 * 1.0 / k).abs() < 1e-9);
    }

    /// A cantilever of n bars (length L, tip load P normal to it, fixed by its first two
    /// nodes) deflects PL³/3EI as the bars shorten: the hinge chain is the discrete
    /// Euler–Bernoulli beam. Static solution by damped dynamic relaxation; small load
    /// (δ/L ≈ 1e-4) so the geometry stays linear. The clamp's hinge has the tributary length
    /// h/2 of a bar end (k = 2EI/h), the others h. By the discrete moment–area sum the
    /// chain's tip deflection is PL³/3EI·(1 + 1/(2n²)) (0.125 % at n = 20); tolerance 0.5 %.
    #[test]
    fn a_cantilever_of_hinges_deflects_pl3_over_3ei() {
        let (len, ei, p, n) = (1.0, 50.0, 0.015, 20usize);
        let h = len / n as Real;
        let mut nodes = Nodes::default();
        // A node behind the clamp: the clamp is the hinge at x = 0 between fixed nodes −h, 0.
        for i in 0..=n + 1 {
            nodes.push(Vec3::new((i as Real - 1.0) * h, 0.0, 0.0), 0);
        }
        let mut hinges = BarHinges::default();
        for i in 1..=n {
            let k = if i == 1 { 2.0 * ei / h } else { ei / h };
            hinges.push(
                [i as u32 - 1, i as u32, i as u32 + 1],
                [i as u32 - 1, i as u32],
                k,
                Real::INFINITY,
                0.0,
            );
        }
        let rup = vec![Real::NAN; n + 1];
        let mass = 1.0;
        let w2 = max_omega2(&hinges, &vec![h; n + 1], &vec![mass; n + 2]);
        let dt = 1.0 / w2.sqrt();
        let omega1 = 3.516 * (ei / (mass / h)).sqrt() / (len * len);
        let damping = 2.0 * omega1;
        let mut v = vec![Vec3::zeros(); n + 2];
        for _ in 0..40_000 {
            nodes.f.iter_mut().for_each(|f| *f = Vec3::zeros());
            add_hinge_forces(&mut nodes, &mut hinges, &rup, false);
            nodes.f[n + 1].y += p;
            for i in 2..n + 2 {
                v[i] = (v[i] * (1.0 - 0.5 * damping * dt) + nodes.f[i] * (dt / mass))
                    / (1.0 + 0.5 * damping * dt);
                v[i].x = 0.0; // inextensible: the bars' axial stiffness is not modelled here
                nodes.x[i] += v[i] * dt;
            }
        }
        let tip = nodes.x[n + 1].y;
        let exact = p * len.powi(3) / (3.0 * ei);
        assert!(
            (tip / exact - 1.0).abs() < 0.005,
            "tip {tip} against PL³/3EI {exact}"
        );
    }
}
