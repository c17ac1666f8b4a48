//! Domes under self-weight (issue 11), against the membrane theory of shells and the crack
//! pattern of masonry domes.
//!
//! 1. A thin continuous hemispherical shell: the meridional and hoop stress resultants follow
//!    the membrane solution (Timoshenko & Woinowsky-Krieger, *Theory of Plates and Shells*,
//!    2nd ed. 1959, §(spherical dome under its own weight)), and the hoop force changes sign
//!    where the theory says.
//! 2. A masonry dome of voussoir blocks and weak mortar: the hoop tension of the lower part
//!    opens meridional cracks (Heyman, *The Stone Skeleton*, 1995, on domes; the four great
//!    fissures of Brunelleschi's dome), the upper part stays whole, and the cracked dome stands.

use fdem::material::{Formulation, Material};
use fdem::math::{Mat3, Real, Vec3};
use fdem::mesh::masonry::{self, Dome};
use fdem::mesh::Mesh;
use fdem::pipeline::Energy;
use fdem::{Layout, Simulation};
use std::collections::HashMap;
use std::f64::consts::{FRAC_PI_2, PI};
use std::time::Instant;

const G: Real = 9.81;

// ─── Membrane theory ─────────────────────────────────────────────────────────────

/// Membrane resultants (N_φ, N_θ)/(wR) of a spherical dome with an oculus of half-angle φ₀
/// (no lantern) under its own weight w per unit mid-surface area, at polar angle φ
/// (Timoshenko & Woinowsky-Krieger §(dome under own weight)): N_φ = −wR (cos φ₀ − cos φ)/sin²φ
/// from the vertical equilibrium of the cap above φ, N_θ = −wR cos φ − N_φ from the normal
/// one. φ₀ = 0: N_φ = −wR/(1 + cos φ), N_θ = wR (1/(1 + cos φ) − cos φ).
fn membrane(phi0: Real, phi: Real) -> (Real, Real) {
    let n_phi = -(phi0.cos() - phi.cos()) / phi.sin().powi(2);
    (n_phi, -phi.cos() - n_phi)
}

/// Polar angle where the membrane hoop force changes sign, cos φ (2 − cos²φ) = cos φ₀
/// (51.83° for a closed crown), by bisection.
fn hoop_transition(phi0: Real) -> Real {
    let (mut lo, mut hi) = (phi0.max(1e-6), FRAC_PI_2);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if membrane(phi0, mid).1 < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Polar angle φ of `p` and the unit vectors e_φ (meridional, towards the base) and e_θ
/// (hoop, towards larger longitude) there.
fn frame(p: &Vec3) -> (Real, Vec3, Vec3) {
    let phi = (p.z / p.norm()).clamp(-1.0, 1.0).acos();
    let lon = p.y.atan2(p.x);
    let e_phi = Vec3::new(phi.cos() * lon.cos(), phi.cos() * lon.sin(), -phi.sin());
    let e_theta = Vec3::new(-lon.sin(), lon.cos(), 0.0);
    (phi, e_phi, e_theta)
}

/// Mass damping over the critical damping 2ω of the mode that the settled deflection u is,
/// ω² from its Rayleigh quotient uᵀKu / uᵀMu = Σ m g·u / Σ m |u|² (Ku = f = m g at rest).
fn damping_ratio(sim: &Simulation) -> Real {
    let n = &sim.nodes;
    let (gu, uu) = (0..n.len()).fold((0.0, 0.0), |(gu, uu), i| {
        let u = n.x[i] - n.x0[i];
        (
            gu + n.m[i] * u.dot(&sim.loads.gravity),
            uu + n.m[i] * u.norm_squared(),
        )
    });
    sim.settings.mass_damping / (2.0 * (gu / uu).sqrt())
}

// ─── 1. Continuous shell ─────────────────────────────────────────────────────────

/// The blocks of `dome` merged into one shared-node mesh, keeping the tetrahedra whose
/// centroid lies in the quadrant x > 0, y > 0. Neighbouring blocks share their face nodes
/// exactly (same formulas, bit for bit), so nodes are merged by their coordinates (on a
/// 1e-9 R grid); the quadrant's planes x = 0 and y = 0 are grid lines of the generator's
/// longitude grid when the dome has 4 blocks per course.
fn quarter_shell(d: &Dome, h: Real) -> Mesh {
    let a = masonry::dome(d, h).unwrap();
    let q = 1e-9 * d.radius;
    let key = |p: &Vec3| [p.x, p.y, p.z].map(|c| (c / q).round() as i64);
    let mut ids: HashMap<[i64; 3], u32> = HashMap::new();
    let (mut nodes, mut tets) = (Vec::new(), Vec::new());
    for b in &a.blocks {
        for (e, t) in b.mesh.tets.iter().enumerate() {
            let c = b.mesh.tet_centroid(e);
            if c.x <= 0.0 || c.y <= 0.0 {
                continue;
            }
            tets.push(t.map(|n| {
                let p = b.mesh.nodes[n as usize];
                *ids.entry(key(&p)).or_insert_with(|| {
                    nodes.push(p);
                    (nodes.len() - 1) as u32
                })
            }));
        }
    }
    Mesh::new(nodes, tets)
}

/// A quarter hemispherical shell settled under its own weight.
struct Shell {
    sim: Simulation,
    /// Mid-surface radius R and thickness t [m].
    rm: Real,
    t: Real,
    /// Oculus half-angle φ₀ [rad].
    phi0: Real,
    /// Weight per unit mid-surface area of the meshed shell [N/m²].
    w: Real,
    /// |Σ R_z / W − 1|, kinetic / strain energy, relative energy balance error at the end.
    reaction_error: Real,
    kinetic_ratio: Real,
    balance: Real,
    /// Damping / critical damping of the mode the static deflection is (Rayleigh quotient).
    damping_ratio: Real,
    seconds: Real,
}

impl Shell {
    /// Mid-surface radius 1 m, thickness `t`, oculus `oculus` degrees, meshed at `h` (two
    /// layers of tets through the thickness for h ∈ (0.4t, 0.67t)), linear elastic
    /// (small strain; the membrane state is statically determinate, so E and ν do not enter).
    ///
    /// Supports: the base (φ = 90°) rests on rollers along the mid-surface circle (z fixed):
    /// the membrane force there is vertical (the meridian is), so the rollers carry it and
    /// leave the radial displacement and the rotation of the base free, as the membrane
    /// state needs them: no bending boundary layer is forced. The
    /// symmetry planes x = 0 and y = 0 hold the normal component. Gravity is switched on at
    /// once and brought to rest by mass-proportional damping α = 1.6 c/R, critical (α = 2ω)
    /// for the mode that carries the deflection (ω ≈ 0.80 c/R, measured from the undamped
    /// response; the Rayleigh quotient of the settled deflection puts α at 0.97–0.98 of
    /// critical), over 20 R/c ≈ 16/ω.
    fn settle(t: Real, oculus: Real, h: Real) -> Shell {
        let start = Instant::now();
        let rm = 1.0;
        let d = Dome {
            radius: rm - 0.5 * t,
            thickness: t,
            courses: 8,
            blocks_per_course: 4,
            oculus,
            base: 90.0,
        };
        let mesh = quarter_shell(&d, h);
        let (rho, e, nu) = (2400.0, 10e9, 0.2);
        let mut sim = Simulation::new();
        let m = sim.add_material(Material::new(Formulation::SmallStrain, rho, e, nu, 0.0).unwrap());
        sim.add_body("shell", &mesh, m, Layout::Continuous).unwrap();
        let tol = 1e-7 * rm;
        let x0 = sim.nodes.x0.clone();
        let pick = |f: &dyn Fn(&Vec3) -> bool| {
            (0..x0.len() as u32)
                .filter(|&i| f(&x0[i as usize]))
                .collect::<Vec<u32>>()
        };
        let base = pick(&|p| p.z.abs() < tol && (p.norm() - rm).abs() < tol);
        let (on_x0, on_y0) = (pick(&|p| p.x.abs() < tol), pick(&|p| p.y.abs() < tol));
        assert!(
            base.len() > 10,
            "no mid-surface nodes on the base: {}",
            base.len()
        );
        sim.fix(&base, [false, false, true]);
        sim.fix(&on_x0, [true, false, false]);
        sim.fix(&on_y0, [false, true, false]);
        sim.loads.gravity = Vec3::new(0.0, 0.0, -G);
        let c = (e / rho).sqrt();
        sim.settings.mass_damping = 1.6 * c / rm;
        sim.prepare().unwrap();
        let weight = sim.total_mass() * G;
        let phi0 = oculus.to_radians();
        let w = weight / (0.5 * PI * rm * rm * phi0.cos()); // quarter of 2πR² cos φ₀
        while sim.time < 20.0 * rm / c {
            sim.step().unwrap();
        }
        let strain = sim.strain_energy_now();
        println!(
            "shell R/t = {:.0}, oculus {oculus}°, h = {:.3}t: {} nodes, {} tets, {} base nodes, {} steps; {}",
            rm / t,
            h / t,
            mesh.nodes.len(),
            mesh.tets.len(),
            base.len(),
            sim.step,
            sim.dt_info.as_ref().unwrap()
        );
        Shell {
            rm,
            t,
            phi0,
            w,
            reaction_error: (sim.reaction_sum(&base).z / weight - 1.0).abs(),
            kinetic_ratio: sim.kinetic_energy_now() / strain,
            balance: sim.energy.relative_balance_error(),
            damping_ratio: damping_ratio(&sim),
            seconds: start.elapsed().as_secs_f64(),
            sim,
        }
    }

    /// Band means over the tets whose centroid lies at polar angles in [lo, hi) of the
    /// measured (N_φ, N_θ) and of the membrane theory for an oculus `phi0`, both divided by wR.
    ///
    /// N = ∫ σ (r/R) dr through the thickness is the force per unit length of a mid-surface
    /// line (a line at radius r is r/R times longer). Over a band, Σ_e σ_e V_e R/r_e = A·⟨N⟩
    /// and Σ_e V_e R/r_e = A·t (A the band's mid-surface area), so ⟨N⟩ = t·Σ σ_e V_e R/r_e /
    /// Σ V_e R/r_e with σ_e the tet's Cauchy stress resolved on e_φ, e_θ at its centroid.
    /// The theory is averaged with the same weights at the same centroids, so the width of
    /// the band does not bias the comparison. With these definitions and w the meshed weight
    /// per unit mid-surface area, N_φ is exact by the vertical equilibrium of the cap and
    /// N_φ + N_θ = −wR cos φ by the radial equilibrium through the thickness (the traction-free
    /// faces drop out), for any thickness, as long as transverse shear is negligible.
    fn band(&self, lo: Real, hi: Real, phi0: Real) -> ([Real; 2], [Real; 2]) {
        let s = &self.sim;
        let (mut m, mut th, mut wsum) = ([0.0; 2], [0.0; 2], 0.0);
        for e in 0..s.tets.len() {
            let c = s.reference_centroid(e);
            let (phi, ep, et) = frame(&c);
            if phi < lo || phi >= hi {
                continue;
            }
            let sigma = s.cauchy_stress(e);
            let wt = s.tets.vol0[e] * self.rm / c.norm();
            m[0] += ep.dot(&(sigma * ep)) * wt;
            m[1] += et.dot(&(sigma * et)) * wt;
            let (a, b) = membrane(phi0, phi);
            th[0] += a * wt;
            th[1] += b * wt;
            wsum += wt;
        }
        assert!(wsum > 0.0, "no tets in the band [{lo}, {hi})");
        let k = self.t / (wsum * self.w * self.rm);
        (m.map(|x| x * k), th.map(|x| x / wsum))
    }

    /// Measured (N_φ, N_θ)/(wR) in the band φ ± 1.5° against the membrane theory averaged
    /// over the same band (for the oculus φ₀, or for a closed crown when `closed`); the
    /// relative errors, printed.
    fn check_at(&self, deg: Real, closed: bool) -> [Real; 2] {
        let (lo, hi) = ((deg - 1.5).to_radians(), (deg + 1.5).to_radians());
        let (m, th) = self.band(lo, hi, if closed { 0.0 } else { self.phi0 });
        let err = [m[0] / th[0] - 1.0, m[1] / th[1] - 1.0];
        let from_base = (FRAC_PI_2 - deg.to_radians()) * self.rm / (self.rm * self.t).sqrt();
        println!(
            "  φ = {deg}° ({from_base:.1} √(Rt) from the base): N_φ/wR = {:.5} (theory {:.5}, {:+.2} %), N_θ/wR = {:.5} (theory {:.5}, {:+.2} %)",
            m[0], th[0], 100.0 * err[0], m[1], th[1], 100.0 * err[1]
        );
        err
    }

    /// Polar angles [degrees] where the hoop force changes sign, measured and in theory: the
    /// root of a weighted least-squares parabola N_θ(φ) through the tets whose centroid lies
    /// within ±6° of `guess` (each tet a sample t·σ_θθ with the weight V R/r of
    /// [`Self::band`]), fitted to the measured stresses and to the theory at the same
    /// centroids. The fit averages the element-to-element scatter of constant-strain tets
    /// that a root between two narrow bands would pick up; applied to the theory it returns
    /// the exact root to 0.01°.
    fn transition(&self, guess: Real) -> (Real, Real) {
        let s = &self.sim;
        let (lo, hi) = ((guess - 6.0).to_radians(), (guess + 6.0).to_radians());
        let (mut m, mut rhs, mut rhs_th) = (Mat3::zeros(), Vec3::zeros(), Vec3::zeros());
        for e in 0..s.tets.len() {
            let c = s.reference_centroid(e);
            let (phi, _, et) = frame(&c);
            if phi < lo || phi >= hi {
                continue;
            }
            let wt = s.tets.vol0[e] * self.rm / c.norm();
            let x = phi.to_degrees() - guess;
            let basis = Vec3::new(1.0, x, x * x);
            let y = self.t * et.dot(&(s.cauchy_stress(e) * et)) / (self.w * self.rm);
            m += basis * basis.transpose() * wt;
            rhs += basis * (y * wt);
            rhs_th += basis * (membrane(self.phi0, phi).1 * wt);
        }
        let inv = m.try_inverse().expect("tets on both sides of the guess");
        let root = |rhs: Vec3| {
            let [a, b, c] = [0, 1, 2].map(|k| (inv * rhs)[k]);
            // The root of a + b x + c x² nearest to x = 0 (b ≠ 0: N_θ rises through zero).
            let x = -2.0 * a / (b + (b * b - 4.0 * a * c).max(0.0).sqrt().copysign(b));
            guess + x
        };
        (root(rhs), root(rhs_th))
    }
}

/// A thin continuous hemispherical shell (R/t = 25, R the mid-surface radius) under its own
/// weight against the membrane theory (Timoshenko & Woinowsky-Krieger, *Theory of Plates and
/// Shells*, §(spherical dome under its own weight); the formulas at [`membrane`]).
///
/// Model: the blocks of `masonry::dome` (8 courses × 4 blocks) merged into one continuous
/// body ([`quarter_shell`]), a quarter of the dome by symmetry (the planes x = 0 and y = 0
/// held normal to themselves), two layers of tets through the thickness, base on mid-surface
/// rollers, which carry the vertical membrane force and leave the base free to expand and
/// rotate, so no bending boundary layer is forced ([`Shell::settle`]). N_φ and N_θ are band
/// means of the tets' Cauchy stresses integrated through the thickness ([`Shell::band`]) at
/// φ = 30° and 45°, 5.2 and 3.9 √(Rt) from the base (within 1–1.5 % of the theory even at
/// 88°, 0.2 √(Rt) from it); the hoop force's change of sign is the root of a parabola fitted
/// to the tets' hoop resultants ([`Shell::transition`]).
///
/// Runs: (a) oculus φ₀ = 10° against the oculus formulas (h = 0.6t, 16 128 tets); (b) φ₀ = 2°
/// against the closed-crown formulas N_φ = −wR/(1 + cos φ), N_θ = wR(1/(1 + cos φ) − cos φ)
/// and the transition at 51.83° (the 2° oculus moves them by < 0.5 % (N_φ), < 0.8 % (N_θ)
/// and +0.05°; the generator sizes the longitude cells for the oculus, so this mesh is
/// coarser at the base: h = 0.41t, 12 312 tets).
///
/// Measured (this commit): (a) N_φ +0.01 % / −0.13 % at 30° / 45°, N_θ −1.37 % / −1.91 %,
/// transition 52.91° vs 53.07°; (b) N_φ −0.66 % / −0.40 %, N_θ −0.27 % / −1.80 % (against
/// the closed crown), transition 51.61° vs 51.83°. Mesh study ([`membrane_mesh_refinement`],
/// φ₀ = 10°; errors relative to the theory, transition in degrees; the last row run once):
///
/// | h/t  | tets    | N_θ 30° | N_θ 45° | N_φ 30° | N_φ 45° | transition |
/// |------|---------|---------|---------|---------|---------|------------|
/// | 0.6  | 16 128  | −1.37 % | −1.91 % | +0.01 % | −0.13 % | −0.16°     |
/// | 0.5  | 24 072  | −1.39 % | −1.36 % | −0.34 % | −0.07 % | −0.13°     |
/// | 0.41 | 34 080  | −0.97 % | −1.21 % | +0.04 % | −0.12 % | −0.08°     |
/// | 0.25 | 180 576 | −0.70 % | −0.57 % | −0.03 % | −0.10 % | −0.04°     |
///
/// (with R/t = 50 at h = 0.6t: N_θ −0.3 % / −0.4 %). The hoop errors fall with h; the
/// meridional ones stay at the 0.1–0.3 % of the band sampling (N_φ is fixed by the
/// equilibrium of the cap). Tolerances: N_φ 1 % (measured ≤ 0.66 %); N_θ 3 % for (a)
/// (≤ 1.91 %) and the 5 % for the coarser mesh of (b) (≤ 1.80 %); the transition
/// within 0.5° (≤ 0.22°), which is a hoop-force error of 0.01 wR at the root (N_θ rises by
/// 0.02 wR per degree there), the size of 5 % of N_θ at 45°. Static state: Σ R_z = W to 1e-3
/// (measured 1e-5), kinetic energy < 1e-6 of the strain energy (4e-10), energy balance
/// within [`Energy::WARNING_THRESHOLD`] (1e-10). About 4 + 9 s in release on 2 cores
/// (10–20 s while other jobs share them).
#[test]
fn hemisphere_follows_membrane_theory() {
    for (oculus, h_over_t, tol_theta) in [(10.0, 0.6, 0.03), (2.0, 0.4125, 0.05)] {
        let closed = oculus < 5.0;
        let s = Shell::settle(0.04, oculus, h_over_t * 0.04);
        println!(
            "  {:.1} s; Σ R_z/W − 1 = {:.1e}, kinetic/strain energy {:.1e}, energy balance error {:.1e}, damping/critical {:.2}",
            s.seconds, s.reaction_error, s.kinetic_ratio, s.balance, s.damping_ratio
        );
        assert!(s.reaction_error < 1e-3, "reactions do not carry the weight");
        assert!(s.kinetic_ratio < 1e-6, "not at rest");
        assert!(s.balance.abs() < Energy::WARNING_THRESHOLD);
        for deg in [30.0, 45.0] {
            let [e_phi, e_theta] = s.check_at(deg, closed);
            assert!(e_phi.abs() < 0.01, "N_φ at {deg}°: {:+.2} %", 100.0 * e_phi);
            assert!(
                e_theta.abs() < tol_theta,
                "N_θ at {deg}°: {:+.2} %",
                100.0 * e_theta
            );
        }
        let theory = if closed {
            (0.5 * (5.0 as Real).sqrt() - 0.5).acos() // cos φ = (√5 − 1)/2: 51.83°
        } else {
            hoop_transition(s.phi0)
        }
        .to_degrees();
        let (measured, fitted) = s.transition(theory);
        println!(
            "  hoop force changes sign at {measured:.2}° (membrane theory {theory:.2}°, the same fit to it {fitted:.2}°)"
        );
        assert!((measured - theory).abs() < 0.5);
    }
}

/// The mesh study quoted in [`hemisphere_follows_membrane_theory`] (φ₀ = 10°, R/t = 25, two
/// layers of tets through the thickness, h/t = 0.6, 0.5, 0.41; about 25 s): the summed hoop
/// errors at 30° and 45° and the error of the transition angle fall with h. (The h = 0.25t row
/// of the table, four layers and 180 576 tets, took 130 s and is not repeated here.)
#[test]
#[ignore = "mesh study, ~25 s: cargo test --release --test dome -- --ignored"]
fn membrane_mesh_refinement() {
    let mut errors = Vec::new();
    for h_over_t in [0.6, 0.5, 0.41] {
        let s = Shell::settle(0.04, 10.0, h_over_t * 0.04);
        let e30 = s.check_at(30.0, false);
        let e45 = s.check_at(45.0, false);
        let theory = hoop_transition(s.phi0).to_degrees();
        let tr = s.transition(theory).0 - theory;
        println!(
            "  h = {h_over_t}t: transition error {tr:+.3}°, {:.1} s",
            s.seconds
        );
        errors.push((e30[1].abs() + e45[1].abs(), tr.abs()));
    }
    for w in errors.windows(2) {
        assert!(
            w[1].0 < w[0].0 && w[1].1 < w[0].1,
            "errors (Σ|N_θ|, |transition|) by mesh: {errors:?}"
        );
    }
}

// ─── 2. Masonry dome ─────────────────────────────────────────────────────────────

/// Joints of the masonry dome, by course (the lower of the two blocks' courses) and kind.
#[derive(Clone, Copy, Debug, Default)]
struct CourseJoints {
    head: usize,
    head_broken: usize,
    /// Head joints with some point fully damaged (D = 1) that are not broken.
    head_damaged: usize,
    /// Bed joints between this course and the one above.
    bed: usize,
    bed_broken: usize,
    bed_damaged: usize,
}

/// A hemispherical masonry dome of voussoir blocks and weak mortar settling under its own
/// weight. Reference: the crack pattern of masonry domes (Heyman, *The Stone Skeleton*,
/// 1995, on domes; the four great meridional fissures of Brunelleschi's dome in Florence):
/// below the polar angle where the membrane hoop force changes sign (51.8° for a closed crown,
/// 53.07° for this dome's 10° oculus, [`hoop_transition`]) the hoop force is tension, which
/// the mortar cannot carry: the head joints there open into meridional cracks, the upper part
/// stays in compression, and the dome, cut into lunes below, stands.
///
/// Model: `masonry::dome` with mid-surface radius R = 10 m, t = 1.2 m (t/R = 0.12), 8 courses
/// of 10° × 12 blocks, oculus 10°, h = t/2 (11 520 tets); each block one continuous body of
/// stone (ρ = 2400 kg/m³, E = 1 GPa, ν = 0.2); every shared face a `cohesive/munjiza` mortar
/// joint with the default penalties (10E); contact with Coulomb friction μ = 0.7 takes over
/// broken joints whose faces meet again. Mortar: f_t = 0.15 ρgR = 35 kPa, which the membrane
/// hoop stress N_θ/t exceeds below φ ≈ 60° (it reaches 0.98 ρgR at the base); G_I = 0.5 J/m²,
/// brittle enough that an overstressed head joint separates within the elastic hoop strain
/// of the dome (softening length G_I/(0.386 f_t) = 37 µm, against ~0.5 mm of hoop elongation
/// per block in the lower courses); Mohr–Coulomb shear c = 6 f_t, φ = 35°, G_II = 2.5 J/m².
/// The bed joints carry the hoop force round the cracked head joints through the running
/// bond, so their shear strength decides how far the cracks go. With c = 2 f_t, 14 bed joints
/// between the two lowest courses broke as well, and (before the law was made conservative:
/// tests/joints.rs, `intact_joint_conserves_energy_on_a_closed_path_under_changing_compression`)
/// that run did not come to rest: it ended with 0.7 J of kinetic energy and a balance error
/// still growing (3.8e-4 after five periods).
///
/// Supports: the base rests on rollers (z fixed), membrane-compatible as in the shell test,
/// with x held at the base nodes on the y axis and y at those on the x axis (rigid-body
/// modes). A clamped base would suppress the hoop tension over its boundary layer, a few
/// √(Rt) ≈ 3.5 m, most of the cracking zone (measured in a smaller clamped model: the hoop
/// stress stayed below 0.02 ρgR everywhere). Gravity is ramped up over two periods of the
/// lowest mode (ω ≈ 0.8 c/R, measured from the undamped response as for the shell) and held
/// for four more (the cracks grow for about two), with mass damping α = 2ω (the Rayleigh quotient of the settled deflection
/// puts it at 1.04 of critical).
///
/// Asserted: (i) joints break; (ii) every broken joint lies below the transition, within a
/// margin of one course (10°): the polar angle of its centroid φ > 53.07° − 10°; (iii) every
/// broken joint is meridional: its normal within 20° of the hoop direction at its centroid
/// (the criterion); (iv) the dome stands: Σ R_z = W to 1e-3, kinetic energy < 1e-6 of
/// the work of gravity, largest displacement < 1e-3 R; (v) the energy balance error below
/// [`Energy::WARNING_THRESHOLD`] (1 %).
///
/// Measured (conservative law): 110 broken joints, all head joints and all mode I: 67 in
/// course 0 (φ 80°–90°), 35 in course 1, 8 in course 2 (the highest at φ = 63.4°), none above
/// and no bed joint; every crack normal within 0.0° of the hoop direction. Joints with a
/// fully damaged point that have not broken: head joints in courses 0–3 (29, 61, 88, 86; the
/// highest such point at φ = 55.0°, still below the transition) and 45 bed joints between
/// courses 0 and 1. Σ R_z/W − 1 = −2.2e-5, kinetic energy 7.8e-8 of the work of gravity,
/// largest displacement 4.8e-4 R, energy balance error 8.4e-5. The cracks stay open: contact
/// never engages (and costs a quarter of the run). 50–80 s in release on 2 cores, depending on
/// what else runs.
#[test]
fn masonry_dome_cracks_along_meridians_below_the_hoop_transition() {
    use fdem::contact_interaction::{ContactRule, PotentialContact};
    use fdem::joints::law::{Calibration, Cohesive, Softening};
    use fdem::joints::JointLaw;

    let start = Instant::now();
    let (rm, t) = (10.0, 1.2);
    let d = Dome {
        radius: rm - 0.5 * t,
        thickness: t,
        courses: 8,
        blocks_per_course: 12,
        oculus: 10.0,
        base: 90.0,
    };
    let course_height = (d.base - d.oculus) / d.courses as Real;
    let a = masonry::dome(&d, 0.5 * t).unwrap();
    let (rho, e) = (2400.0, 1.0e9);
    let mut sim = Simulation::new();
    let stone = sim.add_material(Material::new(Formulation::Munjiza, rho, e, 0.2, 0.0).unwrap());
    for (i, b) in a.blocks.iter().enumerate() {
        sim.add_body(&format!("block_{i}"), &b.mesh, stone, Layout::Continuous)
            .unwrap();
    }
    let ft = 0.15 * rho * G * rm;
    let tan_phi = 35.0_f64.to_radians().tan();
    let mortar = sim.joints.add_law(JointLaw::Cohesive(Cohesive {
        softening: Softening::Munjiza,
        calibration: Calibration::Exact,
        tensile_strength: ft,
        cohesion: 6.0 * ft,
        tan_friction: tan_phi,
        g_i: 0.5,
        g_ii: 2.5,
        normal_penalty: 10.0 * e,
        tangential_penalty: 10.0 * e,
        residual_friction: tan_phi,
        rate: fdem::joints::law::RateEffects::None,
        dilatancy: fdem::joints::law::Dilatancy::NONE,
    }));
    let bodies = sim.bodies.clone();
    let refs: Vec<&fdem::state::Body> = bodies.iter().collect();
    let x0 = sim.nodes.x0.clone();
    let n_joints = sim
        .joints
        .insert_between(&refs, &x0, mortar, sim.length_tolerance());
    sim.contact
        .laws
        .rules
        .push(ContactRule::from(PotentialContact {
            friction: tan_phi,
            ..Default::default()
        }));
    let tol = 1e-9 * rm;
    let base: Vec<u32> = (0..x0.len() as u32)
        .filter(|&i| x0[i as usize].z.abs() < tol)
        .collect();
    let on_axis = |k: usize| -> Vec<u32> {
        base.iter()
            .copied()
            .filter(|&i| x0[i as usize][k].abs() < tol)
            .collect()
    };
    let (on_x_axis, on_y_axis) = (on_axis(1), on_axis(0));
    sim.fix(&base, [false, false, true]);
    sim.fix(&on_x_axis, [false, true, false]);
    sim.fix(&on_y_axis, [true, false, false]);
    let omega = 0.8 * (e / rho).sqrt() / rm;
    sim.settings.mass_damping = 2.0 * omega;
    sim.prepare().unwrap();
    let weight = sim.total_mass() * G;
    println!(
        "masonry dome: {} blocks, {} tets, {n_joints} joints, {} base nodes; f_t = {:.1} kPa; {}",
        a.blocks.len(),
        sim.tets.len(),
        base.len(),
        ft / 1e3,
        sim.dt_info.as_ref().unwrap()
    );
    let period = 2.0 * PI / omega;
    let ramp = 2.0 * period;
    while sim.time < ramp + 4.0 * period {
        sim.loads.gravity = Vec3::new(0.0, 0.0, -G * (sim.time / ramp).min(1.0));
        sim.step().unwrap();
    }
    for _ in 0..2 {
        sim.sample_next = true;
        sim.step().unwrap(); // an energy sample at the end
    }

    // Joints by course and kind; every broken one checked.
    let transition = hoop_transition(d.oculus.to_radians()).to_degrees();
    let mut rows = vec![CourseJoints::default(); d.courses];
    let mut worst_angle: Real = 0.0;
    let mut highest: Real = 180.0;
    let mut highest_damage: Real = 180.0;
    let broken_at: HashMap<usize, Vec3> = sim
        .break_events
        .iter()
        .map(|ev| (ev.joint, ev.centroid))
        .collect();
    for j in 0..sim.joints.len() {
        let [ca, cb] =
            sim.joints.tets[j].map(|e| a.blocks[sim.tets.body[e as usize] as usize].course);
        let f = sim.joints.faces[j][0].map(|n| x0[n as usize]);
        let normal = (f[1] - f[0]).cross(&(f[2] - f[0])).normalize();
        let (_, _, e_theta) = frame(&((f[0] + f[1] + f[2]) / 3.0));
        let angle = normal.dot(&e_theta).abs().min(1.0).acos().to_degrees();
        let damaged = sim.joints.state[j].iter().any(|p| p.damage >= 1.0);
        for (p, st) in sim.joints.state[j].iter().enumerate() {
            if st.damage >= 1.0 {
                let phi = frame(&x0[sim.joints.faces[j][0][p] as usize])
                    .0
                    .to_degrees();
                highest_damage = highest_damage.min(phi);
            }
        }
        let row = &mut rows[ca.min(cb)];
        let broken = sim.joints.broken[j];
        if ca == cb {
            row.head += 1;
            row.head_broken += broken as usize;
            row.head_damaged += (damaged && !broken) as usize;
        } else {
            row.bed += 1;
            row.bed_broken += broken as usize;
            row.bed_damaged += (damaged && !broken) as usize;
        }
        if let Some(c) = broken_at.get(&j) {
            let phi = frame(c).0.to_degrees();
            highest = highest.min(phi);
            worst_angle = worst_angle.max(angle);
            assert!(
                phi > transition - course_height,
                "joint {j} broke at φ = {phi:.1}°, above the hoop transition {transition:.2}° less one course"
            );
            assert!(
                angle < 20.0,
                "joint {j} (courses {ca}, {cb}) broke with its normal {angle:.1}° from the hoop direction"
            );
        }
    }
    for (c, r) in rows.iter().enumerate() {
        let lo = d.base - course_height * (c + 1) as Real;
        println!(
            "  course {c} (φ {lo:.0}°–{:.0}°): head joints {:>3}, broken {:>3}, damaged {:>3}; bed joints above {:>3}, broken {:>3}, damaged {:>3}",
            lo + course_height, r.head, r.head_broken, r.head_damaged, r.bed, r.bed_broken, r.bed_damaged
        );
    }
    let modes = ["I", "II", "mixed"].map(|m| {
        sim.break_events
            .iter()
            .filter(|ev| ev.mode.name() == m)
            .count()
    });
    let umax = (0..x0.len())
        .map(|i| (sim.nodes.x[i] - x0[i]).norm())
        .fold(0.0, Real::max);
    let en = sim.energy;
    let reaction = sim.reaction_sum(&base).z / weight - 1.0;
    println!(
        "  {} broken (modes I/II/mixed {modes:?}), highest at φ = {highest:.1}° (transition {transition:.2}°), largest normal–hoop angle {worst_angle:.1}°; highest fully damaged point at φ = {highest_damage:.1}°; {} contact pairs touching",
        sim.break_events.len(),
        sim.contact.last.active
    );
    println!(
        "  Σ R_z/W − 1 = {reaction:.1e}, kinetic/gravity work {:.1e}, largest displacement {:.2e} R, energy balance error {:.2e}, damping/critical {:.2}; {} steps in {:.1} s",
        en.kinetic / en.gravity_work,
        umax / rm,
        en.relative_balance_error(),
        damping_ratio(&sim),
        sim.step,
        start.elapsed().as_secs_f64()
    );
    let timers: Vec<String> = fdem::Stage::ALL
        .iter()
        .map(|&s| format!("{} {:.1} s", s.name(), sim.timers.get(s)))
        .collect();
    println!("  {}", timers.join(", "));
    assert!(!sim.break_events.is_empty(), "no joint broke");
    assert!(reaction.abs() < 1e-3, "reactions do not carry the weight");
    assert!(en.kinetic < 1e-6 * en.gravity_work, "not at rest");
    assert!(umax < 1e-3 * rm, "the dome moved {umax:.3e} m");
    assert!(
        en.relative_balance_error().abs() < Energy::WARNING_THRESHOLD,
        "energy balance error {:.3e}",
        en.relative_balance_error()
    );
}
