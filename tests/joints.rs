//! Stages 2–3 physics: a single joint between two rigidly driven tetrahedra (displacement
//! control), in mode I, mode II and mixed mode.

use fdem::joints::law::{Calibration, Cohesive, Softening};
use fdem::joints::JointLaw;
use fdem::loads::{PrescribedVelocity, TimeFunction};
use fdem::material::{Formulation, Material};
use fdem::math::{Real, Vec3};
use fdem::mesh::Mesh;
use fdem::{Layout, Simulation};

/// Two tets sharing the face (1, 2, 3); tet A holds the origin, tet B the far node.
fn two_tets() -> Mesh {
    let nodes = vec![
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(0.7, 0.7, 0.7),
    ];
    let mut b = [1u32, 2, 3, 4];
    let p = |i: u32| nodes[i as usize];
    if fdem::math::tet_volume(&p(b[0]), &p(b[1]), &p(b[2]), &p(b[3])) < 0.0 {
        b.swap(0, 1);
    }
    Mesh::new(nodes, vec![[0, 1, 2, 3], b])
}

fn law(cal: Calibration) -> Cohesive {
    Cohesive {
        softening: Softening::Munjiza,
        calibration: cal,
        tensile_strength: 1e6,
        cohesion: 2e6,
        tan_friction: 30f64.to_radians().tan(),
        g_i: 100.0,
        g_ii: 400.0,
        normal_penalty: 1e13,
        tangential_penalty: 1e13,
        residual_friction: 0.5,
        rate: fdem::joints::law::RateEffects::None,
        dilatancy: fdem::joints::law::Dilatancy::NONE,
    }
}

struct Rig {
    sim: Simulation,
    b_nodes: Vec<u32>,
    n: Vec3,
    area: Real,
    size: Real,
}

/// The two tets, one joint, A fixed, B moving rigidly with velocity `v(t)` (a table per component).
fn rig(cohesive: Cohesive, v: [TimeFunction; 3]) -> Rig {
    let mut sim = Simulation::new();
    let m =
        sim.add_material(Material::new(Formulation::NeoHookean, 1000.0, 1e9, 0.25, 0.0).unwrap());
    sim.add_body("pair", &two_tets(), m, Layout::Jointed)
        .unwrap();
    let l = sim.joints.add_law(JointLaw::Cohesive(cohesive));
    let (body, tets, x0) = (
        sim.bodies[0].clone(),
        sim.tets.nodes.clone(),
        sim.nodes.x0.clone(),
    );
    assert_eq!(
        sim.joints
            .insert_in_body(&body, &tets, &x0, l, |_| true)
            .unwrap(),
        1
    );
    let a_nodes = sim.tets.nodes[0].to_vec();
    let b_nodes = sim.tets.nodes[1].to_vec();
    sim.loads.prescribed.push(PrescribedVelocity {
        nodes: a_nodes.clone(),
        components: std::array::from_fn(|_| Some(TimeFunction::Constant(0.0))),
    });
    sim.loads.prescribed.push(PrescribedVelocity {
        nodes: b_nodes.clone(),
        components: v.map(Some),
    });
    let n = Vec3::new(1.0, 1.0, 1.0).normalize();
    let (area, size) = (sim.joints.area0[0], sim.joints.size[0]);
    sim.settings.energy_every = 1;
    Rig {
        sim,
        b_nodes,
        n,
        area,
        size,
    }
}

impl Rig {
    /// Drive B through `phases` of (steps, constant velocity) one after the other; returns
    /// the time each phase ends [s].
    fn drive_in_phases(&mut self, phases: &[(Real, Vec3)]) -> Vec<Real> {
        let dt = self.sim.dt;
        let mut pts: [Vec<(Real, Real)>; 3] = Default::default();
        let mut t0 = 0.0;
        let mut ends = Vec::new();
        for &(n, v) in phases {
            for k in 0..3 {
                pts[k].push((t0 + 1e-6 * dt, v[k]));
                pts[k].push((t0 + n * dt, v[k]));
            }
            t0 += n * dt;
            ends.push(t0);
        }
        self.sim.loads.prescribed[1].components =
            pts.map(|p| Some(TimeFunction::table(p).unwrap()));
        self.sim.invalidate();
        ends
    }

    /// Normal and shear traction the joint transmits [Pa], from the reactions holding B.
    fn traction(&self, t_dir: Vec3) -> (Real, Real) {
        let r: Vec3 = self
            .b_nodes
            .iter()
            .map(|&i| self.sim.nodes.reaction_sum(&[i]))
            .sum();
        (r.dot(&self.n) / self.area, r.dot(&t_dir) / self.area)
    }
    /// Displacement jump across the joint: A is fixed and B moves rigidly, so it is the
    /// displacement of any node of B.
    fn opening(&self) -> Vec3 {
        let i = self.b_nodes[0] as usize;
        self.sim.nodes.x[i] - self.sim.nodes.x0[i]
    }
}

fn constant(v: Vec3) -> [TimeFunction; 3] {
    [
        TimeFunction::Constant(v.x),
        TimeFunction::Constant(v.y),
        TimeFunction::Constant(v.z),
    ]
}

/// Mode I, slow enough that the peak is resolved by ~1000 steps: peak traction = f_t (1 %) at
/// the opening δp = 2h·f_t/p (1 %). Reference: Munjiza (2004) eq. 7.11.
#[test]
fn mode_one_peak_traction_and_opening() {
    let coh = law(Calibration::Exact);
    let mut r = rig(coh.clone(), constant(Vec3::zeros()));
    r.sim.prepare().unwrap();
    let dp = coh.peak_opening(r.size);
    let v = dp / (1000.0 * r.sim.dt);
    r.sim.loads.prescribed[1].components = constant(r.n * v).map(Some);
    r.sim.invalidate();
    let (mut peak, mut at) = (0.0, 0.0);
    while r.opening().dot(&r.n) < 2.0 * dp {
        r.sim.step().unwrap();
        let (s, _) = r.traction(Vec3::zeros());
        if s > peak {
            peak = s;
            at = r.opening().dot(&r.n) - 0.5 * v * r.sim.dt; // opening when the reaction acted
        }
    }
    assert!(
        (peak - coh.tensile_strength).abs() < 0.01 * coh.tensile_strength,
        "peak {peak:e}"
    );
    assert!(
        (at - dp).abs() < 0.01 * dp,
        "opening at peak {at:e} vs 2h·f_t/p = {dp:e}"
    );
}

/// Mode I to full separation: the energy dissipated (work of the reactions, all of it gone
/// into fracture once the joint has broken) is G_I + ⅔f_t·δp for the exact calibration and
/// 3·0.38631·G_I + ⅔f_t·δp = 1.159·G_I + … for the Y-compatible one (1 %); with p = 1e7·f_t
/// the pre-peak share is 0.19 % of G_I here (h = √2), so both are also within 1 % of G_I and
/// 1.159·G_I.
#[test]
fn mode_one_dissipates_g_i() {
    for (cal, factor) in [
        (Calibration::Exact, 1.0),
        (
            Calibration::YCompatible,
            3.0 * fdem::joints::law::Z_INTEGRAL,
        ),
    ] {
        let coh = law(cal);
        let mut r = rig(coh.clone(), constant(Vec3::zeros()));
        r.sim.prepare().unwrap();
        let (dnt, _) = coh.softening_lengths(coh.cohesion);
        let end = coh.peak_opening(r.size) + dnt;
        let v = 1.2 * end / (20_000.0 * r.sim.dt);
        r.sim.loads.prescribed[1].components = constant(r.n * v).map(Some);
        r.sim.invalidate();
        while r.sim.break_events.is_empty() {
            r.sim.step().unwrap();
            assert!(r.sim.step < 30_000, "never broke");
        }
        for _ in 0..10 {
            r.sim.step().unwrap();
        }
        let e = r.sim.energy;
        let g = factor * coh.g_i;
        let expected = (g + 2.0 / 3.0 * coh.tensile_strength * coh.peak_opening(r.size)) * r.area;
        assert!(
            (e.fracture - expected).abs() < 0.01 * expected,
            "{cal:?}: dissipated {:e} vs {expected:e}",
            e.fracture
        );
        assert!((e.fracture - g * r.area).abs() < 0.01 * g * r.area);
        // Everything the driver put in went into fracture (joint energy ~0 once broken).
        assert!(
            (e.reaction_work - e.fracture).abs() < 0.01 * expected,
            "{e:?}"
        );
        assert_eq!(r.sim.break_events[0].mode, fdem::fracture::BreakMode::I);
    }
}

/// Mode II at σn = 0 and under compression σn < 0 (the joint first closed by δc, then slid):
/// peak shear = c − σn·tan φ (1 %), and at σn = 0 the dissipated energy is G_II (1 %).
#[test]
fn mode_two_peak_follows_mohr_coulomb() {
    let coh = law(Calibration::Exact);
    let t_dir = Vec3::new(1.0, -1.0, 0.0).normalize();
    for closing in [0.0, 3.0] {
        let mut r = rig(coh.clone(), constant(Vec3::zeros()));
        r.sim.prepare().unwrap();
        let dt = r.sim.dt;
        // Close by `closing`·δnp over 200 steps, then slide at a rate resolving the peak.
        let dc = closing * coh.peak_opening(r.size);
        let sigma_n = -coh.normal_penalty / r.size * dc;
        let fs = coh.cohesion - sigma_n * coh.tan_friction;
        let dsp = coh.peak_slip(r.size, fs);
        let (_, dst) = coh.softening_lengths(fs);
        let t_close = 200.0 * dt;
        let v_close = -dc / t_close;
        let v_slide = if closing == 0.0 {
            1.2 * (dsp + dst) / (20_000.0 * dt)
        } else {
            dsp / (1000.0 * dt)
        };
        let comp = |k: usize| {
            TimeFunction::table(vec![
                (0.0, r.n[k] * v_close),
                (t_close, r.n[k] * v_close),
                (t_close + 1e-3 * dt, t_dir[k] * v_slide),
                (1.0, t_dir[k] * v_slide),
            ])
            .unwrap()
        };
        r.sim.loads.prescribed[1].components = [Some(comp(0)), Some(comp(1)), Some(comp(2))];
        r.sim.invalidate();
        let mut peak: Real = 0.0;
        let mut steps = 0;
        while r.sim.break_events.is_empty() && steps < 30_000 {
            r.sim.step().unwrap();
            steps += 1;
            peak = peak.max(r.traction(t_dir).1.abs());
            if closing > 0.0 && r.opening().dot(&t_dir) > 2.0 * dsp {
                break;
            }
        }
        assert!(
            (peak - fs).abs() < 0.01 * fs,
            "σn = {sigma_n:e}: peak shear {peak:e} vs c − σn·tanφ = {fs:e}"
        );
        if closing == 0.0 {
            assert_eq!(r.sim.break_events.len(), 1);
            assert_eq!(r.sim.break_events[0].mode, fdem::fracture::BreakMode::II);
            for _ in 0..10 {
                r.sim.step().unwrap();
            }
            let g = coh.g_ii * r.area;
            assert!(
                (r.sim.energy.fracture - g).abs() < 0.01 * g,
                "dissipated {:e} vs G_II·A = {g:e}",
                r.sim.energy.fracture
            );
        }
    }
}

/// Mixed mode at 45° (equal opening and slip rates): the joint breaks where the elliptical
/// interaction ((δ−δnp)/δnt)² + ((δ−δsp)/δst)² = 1 is met — solved here in closed form.
#[test]
fn mixed_mode_breaks_on_the_ellipse() {
    let coh = law(Calibration::Exact);
    let t_dir = Vec3::new(1.0, -1.0, 0.0).normalize();
    let mut r = rig(coh.clone(), constant(Vec3::zeros()));
    r.sim.prepare().unwrap();
    let (dnp, dsp) = (
        coh.peak_opening(r.size),
        coh.peak_slip(r.size, coh.cohesion),
    );
    let (dnt, dst) = coh.softening_lengths(coh.cohesion);
    // ((δ−a)/A)² + ((δ−b)/B)² = 1  →  quadratic in δ, larger root.
    let (qa, qb, qc) = (
        1.0 / (dnt * dnt) + 1.0 / (dst * dst),
        -2.0 * (dnp / (dnt * dnt) + dsp / (dst * dst)),
        dnp * dnp / (dnt * dnt) + dsp * dsp / (dst * dst) - 1.0,
    );
    let delta = (-qb + (qb * qb - 4.0 * qa * qc).sqrt()) / (2.0 * qa);
    let dir = (r.n + t_dir).normalize();
    let v = 1.2 * delta * 2f64.sqrt() / (20_000.0 * r.sim.dt);
    r.sim.loads.prescribed[1].components = constant(dir * v).map(Some);
    r.sim.invalidate();
    while r.sim.break_events.is_empty() {
        r.sim.step().unwrap();
        assert!(r.sim.step < 30_000);
    }
    let jump = r.opening();
    let (dn, ds) = (jump.dot(&r.n), jump.dot(&t_dir));
    let step = v * r.sim.dt;
    assert!(
        (dn - delta).abs() < 0.01 * delta + step && (ds - delta).abs() < 0.01 * delta + step,
        "broke at ({dn:e}, {ds:e}), ellipse predicts {delta:e}"
    );
    assert_eq!(r.sim.break_events[0].mode, fdem::fracture::BreakMode::Mixed);
}

/// Compliance constant of joints in the structured Kuhn mesh under uniaxial stress along a
/// cell axis: 1/E_eff = 1/E + K_JOINT/p. Measured 2.75–2.87 for p = 10E–100E (a 1D chain of
/// elements with joint stiffness p/h, h the element size, has K = 1; the Kuhn cell adds its
/// inclined internal faces). Documented in docs/theory/joints.md.
const K_JOINT: Real = 2.8;

struct BarResult {
    peak_over_ft_a: Real,
    e_eff_over_e: Real,
    fragments: u32,
    crack_planes: Vec<Real>,
    broken: usize,
    balance: Real,
}

/// A fully jointed bar L × L/10 × L/10 (20 × 2 × 2 Kuhn cells, `elastic/munjiza`, ν = 0) with
/// the test law at f_t = `ft`, c = 3f_t, G_I = 50 J/m² and p = `p_over_e`·E on every internal
/// face, held along x at x = 0 and pulled at x = L with a velocity ramped from 0 to `v` over
/// five wave transits. Returns the simulation and the nodes of the pulled end.
fn pulled_bar(
    l: Real,
    (e, rho, ft, p_over_e): (Real, Real, Real, Real),
    rate: fdem::joints::law::RateEffects,
    v: Real,
) -> (Simulation, Vec<u32>) {
    let a = l / 10.0;
    let mut sim = Simulation::new();
    let m = sim.add_material(Material::new(Formulation::Munjiza, rho, e, 0.0, 0.0).unwrap());
    sim.add_body(
        "bar",
        &fdem::mesh::box_mesh(Vec3::zeros(), Vec3::new(l, a, a), [20, 2, 2]),
        m,
        Layout::Jointed,
    )
    .unwrap();
    let mut coh = law(Calibration::Exact);
    coh.tensile_strength = ft;
    coh.cohesion = 3.0 * ft;
    coh.g_i = 50.0;
    coh.normal_penalty = p_over_e * e;
    coh.tangential_penalty = p_over_e * e;
    coh.rate = rate;
    let l_id = sim.joints.add_law(JointLaw::Cohesive(coh));
    let (body, tets, x0) = (
        sim.bodies[0].clone(),
        sim.tets.nodes.clone(),
        sim.nodes.x0.clone(),
    );
    sim.joints
        .insert_in_body(&body, &tets, &x0, l_id, |_| true)
        .unwrap();
    let plane = |x: Real, out: Real| {
        sim.nodes_in(
            &fdem::mesh::Region::HalfSpace {
                point: Vec3::new(x, 0.0, 0.0),
                normal: Vec3::new(out, 0.0, 0.0),
            },
            None,
        )
    };
    let (left, right) = (plane(0.0, -1.0), plane(l, 1.0));
    let c = (e / rho).sqrt();
    sim.loads.prescribed.push(PrescribedVelocity {
        nodes: left,
        components: [Some(TimeFunction::Constant(0.0)), None, None],
    });
    sim.loads.prescribed.push(PrescribedVelocity {
        nodes: right.clone(),
        components: [
            Some(TimeFunction::table(vec![(0.0, 0.0), (5.0 * l / c, v)]).unwrap()),
            None,
            None,
        ],
    });
    (sim, right)
}

/// A fully jointed bar (1 × 0.1 × 0.1 m, 20 × 2 × 2 Kuhn cells, ν = 0) pulled slowly (over
/// 40 wave transits) at x = L, held along x at x = 0, until it separates.
fn jointed_bar(p_over_e: Real) -> BarResult {
    let (l, a, e, ft) = (1.0, 0.1, 1e10, 1e6);
    let c = (e / 2500.0 as Real).sqrt();
    let t_load = 40.0 * l / c;
    let v = 2.0 * ft / e * l / t_load;
    let (mut sim, right) = pulled_bar(
        l,
        (e, 2500.0, ft, p_over_e),
        fdem::joints::law::RateEffects::None,
        v,
    );
    let (mut peak, mut e_eff, mut fragments) = (0.0 as Real, 0.0, 1);
    while sim.time < 1.5 * t_load {
        sim.step().unwrap();
        let f: Real = right.iter().map(|&n| sim.nodes.reaction_sum(&[n]).x).sum();
        let u = right
            .iter()
            .map(|&n| sim.nodes.x[n as usize].x - l)
            .sum::<Real>()
            / right.len() as Real;
        if e_eff == 0.0 && u > 0.25 * ft / e * l {
            e_eff = (f / (a * a)) / (u / l); // secant stiffness at a quarter of the strength
        }
        peak = peak.max(f);
        if !sim.break_events.is_empty() && sim.step.is_multiple_of(200) {
            fragments = fdem::fracture::fragments(&sim.tets.nodes, &sim.joints, sim.nodes.len())
                .into_iter()
                .max()
                .unwrap()
                + 1;
            if fragments >= 2 {
                break;
            }
        }
    }
    // Crack planes: break positions along x, merged when closer than a fifth of a cell.
    let mut xs: Vec<Real> = sim.break_events.iter().map(|b| b.centroid.x).collect();
    xs.sort_by(|p, q| p.total_cmp(q));
    let mut crack_planes: Vec<Real> = Vec::new();
    for x in xs {
        if crack_planes.last().is_none_or(|&c| x - c > 0.2 * l / 20.0) {
            crack_planes.push(x);
        }
    }
    BarResult {
        peak_over_ft_a: peak / (ft * a * a),
        e_eff_over_e: e_eff / e,
        fragments,
        crack_planes,
        broken: sim.break_events.len(),
        balance: sim.energy.relative_balance_error(),
    }
}

/// Jointed bar in slow tension: it breaks at f_t·A (2 %) along one plane into two fragments;
/// its stiffness follows the documented compliance 1/E_eff = 1/E + K/p (2 %) for p = 10E and
/// 100E; and the energy account closes through fracture — external work = strain + kinetic
/// + joint + fracture dissipation — within 2 %.
#[test]
fn jointed_bar_breaks_at_its_strength_into_two_fragments() {
    for p in [10.0, 100.0] {
        let r = jointed_bar(p);
        assert!(
            (r.peak_over_ft_a - 1.0).abs() < 0.02,
            "p = {p}E: peak/(f_t·A) = {}",
            r.peak_over_ft_a
        );
        assert_eq!(r.fragments, 2, "p = {p}E");
        assert_eq!(
            r.crack_planes.len(),
            1,
            "one crack plane, got {:?}",
            r.crack_planes
        );
        assert_eq!(
            r.broken, 8,
            "the crack cuts the 2×2-cell section: 8 triangles"
        );
        let predicted = 1.0 / (1.0 + K_JOINT / p);
        assert!(
            (r.e_eff_over_e - predicted).abs() < 0.02 * predicted,
            "p = {p}E: E_eff/E = {} vs {predicted}",
            r.e_eff_over_e
        );
        assert!(
            r.balance.abs() < 0.02,
            "p = {p}E: energy balance {}",
            r.balance
        );
    }
}

/// Friction on a broken, closed joint: after a mode-I break the faces are pushed back into
/// contact (overlap δc, normal stress σn = −p_n·δc/h) and slid by +d, then by −2d. Coulomb
/// friction resists in both directions with |τ| = μ|σn| (1 %), and the energy dissipated by
/// sliding is μ|σn|·A·(3d − 3u_e), u_e = μ|σn|/(p_t/h) the elastic pre-slip of each reversal
/// (1 %). Regression: a scalar slip anchor once let a joint slide back without resistance.
#[test]
fn broken_joint_has_coulomb_friction_both_ways() {
    let coh = law(Calibration::Exact);
    let t_dir = Vec3::new(1.0, -1.0, 0.0).normalize();
    let mut r = rig(coh.clone(), constant(Vec3::zeros()));
    r.sim.prepare().unwrap();
    let dt = r.sim.dt;
    let (dnp, (dnt, _)) = (
        coh.peak_opening(r.size),
        coh.softening_lengths(coh.cohesion),
    );
    let open = 1.2 * (dnp + dnt);
    let dc = 3.0 * dnp;
    let d = 0.1 * dnt;
    // Phases: open (20 000 steps), close to overlap dc (2 000), slide +d (4 000), slide −2d (8 000).
    let phases = [
        (20_000.0, r.n * (open / (20_000.0 * dt))),
        (2_000.0, -r.n * ((open + dc) / (2_000.0 * dt))),
        (4_000.0, t_dir * (d / (4_000.0 * dt))),
        (8_000.0, -t_dir * (2.0 * d / (8_000.0 * dt))),
    ];
    let ends = r.drive_in_phases(&phases);
    let mu_sigma = coh.residual_friction * coh.normal_penalty / r.size * dc;
    let (mut fwd, mut back, mut dissipated_before_slide) = (0.0 as Real, 0.0 as Real, 0.0);
    while r.sim.time < ends[3] - 0.5 * dt {
        r.sim.step().unwrap();
        let (_, tau) = r.traction(t_dir);
        if r.sim.time > ends[1] && r.sim.time < ends[2] {
            fwd = fwd.max(tau);
        } else if r.sim.time > ends[2] {
            back = back.min(tau);
        } else if r.sim.time <= ends[1] {
            dissipated_before_slide = r.sim.energy.fracture;
        }
    }
    assert_eq!(
        r.sim.break_events.len(),
        1,
        "the joint broke in the opening phase"
    );
    assert!(
        (fwd - mu_sigma).abs() < 0.01 * mu_sigma,
        "forward friction {fwd:e} vs μ|σn| = {mu_sigma:e}"
    );
    assert!(
        (back + mu_sigma).abs() < 0.01 * mu_sigma,
        "backward friction {back:e} vs −μ|σn| = {:e}",
        -mu_sigma
    );
    for _ in 0..2 {
        r.sim.step().unwrap(); // a sample at rest
    }
    let u_e = mu_sigma / (coh.tangential_penalty / r.size);
    let expected = mu_sigma * r.area * (3.0 * d - 3.0 * u_e);
    let friction = r.sim.energy.fracture - dissipated_before_slide;
    assert!(
        (friction - expected).abs() < 0.01 * expected,
        "friction dissipation {friction:e} vs {expected:e}"
    );
}

/// The Munjiza law written in Rhai (stdlib/joint_laws.rhai), compiled to a closure tree,
/// gives the same tractions and damage as the built-in law to 1e-12 (relative to the
/// strength) along monotonic loading paths through the pre-peak, softening and
/// compressed-sliding regimes, in both calibrations. (Broken joints in compression and
/// reversed slip are excluded: the built-in adds friction, and slips plastically beyond the
/// shear peak, with vector histories that a scalar script law does not have.)
#[test]
fn rhai_munjiza_law_equals_the_builtin() {
    use fdem::joints::law::{PointKinematics, PointState};
    let src = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/stdlib/joint_laws.rhai"
    ))
    .unwrap();
    let ast = rhai::Engine::new_raw().compile(&src).unwrap();
    for cal in [Calibration::Exact, Calibration::YCompatible] {
        let mut coh = law(cal);
        coh.normal_penalty = 1e10;
        coh.tangential_penalty = 5e9;
        let k_soft = match cal {
            Calibration::Exact => 1.0 / fdem::joints::law::Z_INTEGRAL,
            Calibration::YCompatible => 3.0,
        };
        let mut params = rhai::Map::new();
        for (k, v) in [
            ("tensile_strength", coh.tensile_strength),
            ("cohesion", coh.cohesion),
            ("tan_friction", coh.tan_friction),
            ("g_i", coh.g_i),
            ("g_ii", coh.g_ii),
            ("normal_penalty", coh.normal_penalty),
            ("tangential_penalty", coh.tangential_penalty),
            ("k_soft", k_soft),
        ] {
            params.insert(k.into(), v.into());
        }
        let script =
            fdem::compiled::compile_with(&ast, "munjiza", &params, fdem::joints::JOINT_LAW)
                .unwrap();
        let consts = coh.consts();
        let h = 0.02;
        let dnp = coh.peak_opening(h);
        let (dnt, _) = coh.softening_lengths(coh.cohesion);
        // Paths (opening, slip) as functions of a load parameter s ∈ [0, 1].
        let paths: [&dyn Fn(Real) -> (Real, Real); 4] = [
            &|s| (s * (dnp + 1.1 * dnt), 0.0),
            &|s| (0.0, s * 10.0 * dnt),
            &|s| (s * 0.6 * dnt, s * 2.0 * dnt),
            &|s| (-s * 3.0 * dnp, s * 2.0 * dnt),
        ];
        let mut compared = 0;
        for path in paths {
            let (mut sb, mut ss) = (PointState::default(), PointState::default());
            for i in 0..=2000 {
                let (opening, slip) = path(i as Real / 2000.0);
                if sb.damage >= 1.0 && opening <= 0.0 {
                    break;
                }
                let k = PointKinematics {
                    opening,
                    slip,
                    slip_vector: Vec3::new(slip, 0.0, 0.0),
                    normal: Vec3::z(),
                    size: h,
                };
                let b = coh.evaluate_with(&consts, &k, 1.0 / h, &mut sb, false);
                ss.max_opening = ss.max_opening.max(opening);
                ss.max_slip = ss.max_slip.max(slip);
                let [n, t, d] =
                    script.evaluate(&[opening, slip, ss.max_opening, ss.max_slip, h, ss.damage]);
                ss.damage = ss.damage.max(d.min(1.0));
                let scale = coh.cohesion.max(coh.tensile_strength);
                assert!(
                    (n - b.normal).abs() <= 1e-12 * scale,
                    "{cal:?} step {i}: normal {n:e} vs {:e}",
                    b.normal
                );
                assert!(
                    (t - (b.shear + b.tangential.x)).abs() <= 1e-12 * scale,
                    "{cal:?} step {i}: shear {t:e} vs {:e}",
                    b.shear + b.tangential.x
                );
                assert!(
                    (ss.damage - sb.damage).abs() <= 1e-12,
                    "{cal:?} step {i}: damage {} vs {}",
                    ss.damage,
                    sb.damage
                );
                compared += 1;
            }
            assert!(sb.damage > 0.0, "each path reaches the softening branch");
        }
        assert!(compared > 5000);
    }
}

/// Constructs outside the compiled subset are refused with the construct and its line.
#[test]
fn unsupported_construct_in_a_script_law_is_refused_with_its_line() {
    let cases = [
        ("fn law(j, p) {\n    let s = \"text\";\n    #{ normal: 0.0, shear: 0.0, damage: 0.0 }\n}", "line 2: a string"),
        ("fn law(j, p) {\n    let x = 0.0;\n    for i in 0..3 { x += 1.0; }\n    #{ normal: x, shear: 0.0, damage: 0.0 }\n}", "line 3: a loop"),
        ("fn law(j, p) {\n    #{ normal: print(1.0), shear: 0.0, damage: 0.0 }\n}", "line 2: the function 'print'"),
        ("fn law(j, p) {\n    #{ normal: j.speed, shear: 0.0, damage: 0.0 }\n}", "line 2: j.speed is not an input"),
        ("fn law(j, p) {\n    #{ normal: 0.0, shear: 0.0 }\n}", "needs the keys normal, shear, damage"),
    ];
    for (src, expected) in cases {
        let ast = rhai::Engine::new_raw().compile(src).unwrap();
        let e =
            fdem::compiled::compile_with(&ast, "law", &rhai::Map::new(), fdem::joints::JOINT_LAW)
                .unwrap_err();
        assert!(e.contains(expected), "{e}");
    }
}

fn criterion(
    src: &str,
    params: &[(&str, Real)],
    when: fdem::fracture::CriterionWhen,
) -> fdem::fracture::FractureCriterion {
    let ast = rhai::Engine::new_raw().compile(src).unwrap();
    let mut p = rhai::Map::new();
    for (k, v) in params {
        p.insert((*k).into(), (*v).into());
    }
    let f = fdem::compiled::compile_with(&ast, "criterion", &p, fdem::fracture::CRITERION).unwrap();
    fdem::fracture::FractureCriterion::new(std::sync::Arc::new(f), when)
}

/// A criterion that gates breaking ("damaged"): the fully damaged joint breaks only once it
/// has opened to the limit the criterion sets (1.5× the full softening length), within one step.
#[test]
fn fracture_criterion_gates_fully_damaged_joints() {
    let coh = law(Calibration::Exact);
    let mut r = rig(coh.clone(), constant(Vec3::zeros()));
    r.sim.prepare().unwrap();
    let (dnp, (dnt, _)) = (
        coh.peak_opening(r.size),
        coh.softening_lengths(coh.cohesion),
    );
    let limit = 1.5 * (dnp + dnt);
    r.sim.fracture_criterion = Some(criterion(
        "fn criterion(j, p) { j.max_opening > p.limit }",
        &[("limit", limit)],
        fdem::fracture::CriterionWhen::Damaged,
    ));
    let v = 2.0 * limit / (20_000.0 * r.sim.dt);
    r.sim.loads.prescribed[1].components = constant(r.n * v).map(Some);
    r.sim.invalidate();
    let mut failed_at = None;
    while r.sim.break_events.is_empty() {
        r.sim.step().unwrap();
        assert!(r.sim.step < 30_000);
        if failed_at.is_none() && r.sim.joints.state[0].iter().all(|p| p.damage >= 1.0) {
            failed_at = Some(r.opening().dot(&r.n));
        }
    }
    let at = r.opening().dot(&r.n);
    assert!(
        failed_at.unwrap() < 0.7 * limit,
        "the joint was fully damaged well before the limit"
    );
    assert!(
        (at - limit).abs() <= 2.0 * v * r.sim.dt,
        "broke at opening {at:e}, criterion limit {limit:e}"
    );
}

/// A criterion that triggers breaking ("always"): the joint breaks before its peak, at half the
/// peak opening; the energy it stored is released as fracture dissipation, so the driver's work
/// equals the fracture energy (1 %).
#[test]
fn fracture_criterion_breaks_intact_joints_and_books_their_energy() {
    let coh = law(Calibration::Exact);
    let mut r = rig(coh.clone(), constant(Vec3::zeros()));
    r.sim.prepare().unwrap();
    let dnp = coh.peak_opening(r.size);
    r.sim.fracture_criterion = Some(criterion(
        "fn criterion(j, p) { j.opening > p.limit }",
        &[("limit", 0.5 * dnp)],
        fdem::fracture::CriterionWhen::Always { every: 1 },
    ));
    let v = dnp / (1000.0 * r.sim.dt);
    r.sim.loads.prescribed[1].components = constant(r.n * v).map(Some);
    r.sim.invalidate();
    while r.sim.break_events.is_empty() {
        r.sim.step().unwrap();
        assert!(r.sim.step < 5_000);
    }
    let at = r.opening().dot(&r.n);
    assert!(
        (at - 0.5 * dnp).abs() <= 2.0 * v * r.sim.dt,
        "broke at {at:e}, limit {:e}",
        0.5 * dnp
    );
    assert!(r.sim.joints.state[0].iter().all(|p| p.damage == 1.0));
    for _ in 0..5 {
        r.sim.step().unwrap();
    }
    let e = r.sim.energy;
    // Stored at x = δ/δp = 1/2: f_t·δp·(x² − x³/3) per area.
    let stored = coh.tensile_strength * dnp * (0.25 - 0.125 / 3.0) * r.area;
    assert!(
        (e.fracture - stored).abs() < 0.01 * stored,
        "released {:e} vs stored {stored:e}",
        e.fracture
    );
    assert!(
        (e.reaction_work - e.fracture).abs() < 0.01 * stored,
        "{e:?}"
    );
}

/// Two continuous blocks glued by joints on their coincident faces (mortar): 32 joints on a
/// 4 × 4-cell interface. Pulled apart slowly (over 160 wave transits: at 40 the block's inertia,
/// ringing as the interface softens, adds 2.1 % to the reaction at the driven face), the
/// interface carries f_t·A at peak (2 %) and separates into two fragments along the interface.
#[test]
fn joints_between_bodies_glue_and_release_them() {
    let (e, ft) = (1e10, 1e6);
    let mut sim = Simulation::new();
    let m = sim.add_material(Material::new(Formulation::Munjiza, 2500.0, e, 0.0, 0.0).unwrap());
    let base = fdem::mesh::box_mesh(Vec3::zeros(), Vec3::new(1.0, 1.0, 0.5), [4, 4, 2]);
    let block = fdem::mesh::box_mesh(
        Vec3::new(0.0, 0.0, 0.5),
        Vec3::new(1.0, 1.0, 1.0),
        [4, 4, 2],
    );
    sim.add_body("base", &base, m, Layout::Continuous).unwrap();
    sim.add_body("block", &block, m, Layout::Continuous)
        .unwrap();
    let mut coh = law(Calibration::Exact);
    coh.tensile_strength = ft;
    coh.cohesion = 3.0 * ft;
    coh.g_i = 20.0;
    coh.normal_penalty = 100.0 * e;
    coh.tangential_penalty = 100.0 * e;
    let l = sim.joints.add_law(JointLaw::Cohesive(coh));
    let (b0, b1, x0) = (
        sim.bodies[0].clone(),
        sim.bodies[1].clone(),
        sim.nodes.x0.clone(),
    );
    assert_eq!(sim.joints.insert_between(&[&b0, &b1], &x0, l, 1e-9), 32);
    let plane = |z: Real, out: Real| {
        sim.nodes_in(
            &fdem::mesh::Region::HalfSpace {
                point: Vec3::new(0.0, 0.0, z),
                normal: Vec3::new(0.0, 0.0, out),
            },
            None,
        )
    };
    let (bottom, top) = (plane(0.0, -1.0), plane(1.0, 1.0));
    let c = (e / 2500.0 as Real).sqrt();
    let t_load = 160.0 / c;
    let v = 2.0 * ft / e / t_load;
    sim.loads.prescribed.push(PrescribedVelocity {
        nodes: bottom.clone(),
        components: [None, None, Some(TimeFunction::Constant(0.0))],
    });
    sim.loads.prescribed.push(PrescribedVelocity {
        nodes: top.clone(),
        components: [
            None,
            None,
            Some(TimeFunction::table(vec![(0.0, 0.0), (5.0 / c, v)]).unwrap()),
        ],
    });
    let mut peak: Real = 0.0;
    let mut fragments = 1;
    while sim.time < 2.0 * t_load {
        sim.step().unwrap();
        peak = peak.max(top.iter().map(|&n| sim.nodes.reaction_sum(&[n]).z).sum());
        if !sim.break_events.is_empty() && sim.step.is_multiple_of(100) {
            fragments = fdem::fracture::fragments(&sim.tets.nodes, &sim.joints, sim.nodes.len())
                .into_iter()
                .max()
                .unwrap()
                + 1;
            if fragments == 2 {
                break;
            }
        }
    }
    assert!(
        (peak / ft - 1.0).abs() < 0.02,
        "peak {peak:e} vs f_t·A = {ft:e}"
    );
    assert_eq!(fragments, 2);
    assert!(
        sim.break_events
            .iter()
            .all(|b| (b.centroid.z - 0.5).abs() < 0.01),
        "cracks along the interface"
    );
}

/// An intact joint (D = 0 throughout) driven around a closed path of relative displacement:
/// close to σn1 = −2f_t, slide by s (x = 0.9 of the peak slip), close further to σn2 = −20f_t,
/// slide back, reopen. Below the peak the law is elastic at fixed damage (docs/theory/joints.md),
/// so a closed path returns exactly the work it took: the energy account closes.
///
/// Reference: the potential ψ(δn, δs) of the law. The pre-peak shear
/// τ = f_s·g(δs·(p_t/h)/(2f_s)), g(x) = 2x − x², depends on δn through the Mohr–Coulomb
/// strength f_s = c − σn·tanφ; the normal traction carries the matching term
/// −z·tanφ·(p_n/h)·(2f_s/k_t)·x³/3, so the traction field is ψ's gradient. Before that term
/// (found with tests/dome.rs) sliding out under σn1 and back under σn2 created
/// ΔW = A·k_t²·s³/12·(1/f_s1 − 1/f_s2) per cycle, 0.33 of the shear energy stored at s (the
/// closed form, reproduced to 1e-3), and a masonry dome with c = 2f_t never came to rest.
/// Tolerance: 1e-5 of the stored shear energy (measured 3.6e-7: the trapezoidal work over
/// 2 000 steps a leg).
#[test]
fn intact_joint_conserves_energy_on_a_closed_path_under_changing_compression() {
    let coh = law(Calibration::Exact);
    let t_dir = Vec3::new(1.0, -1.0, 0.0).normalize();
    let mut r = rig(coh.clone(), constant(Vec3::zeros()));
    r.sim.prepare().unwrap();
    let dt = r.sim.dt;
    let (kn, kt) = (coh.normal_penalty / r.size, coh.tangential_penalty / r.size);
    let dnp = coh.peak_opening(r.size);
    let (d1, d2) = (dnp, 10.0 * dnp); // σn1 = −2f_t, σn2 = −20f_t
    let fs = |d: Real| coh.cohesion + kn * d * coh.tan_friction;
    let (fs1, fs2) = (fs(d1), fs(d2));
    let s = 0.9 * coh.peak_slip(r.size, fs1); // x = 0.9 under σn1: below the peak throughout
    let steps = 2_000.0;
    let legs = [
        -r.n * d1,
        t_dir * s,
        -r.n * (d2 - d1),
        -t_dir * s,
        r.n * (d2 - d1),
        r.n * d1,
    ];
    let mut pts: [Vec<(Real, Real)>; 3] = Default::default();
    let mut t0 = 0.0;
    for leg in legs {
        let v = leg / (steps * dt);
        for k in 0..3 {
            pts[k].push((t0 + 1e-6 * dt, v[k]));
            pts[k].push((t0 + steps * dt, v[k]));
        }
        t0 += steps * dt;
    }
    for p in &mut pts {
        p.push((t0 + 1e-6 * dt, 0.0)); // then at rest
    }
    r.sim.loads.prescribed[1].components = pts.map(|p| Some(TimeFunction::table(p).unwrap()));
    r.sim.invalidate();
    while r.sim.time < t0 - 0.5 * dt {
        r.sim.step().unwrap();
    }
    for _ in 0..2 {
        r.sim.step().unwrap(); // a sample at rest, back at the start
    }
    assert!(r.sim.joints.state[0].iter().all(|p| p.damage == 0.0));
    assert!(r.opening().norm() < 1e-6 * s, "not back at the start");
    let created = r.sim.energy.balance_error();
    let stored = r.area * (kt * s * s / 2.0 - kt * kt * s.powi(3) / (12.0 * fs1));
    let without_coupling = r.area * kt * kt * s.powi(3) / 12.0 * (1.0 / fs1 - 1.0 / fs2);
    println!(
        "energy created over the cycle {created:.4e} J = {:.2e} of the shear energy stored at s (a law without the normal coupling term: {without_coupling:.4e} J)",
        created / stored
    );
    assert!(
        created.abs() < 1e-5 * stored,
        "created {created:.4e} J of {stored:.4e} J stored"
    );
}

/// A jointed bar (L × L/10 × L/10, 20 × 2 × 2 Kuhn cells, ν = 0, p = 10E) with
/// rate-dependent joints (`rate_effects: "fib2010"`), held at x = 0 and pulled at x = L so
/// that its strain rate is `rate` [1/s] once the ramp (5 wave transits) is over. The bar's
/// length is scaled with the rate (ρ = 25, c = 20 km/s, L = c·t_peak/40 with t_peak the time
/// to the dynamic strength) so that the peak comes after ~40 wave transits at any rate: the
/// stress is uniform and the test measures the law, not wave effects, in the same number of
/// steps.
fn rate_bar(rate: Real, rate_effects: bool) -> RateBar {
    rate_bar_held(rate, rate_effects, None)
}

/// [`rate_bar`], stopping the pulled end once the force reaches `hold_at`·f_t·A and holding it
/// for 3 times the loading time (the bar then stays at that load).
fn rate_bar_held(rate: Real, rate_effects: bool, hold_at: Option<Real>) -> RateBar {
    let (e, ft, rho) = (1e10, 1e7, 25.0);
    let t_peak = 1.3 * fdem::joints::law::dif_tension_fib2010(rate) * ft / e / rate;
    let c = (e / rho).sqrt();
    let l = c * t_peak / 40.0;
    let a = l / 10.0;
    let law_rate = if rate_effects {
        fdem::joints::law::RateEffects::Fib2010 { young: e }
    } else {
        fdem::joints::law::RateEffects::None
    };
    let (mut sim, right) = pulled_bar(l, (e, rho, ft, 10.0), law_rate, rate * l);
    sim.settings.energy_every = 50;
    let (mut peak, mut fragments) = (0.0 as Real, 1);
    let (mut t_start, mut t_at_peak) = (Real::NAN, 0.0);
    let mut t_end = 5.0 * l / c + 3.0 * t_peak;
    let mut held = false;
    while sim.time < t_end {
        sim.step().unwrap();
        let f: Real = right.iter().map(|&n| sim.nodes.reaction_sum(&[n]).x).sum();
        if t_start.is_nan() && f > 0.01 * ft * a * a {
            t_start = sim.time;
        }
        if !held && hold_at.is_some_and(|h| f > h * ft * a * a) {
            sim.loads.prescribed[1].components[0] = Some(TimeFunction::Constant(0.0));
            sim.invalidate();
            held = true;
            t_end = sim.time + 3.0 * (sim.time - t_start);
        }
        if f > peak {
            (peak, t_at_peak) = (f, sim.time);
        }
        if !sim.break_events.is_empty() && sim.step.is_multiple_of(200) {
            fragments = fdem::fracture::fragments(&sim.tets.nodes, &sim.joints, sim.nodes.len())
                .into_iter()
                .max()
                .unwrap()
                + 1;
            if fragments >= 2 {
                break;
            }
        }
    }
    RateBar {
        max_damage: sim
            .joints
            .state
            .iter()
            .flatten()
            .map(|p| p.damage)
            .fold(0.0, Real::max),
        broken: sim.break_events.len(),
        peak: peak / (ft * a * a),
        stress_rate_over_e: peak / (a * a) / e / (t_at_peak - t_start),
        fragments,
        balance: sim.energy.relative_balance_error(),
    }
}

struct RateBar {
    /// Largest damage of any joint point, and the number of broken joints, at the end.
    max_damage: Real,
    broken: usize,
    /// Peak force over f_t·A.
    peak: Real,
    /// The bar's stress rate up to its peak over E, σ_peak/(E·(t_peak − t₀)) [1/s].
    stress_rate_over_e: Real,
    fragments: u32,
    balance: Real,
}

/// Rate-dependent joints (fib Model Code 2010 §5.1.11.2, eq. 5.1-107/108): a jointed bar
/// pulled at a constant strain rate breaks at f_t·DIF_t(ε̇) within 3 %, ε̇ its stress rate
/// over E (what the joints read, [`fdem::joints::RateState`]; the nominal rate × E_eff/E) —
/// at 1 /s in the power-law branch (DIF ≈ 1.27), 30 and 150 /s in the cube-root one (1.7,
/// 2.9) — into two or three fragments, with the energy account closed to 2 % as for the
/// rate-independent bar (the stored energy the rising strengths add at fixed opening is
/// booked; measured 2.4e-3, 1.25e-2 with three fragments at 30 /s, 2.4e-3). Without rate effects the same
/// bar breaks at f_t at every rate (1 %). 3 %: the secant rate counts the loading from the
/// first 1 % of the strength, the bar's stress rate from its first 1 %; they differ by the
/// ramp and the joints' spread, ~5 % in rate, < 2 % in DIF (measured: −0.4…+1.2 %).
#[test]
fn rate_dependent_joints_break_at_the_fib2010_dynamic_strength() {
    use fdem::joints::law::dif_tension_fib2010;
    for rate in [1.0, 30.0, 150.0] {
        let r = rate_bar(rate, true);
        let dif = dif_tension_fib2010(r.stress_rate_over_e);
        let r0 = rate_bar(rate, false);
        eprintln!(
            "ε̇ = {rate} /s (σ̇/E = {:.3} /s): peak/(f_t·A) = {:.4}, DIF_t = {dif:.4}, {} fragments, balance {:.2e}; rate-independent {:.4}",
            r.stress_rate_over_e, r.peak, r.fragments, r.balance, r0.peak
        );
        assert!(
            (r.peak / dif - 1.0).abs() < 0.03,
            "ε̇ = {rate} /s: peak/(f_t·A) = {} vs DIF_t = {dif}",
            r.peak
        );
        assert!(
            (2..=3).contains(&r.fragments),
            "ε̇ = {rate} /s: {} fragments",
            r.fragments
        );
        assert!(
            r.balance.abs() < 0.02,
            "ε̇ = {rate} /s: balance {}",
            r.balance
        );
        assert!(
            (r0.peak - 1.0).abs() < 0.01,
            "rate-independent at ε̇ = {rate} /s: peak/(f_t·A) = {}",
            r0.peak
        );
    }
}

/// A rate-dependent jointed bar pulled at 30 /s to 1.5·f_t (below its dynamic strength
/// f_t·DIF_t ≈ 1.69·f_t) and then held for three times its loading time does not break: no
/// joint breaks, it stays in one piece and no point is damaged beyond D = 0.1, although its
/// secant loading rate falls by 4 and the factor the rate alone would give drops to ≈ 1.3
/// (a static joint at 1.5·f_t would break at once). The factors fall only as far as keeps the
/// tractions at 0.9 of the strengths (theory/joints.md, History). Small damage remains
/// possible: the bar's vibrations load one vertex of a joint more than the others (measured
/// D ≤ 0.05 on the most loaded vertices). Energy balance 2 % (measured −1.5e-2: while the
/// factors move with the vibrations each change is booked at the step's start, and the
/// account drifts by that much over the hold; not yet explained further).
#[test]
fn rate_dependent_joints_loaded_fast_and_held_do_not_break() {
    let r = rate_bar_held(30.0, true, Some(1.5));
    eprintln!(
        "held: peak {:.4}, max damage {:.4}, {} broken, {} fragments, balance {:.2e}",
        r.peak, r.max_damage, r.broken, r.fragments, r.balance
    );
    assert_eq!(r.broken, 0, "broken joints after the hold");
    assert_eq!(r.fragments, 1);
    assert!(r.max_damage < 0.1, "largest damage {}", r.max_damage);
    assert!(r.peak < 1.6, "held near 1.5·f_t·A, peak {}", r.peak);
    assert!(r.balance.abs() < 0.02, "balance {}", r.balance);
}

/// A joint whose faces no longer face each other is retired once (broken first if it was
/// not): what its springs hold is booked as dissipated, it applies no force, and later calls
/// skip it. Reference: the
/// energy account — a broken Munjiza joint closed by δ (no slip against its anchors) stores
/// ½·(p/h)·δ²·A, and retiring it must move exactly that into the dissipation (1e-9: the same
/// arithmetic in a different order). Cases: slid 3h (past the 2h limit), faces folded onto
/// each other (mid-surface collapsed, normals opposed), broken or intact; and a control slid
/// 1.5h that stays in force. (The laminated-glass run booked 8.95 J of friction that no force
/// paid for, in 450 steps, from two folded joints kept in force.)
#[test]
fn broken_joint_whose_faces_parted_is_retired_with_its_energy_booked() {
    use fdem::joints::add_joint_forces;
    let coh = law(Calibration::Exact);
    let t_dir = Vec3::new(1.0, -1.0, 0.0).normalize();
    let retire_with = |slide: Real, fold: bool, broken: bool| {
        let mut r = rig(coh.clone(), constant(Vec3::zeros()));
        r.sim.prepare().unwrap();
        let dc = 3.0 * coh.peak_opening(r.size);
        let shift = -r.n * dc + t_dir * (slide * r.size);
        for &i in &r.b_nodes {
            r.sim.nodes.x[i as usize] += shift;
        }
        let faces = r.sim.joints.faces[0];
        if fold {
            // Swap where two of B's face nodes sit: face B turns over onto face A.
            let [b1, b2] = [faces[1][1] as usize, faces[1][2] as usize];
            r.sim.nodes.x.swap(b1, b2);
        }
        let x = r.sim.nodes.x.clone();
        let (_, _, pts) = fdem::joints::joint_kinematics(&faces, &x);
        if broken {
            for (p, (_, ds, dir)) in pts.iter().enumerate() {
                r.sim.joints.state[0][p].damage = 1.0;
                r.sim.joints.set_anchor_global(0, p, &x, dir * *ds);
            }
            r.sim.joints.broken[0] = true;
        }
        let stored = r.sim.joints.stored_energy(0, &x);
        let zero = |r: &mut Rig| r.sim.nodes.f.iter_mut().for_each(|f| *f = Vec3::zeros());
        zero(&mut r);
        // Intact joints are called without energy, as most steps are: the fast path too
        // must hand a collapsed joint to the parted-faces check.
        let first = add_joint_forces(&mut r.sim.joints, &mut r.sim.nodes, 0.0, broken);
        let force: Real = r.sim.nodes.f.iter().map(|f| f.norm()).sum();
        zero(&mut r);
        let second = add_joint_forces(&mut r.sim.joints, &mut r.sim.nodes, 0.0, true);
        let force2: Real = r.sim.nodes.f.iter().map(|f| f.norm()).sum();
        let closed = 0.5 * coh.normal_penalty / r.size * dc * dc * r.area;
        let failed = r.sim.joints.state[0].iter().all(|p| p.damage == 1.0);
        (
            (first, second, force, force2, stored, closed),
            (r.sim.joints.handed_over[0], failed),
        )
    };
    let retire = |slide: Real, fold: bool| {
        let (r, (handed, _)) = retire_with(slide, fold, true);
        (r.0, r.1, r.2, r.3, r.4, r.5, handed)
    };

    let (first, second, force, force2, stored, closed, handed) = retire(3.0, false);
    assert!(
        (stored - closed).abs() < 1e-9 * closed,
        "stored {stored:e} vs ½(p/h)δ²A = {closed:e}"
    );
    assert_eq!((first.parted, handed), (1, true), "slid 3h: retired");
    assert!(
        (first.dissipated - closed).abs() < 1e-9 * closed,
        "booked {:e} vs stored {closed:e}",
        first.dissipated
    );
    assert_eq!(
        (force, first.energy),
        (0.0, 0.0),
        "a retired joint acts no more"
    );
    assert_eq!(
        (second.parted, second.dissipated, second.energy, force2),
        (0, 0.0, 0.0, 0.0),
        "and is skipped afterwards"
    );

    let (first, second, force, _, stored, _, handed) = retire(0.0, true);
    assert_eq!((first.parted, handed), (1, true), "folded: retired");
    assert!(
        (first.dissipated - stored).abs() <= 1e-9 * stored.abs().max(closed),
        "booked {:e} vs stored {stored:e}",
        first.dissipated
    );
    assert_eq!((force, second.parted, second.dissipated), (0.0, 0, 0.0));

    // Not yet broken (a fold about one node leaves that node's point undamaged: the
    // laminated-glass joints had two points at D = 1 and the hinge's at 0.58): it breaks.
    let ((first, second, force, _, stored, closed), (handed, failed)) =
        retire_with(0.0, true, false);
    assert_eq!(
        (first.parted, first.newly_failed, handed, failed),
        (1, 1, true, true),
        "an intact folded joint breaks and is retired"
    );
    assert!(
        (first.dissipated - stored).abs() <= 1e-9 * stored.abs().max(closed),
        "booked {:e} vs stored {stored:e}",
        first.dissipated
    );
    assert_eq!((force, second.parted, second.dissipated), (0.0, 0, 0.0));

    let (first, second, force, force2, stored, closed, handed) = retire(1.5, false);
    assert_eq!(
        (first.parted, handed),
        (0, false),
        "slid 1.5h: still in force"
    );
    assert!(force > 0.0 && force2 > 0.0, "it pushes the faces apart");
    assert!((first.energy - stored).abs() < 1e-9 * closed);
    assert_eq!(second.parted, 0);
}

/// A law with dilatancy ψ = 30° up to `u_max`.
fn dilatant(u_max: Real) -> Cohesive {
    Cohesive {
        dilatancy: fdem::joints::law::Dilatancy {
            tan_angle: 30f64.to_radians().tan(),
            max_opening: u_max,
        },
        ..law(Calibration::Exact)
    }
}

/// One broken point sliding under a constant compression σ₀ (the opening prescribed so that
/// the gap's penalty gives σ₀: δn = u_d(|q|) − σ₀/k_n). Reference: the dilatancy's potential
/// (`Dilatancy` in src/joints/law.rs; Coulomb slip with dilation as in UDEC): the
/// point slides at τ = (μ + u_d'(|q|))σ₀, exact at every step (the return mapping is exact at
/// constant σ, with u_d' at the step's start), falling from (μ + tan ψ)σ₀ to μσ₀ once it
/// has slid q_c = 2u_max/tan ψ and opened u_max; it dissipates μσ₀ per unit of plastic slip
/// (1e-9); the work the faces did, ∫τ ds + ∫σ dδn (trapezoid), equals the stored change plus
/// the dissipation within tan ψ·σ₀·Δs, the trapezoid's error on a traction that falls by
/// tan ψ·σ₀ over the ride (and halves with Δs).
#[test]
fn dilatant_broken_point_slides_at_mu_plus_its_dilatancy_rate_until_worn() {
    use fdem::joints::law::{PointKinematics, PointState};
    let u_max = 20e-6;
    let c = dilatant(u_max);
    let tan_psi = c.dilatancy.tan_angle;
    let (h, sigma0) = (0.05, 2e6);
    let (kn, kt) = (c.normal_penalty / h, c.tangential_penalty / h);
    let mu = c.residual_friction;
    let slide = |n: usize| {
        let mut s = PointState {
            damage: 1.0,
            ..Default::default()
        };
        let slip_end = 1.5 * c.dilatancy.wear_slip();
        let (mut work, mut dissipated) = (0.0, 0.0);
        let (mut prev, mut prev_dn, mut prev_s) = (None::<(Real, Real)>, 0.0, 0.0);
        let mut first_energy = None;
        let (mut riding, mut worn) = (0, 0);
        for i in 0..=n {
            let slip = slip_end * i as Real / n as Real;
            let (u, rate) = c.dilatancy.opening(s.offset.norm());
            let dn = u - sigma0 / kn;
            let k = PointKinematics {
                opening: dn,
                slip,
                slip_vector: Vec3::new(slip, 0.0, 0.0),
                normal: Vec3::z(),
                size: h,
            };
            let was_sliding = s.slid > 0.0;
            let t = c.evaluate(&k, &mut s);
            assert!(
                (t.normal + sigma0).abs() < 1e-9 * sigma0,
                "σ = {}",
                t.normal
            );
            let tau = t.tangential.x;
            if was_sliding {
                let expected = (mu + rate) * sigma0;
                assert!(
                    (tau - expected).abs() < 1e-9 * sigma0,
                    "τ {tau:e} vs {expected:e}"
                );
                if rate > 0.0 {
                    riding += 1;
                } else {
                    worn += 1;
                }
            }
            if let Some((t0, s0)) = prev {
                work += 0.5 * (tau + t0) * (slip - prev_s) + 0.5 * (t.normal + s0) * (dn - prev_dn);
            }
            dissipated += t.dissipated;
            first_energy.get_or_insert(t.energy);
            (prev, prev_dn, prev_s) = (Some((tau, t.normal)), dn, slip);
            if i == n {
                let stored = t.energy - first_energy.unwrap();
                let plastic_slip = slip - tau / kt;
                let expected = mu * sigma0 * plastic_slip;
                assert!(
                    (dissipated - expected).abs() < 1e-9 * expected,
                    "dissipated {dissipated:e} vs μσ₀·slip {expected:e}"
                );
                assert!((s.slid - plastic_slip).abs() < 1e-9 * plastic_slip);
                assert!((dn - (u_max - sigma0 / kn)).abs() < 1e-15, "opened {dn:e}");
                assert!(
                    riding > n / 2 && worn > n / 10,
                    "{riding} riding, {worn} worn"
                );
                return (
                    work - stored - dissipated,
                    tan_psi * sigma0 * slip_end / n as Real,
                );
            }
        }
        unreachable!()
    };
    let (err, bound) = slide(20_000);
    assert!(err.abs() < bound, "balance {err:e} vs bound {bound:e}");
    let (err2, _) = slide(40_000);
    assert!(
        (err2 / err - 0.5).abs() < 0.05,
        "the error halves with the step: {err:e} → {err2:e}"
    );
}

/// One broken point under a constant compression σ₀ slid forward to 0.75 q_c (riding up its
/// asperities), back past where its faces mated to −0.25 q_c, and forward to 0 again.
/// Reference: the dilatancy's potential u_d(|q|) (`Dilatancy` in src/joints/law.rs): the
/// anchor's force X = k_t·e − σ₀u_d'·q̂ slides at |X| = μσ₀, so every sliding step has
/// τ = μσ₀·sign(Δq) + u_d'(|q|)σ₀·sign(q) exactly (1e-9: the return mapping is exact at
/// constant σ₀ with u_d' at the step's start); the offset q never jumps across the seat (it
/// stops there, where the crack is closed: u_d = 0, and the corner holds it until
/// k_t|e| > (μ + tan ψ)σ₀); it dissipates μσ₀ per unit of plastic slip both ways (1e-9); the
/// work the faces did equals the stored change plus the dissipation within a step's slip
/// times the largest traction at each corner of the path (and 1e-4 of the dissipation;
/// 3e-5 measured). A path-driven dilatancy kept the crack open by
/// u_d(Σ|Δq|) on the way back instead: the wedged cracks that held the drop-weight beam's
/// residual sag.
#[test]
fn dilatant_broken_point_slid_back_closes_at_its_seat() {
    use fdem::joints::law::{PointKinematics, PointState};
    let u_max = 20e-6;
    let c = dilatant(u_max);
    let (tan_psi, qc) = (c.dilatancy.tan_angle, c.dilatancy.wear_slip());
    let (h, sigma0) = (0.05, 2e6);
    let kn = c.normal_penalty / h;
    let mu = c.residual_friction;
    assert!(
        tan_psi > mu,
        "the asperities push a point back to its seat: tan ψ > μ"
    );
    // Slip at step i of n along the path 0 → 0.75 q_c → −0.25 q_c → 0.
    let path = |i: usize, n: usize| {
        let u = 2.0 * i as Real / n as Real;
        qc * if u < 0.75 {
            u
        } else if u < 1.75 {
            1.5 - u
        } else {
            u - 2.0
        }
    };
    let run = |n: usize| {
        let mut s = PointState {
            damage: 1.0,
            ..Default::default()
        };
        let (mut work, mut dissipated) = (0.0, 0.0);
        let (mut prev, mut first_energy, mut seated, mut checked) = (None, None, false, 0);
        for i in 0..=n {
            let slip = path(i, n);
            let q_old = s.offset.x;
            let (u, rate) = c.dilatancy.opening(q_old.abs());
            let dn = u - sigma0 / kn;
            let k = PointKinematics {
                opening: dn,
                slip: slip.abs(),
                slip_vector: Vec3::new(slip, 0.0, 0.0),
                normal: Vec3::z(),
                size: h,
            };
            let was_closed = !s.anchor.x.is_nan() && i > 0;
            let t = c.evaluate(&k, &mut s);
            let (tau, q) = (t.tangential.x, s.offset.x);
            assert!((t.normal + sigma0).abs() < 1e-9 * sigma0);
            assert!(
                q * q_old >= 0.0,
                "q jumped across the seat: {q_old:e} → {q:e}"
            );
            if q == 0.0 && q_old != 0.0 {
                seated = true;
            }
            let dq = q - q_old;
            if was_closed && dq != 0.0 && q != 0.0 {
                let expected = if q_old == 0.0 {
                    dq.signum() * (mu + tan_psi) * sigma0
                } else {
                    mu * sigma0 * dq.signum() + rate * sigma0 * q_old.signum()
                };
                assert!(
                    (tau - expected).abs() < 1e-9 * sigma0,
                    "step {i}: q {q_old:e} → {q:e}: τ {tau:e} vs {expected:e}"
                );
                checked += 1;
            }
            if let Some((t0, s0, slip0, dn0)) = prev {
                work += 0.5 * (tau + t0) * (slip - slip0) + 0.5 * (t.normal + s0) * (dn - dn0);
            }
            dissipated += t.dissipated;
            first_energy.get_or_insert(t.energy);
            prev = Some((tau, t.normal, slip, dn));
            if i == n {
                let expected = mu * sigma0 * s.slid;
                assert!(
                    (dissipated - expected).abs() < 1e-9 * expected,
                    "dissipated {dissipated:e} vs μσ₀·Σ|Δq| {expected:e}"
                );
                assert!(
                    s.slid > 1.9 * qc,
                    "slid {:e}: forward, back and forward",
                    s.slid
                );
                assert!(seated, "the point came back to its seat");
                assert!(checked > n / 2, "{checked} sliding steps checked of {n}");
                // Each of the path's six corners (the start, two reversals, two landings
                // on the seat and one departure from it) happens within a step or two (the
                // spring's elastic range is about a step's slip here) and may miss up to
                // the largest traction times a step's slip.
                return (
                    work - (t.energy - first_energy.unwrap()) - dissipated,
                    6.0 * (mu + tan_psi) * sigma0 * 2.0 * qc / n as Real,
                    expected,
                );
            }
        }
        unreachable!()
    };
    for n in [20_000, 40_000] {
        let (err, bound, dissipated) = run(n);
        assert!(
            err.abs() < bound && err.abs() < 1e-4 * dissipated,
            "{n} steps: balance {err:e} vs bound {bound:e} ({dissipated:e} dissipated)"
        );
    }
}

/// The same joint between two tets in the full pipeline with contact on: broken by opening,
/// closed to an overlap δc and slid under fixed normal displacement (infinitely stiff
/// confinement), it pushes the faces apart harder as it dilates: a quarter into the slide
/// τ = (μ + u_d'(|q|))|σ|, at its end (worn after two thirds) τ = μ|σ| with
/// σ = −k_n(δc + u_max) (1 %); pulled open less than
/// its reach (2 u_max past its dilation) it keeps its faces from contact (not handed over),
/// pulled further it hands them over. The energy account closes through it (1e-3 of the
/// dissipation: the explicit steps).
#[test]
fn dilatant_broken_joint_clamps_its_faces_and_holds_them_from_contact_within_reach() {
    use fdem::contact_interaction::{ContactRule, PotentialContact};
    let coh = law(Calibration::Exact);
    let t_dir = Vec3::new(1.0, -1.0, 0.0).normalize();
    let probe = rig(coh.clone(), constant(Vec3::zeros()));
    let (dnp, (dnt, _)) = (
        coh.peak_opening(probe.size),
        coh.softening_lengths(coh.cohesion),
    );
    let dc = 3.0 * dnp;
    let open = 1.2 * (dnp + dnt);
    // Opened to break it, it stays within reach (2 u_max).
    let u_max = open;
    let c = dilatant(u_max);
    let mut r = rig(c.clone(), constant(Vec3::zeros()));
    r.sim
        .contact
        .laws
        .rules
        .push(ContactRule::from(PotentialContact::default()));
    r.sim.prepare().unwrap();
    let dt = r.sim.dt;
    let slide = 1.5 * c.dilatancy.wear_slip();
    let dilated = u_max; // reached by the end of the slide
                         // Phases: open, close to −δc, slide, open to δc + u_max past the dilation (within reach),
                         // open 3 u_max further (beyond).
    let phases = [
        (20_000.0, r.n * (open / (20_000.0 * dt))),
        (2_000.0, -r.n * ((open + dc) / (2_000.0 * dt))),
        (20_000.0, t_dir * (slide / (20_000.0 * dt))),
        (2_000.0, r.n * ((dc + dilated + u_max) / (2_000.0 * dt))),
        (2_000.0, r.n * ((3.0 * u_max) / (2_000.0 * dt))),
    ];
    let ends = r.drive_in_phases(&phases);
    let (mut riding, mut end_of_slide, mut held_within_reach) = (None, None, true);
    let quarter = ends[1] + 0.25 * (ends[2] - ends[1]);
    while r.sim.time < ends[4] - 0.5 * dt {
        r.sim.step().unwrap();
        if riding.is_none() && r.sim.time >= quarter {
            let rate = c.dilatancy.opening(r.sim.joints.offset[0][0].norm()).1;
            riding = Some((r.traction(t_dir), rate));
        }
        if end_of_slide.is_none() && r.sim.time >= ends[2] - 0.5 * dt {
            end_of_slide = Some(r.traction(t_dir));
        }
        if r.sim.time > ends[2] && r.sim.time < ends[3] {
            held_within_reach &= !r.sim.joints.handed_over[0];
        }
    }
    let (sigma, tau) = end_of_slide.unwrap();
    let kn = c.normal_penalty / r.size;
    let expected_sigma = -kn * (dc + u_max);
    assert!(
        (sigma - expected_sigma).abs() < 0.01 * expected_sigma.abs(),
        "σ {sigma:e} vs k_n(δc + u_max) {expected_sigma:e}"
    );
    let mu = c.residual_friction;
    assert!(
        (tau / -sigma - mu).abs() < 0.01 * mu,
        "flat: τ/|σ| = {}",
        tau / -sigma
    );
    let ((sigma_q, tau_q), rate) = riding.unwrap();
    assert!(rate > 0.5 * c.dilatancy.tan_angle, "u_d' = {rate}");
    let ride = mu + rate;
    assert!(
        (tau_q / -sigma_q - ride).abs() < 0.01 * ride,
        "riding: τ/|σ| = {} vs μ + tan ψ = {ride}",
        tau_q / -sigma_q
    );
    assert!(
        held_within_reach,
        "handed over within the asperities' reach"
    );
    r.sim.sample_next = true;
    r.sim.step().unwrap();
    assert!(
        r.sim.joints.handed_over[0],
        "not handed over beyond its reach"
    );
    let en = r.sim.energy;
    assert!(
        en.balance_error().abs() < 1e-3 * en.fracture,
        "balance {:e} J vs dissipated {:e} J",
        en.balance_error(),
        en.fracture
    );
}

/// Dilatancy needs both its angle and its opening: one without the other is an error naming
/// both; both give tan ψ and u_max; ψ must be below 45°.
#[test]
fn dilatancy_angle_and_opening_go_together() {
    use fdem::params::Param;
    let make = |angle: Option<Real>, opening: Option<Real>| {
        let given = move |p: &Param| -> Result<Option<Real>, String> {
            Ok(match p.name {
                "tensile_strength" => Some(1e6),
                "cohesion" => Some(2e6),
                "g_i" => Some(100.0),
                "g_ii" => Some(400.0),
                "dilatancy_angle" => angle,
                "dilatancy_opening" => opening,
                _ => None,
            })
        };
        Cohesive::from_params(Softening::Munjiza, Calibration::Exact, &given)
    };
    let e = make(Some(30.0), None).unwrap_err();
    assert!(
        e.contains("dilatancy_angle") && e.contains("dilatancy_opening"),
        "{e}"
    );
    assert!(make(None, Some(1e-3)).is_err());
    let c = make(Some(40.0), Some(1e-3)).unwrap().dilatancy;
    assert!((c.tan_angle - 40f64.to_radians().tan()).abs() < 1e-12 && c.max_opening == 1e-3);
    // ψ < 45°: steeper, a sliding point's stiffness passes twice the normal penalty.
    assert!(make(Some(45.0), Some(1e-3)).is_err());
    assert!(!make(None, None).unwrap().dilatancy.is_active());
}

/// A block (1 kg per m² of joint) on a broken dilatant joint, pressed down by a preload and a
/// confining spring and dragged at 8 m/s through a soft spring, integrated with the engine's
/// central differences (half-step velocities) at 0.8 and 0.4 of the critical step of its
/// stiffest spring ([`fdem::joints::JointLaw::stiffest_penalty`]): it slides, rides up
/// (opening ≈ u_max) and wears flat. Reference: energy conservation: drag work = stored +
/// kinetic + dissipated, to 1e-5 of the work, the error halving with the step (the step's
/// first-order lag of the dilatancy).
#[test]
fn dilatant_joint_in_explicit_dynamics_conserves_energy() {
    use fdem::joints::law::{PointKinematics, PointState};
    let u_max = 3e-3;
    let c = dilatant(u_max);
    let h = 0.05;
    let (kn, kt) = (c.normal_penalty / h, c.tangential_penalty / h);
    let (m, kc, kd, v, pre) = (1.0, 0.05 * kn, 0.05 * kt, 8.0, 1e6);
    let stiffest = JointLaw::Cohesive(c.clone()).stiffest_penalty() / h;
    let run = |safety: Real| {
        let dt = safety * 2.0 / ((stiffest + kc.max(kd)) / m).sqrt();
        let mut s = PointState {
            damage: 1.0,
            ..Default::default()
        };
        let (mut x, mut y, mut vx, mut vy) = (0.0, -pre / kn, 0.0, 0.0);
        let force = |x: Real, y: Real, s: &mut PointState, t: Real| {
            let k = PointKinematics {
                opening: y,
                slip: x.abs(),
                slip_vector: Vec3::new(x, 0.0, 0.0),
                normal: Vec3::z(),
                size: h,
            };
            let tr = c.evaluate(&k, s);
            (
                -tr.tangential.x + kd * (v * t - x),
                -tr.normal - kc * y - pre,
                tr,
            )
        };
        let (mut fx, mut fy, tr0) = force(x, y, &mut s, 0.0);
        let e0 = tr0.energy + 0.5 * kc * y * y + pre * y;
        let (mut work, mut dissipated, mut energy) = (0.0, 0.0, e0);
        let n = (5e-3 / dt) as usize;
        for i in 0..n {
            let t = i as Real * dt;
            vx += 0.5 * dt * fx / m;
            vy += 0.5 * dt * fy / m;
            let pulled_before = kd * (v * t - x);
            x += dt * vx;
            y += dt * vy;
            let (nfx, nfy, tr) = force(x, y, &mut s, t + dt);
            work += 0.5 * (pulled_before + kd * (v * (t + dt) - x)) * v * dt;
            dissipated += tr.dissipated;
            (fx, fy) = (nfx, nfy);
            vx += 0.5 * dt * fx / m;
            vy += 0.5 * dt * fy / m;
            energy = tr.energy
                + 0.5 * kc * y * y
                + pre * y
                + 0.5 * kd * (v * (t + dt) - x).powi(2)
                + 0.5 * m * (vx * vx + vy * vy);
        }
        assert!(s.slid > c.dilatancy.wear_slip(), "slid {:e}", s.slid);
        assert!(y > 0.9 * u_max, "opened {y:e}");
        (energy - e0 + dissipated - work) / work
    };
    let (coarse, fine) = (run(0.8), run(0.4));
    assert!(coarse.abs() < 1e-5, "balance {coarse:e} of the work");
    assert!(
        (fine / coarse - 0.5).abs() < 0.1,
        "the error halves with the step: {coarse:e} → {fine:e}"
    );
}

/// Objectivity of the anchors (reference: a rigid rotation of both faces changes no jump in
/// the joint's own axes, so it must change no traction in them and dissipate nothing). The
/// joint is sheared under compression to 3 peak slips, so its points soften with a plastic
/// slip s_p ≈ 2 δsp; then the whole pair is spun about the joint normal by 30° and tilted
/// by 30° about an in-plane axis, in 1° increments, each evaluated by stage 2. The force on B
/// must turn with the pair (1e-7 of its size: round-off of the rotated positions against the
/// springs' small stretch) and no energy be
/// dissipated (1e-9 of what the shearing dissipated). Anchors kept in global coordinates and
/// only projected on the turning plane gave |e| = δsp·θ·(|s_p|/δsp) of spurious stretch: at
/// 30° the force turned by a different angle and grew, and the spin itself dissipated
/// (plastic return). Then the same after the joint breaks: the friction anchor turns too.
#[test]
fn anchors_turn_with_the_joint() {
    use fdem::joints::add_joint_forces;
    use nalgebra::{Rotation3, Unit};
    let coh = law(Calibration::Exact);
    for broken in [false, true] {
        let mut r = rig(coh.clone(), constant(Vec3::zeros()));
        r.sim.prepare().unwrap();
        let t_dir = Vec3::new(1.0, -1.0, 0.0).normalize();
        // Compression: σ ≈ −0.5 f_t, to give friction and a Mohr–Coulomb term.
        let squeeze = 0.5 * coh.tensile_strength / (coh.normal_penalty / r.size);
        let f_s = coh.cohesion + 0.5 * coh.tensile_strength * coh.tan_friction;
        let dsp = coh.peak_slip(r.size, f_s);
        if broken {
            // Broken beforehand (as a fracture criterion breaks it): friction from the start.
            r.sim.joints.state[0]
                .iter_mut()
                .for_each(|p| p.damage = 1.0);
            r.sim.joints.last_energy[0] = [0.0; 3];
            r.sim.joints.broken[0] = true;
        }
        let target = 3.0;
        let b_nodes = r.b_nodes.clone();
        let x0 = r.sim.nodes.x.clone();
        let steps = 400;
        let mut shear_dissipated = 0.0;
        for k in 1..=steps {
            let slip = target * dsp * k as Real / steps as Real;
            for &i in &b_nodes {
                r.sim.nodes.x[i as usize] = x0[i as usize] - r.n * squeeze + t_dir * slip;
            }
            r.sim.nodes.f.iter_mut().for_each(|f| *f = Vec3::zeros());
            shear_dissipated +=
                add_joint_forces(&mut r.sim.joints, &mut r.sim.nodes, 0.0, true).dissipated;
        }
        let d = r.sim.joints.state[0].map(|p| p.damage);
        if broken {
            assert!(d.iter().all(|&d| d >= 1.0), "not broken: D = {d:?}");
        } else {
            assert!(
                d.iter().all(|&d| d > 0.0 && d < 1.0),
                "not softening: D = {d:?}"
            );
        }
        let force_on_b =
            |r: &Rig| -> Vec3 { b_nodes.iter().map(|&i| r.sim.nodes.f[i as usize]).sum() };
        let f0 = force_on_b(&r);
        assert!(f0.norm() > 0.0);
        let centre: Vec3 = r.sim.joints.faces[0][0]
            .iter()
            .map(|&i| r.sim.nodes.x[i as usize])
            .sum::<Vec3>()
            / 3.0;
        let x_sheared = r.sim.nodes.x.clone();
        for axis in [r.n, t_dir] {
            // Start each rotation from the sheared state (the spin, then the tilt).
            let mut rs = rig(coh.clone(), constant(Vec3::zeros()));
            rs.sim.prepare().unwrap();
            rs.sim.joints = r.sim.joints.clone();
            let mut rotated_dissipation = 0.0;
            let mut f = Vec3::zeros();
            for deg in 1..=30 {
                let rot = Rotation3::from_axis_angle(
                    &Unit::new_normalize(axis),
                    (deg as Real).to_radians(),
                );
                for (x, x_s) in rs.sim.nodes.x.iter_mut().zip(&x_sheared) {
                    *x = centre + rot * (x_s - centre);
                }
                rs.sim.nodes.f.iter_mut().for_each(|f| *f = Vec3::zeros());
                rotated_dissipation +=
                    add_joint_forces(&mut rs.sim.joints, &mut rs.sim.nodes, 0.0, true).dissipated;
                f = force_on_b(&rs);
                let want = rot * f0;
                // Round-off: positions of order 1 m carry 1e-16 m, against a friction
                // spring stretched by μ|σ|h/p_t = 2.5e-8 m (broken) or δsp (softening).
                assert!(
                    (f - want).norm() <= 1e-7 * f0.norm(),
                    "broken {broken}, axis {axis:?}, {deg}°: force {f:?}, the sheared force turned {want:?}"
                );
            }
            assert!(
                rotated_dissipation.abs() <= 1e-9 * shear_dissipated.abs(),
                "broken {broken}, axis {axis:?}: the rotation dissipated {rotated_dissipation:e} J (shearing {shear_dissipated:e} J)"
            );
            assert!(f.norm() > 0.0);
        }
    }
}

/// Sampling the energy is observation, not physics: the same jointed bar pulled apart runs
/// bit for bit the same steps whether energies are sampled every step or every 37th. Stage 2
/// took its fast path for intact joints only on unsampled steps, and the general path agrees
/// with it to rounding, not to the bit: the quick drop-weight beam ended 0.07 mm apart
/// (19.435 against 19.505 mm) between `energy_every` 100 and 1. Reference: exact equality of
/// every node's position and velocity after the bar has broken.
#[test]
fn energy_sampling_does_not_change_the_motion() {
    let run = |every: u64| {
        let (l, e, ft) = (1.0, 1e10, 1e6);
        let c = (e / 2500.0 as Real).sqrt();
        let t_load = 4.0 * l / c;
        let v = 2.0 * ft / e * l / t_load;
        let (mut sim, _) = pulled_bar(
            l,
            (e, 2500.0, ft, 10.0),
            fdem::joints::law::RateEffects::None,
            v,
        );
        sim.settings.energy_every = every;
        while sim.time < 2.0 * t_load {
            sim.step().unwrap();
        }
        assert!(!sim.break_events.is_empty(), "the bar must break");
        (
            sim.nodes.x.clone(),
            sim.nodes.v.clone(),
            sim.break_events.len(),
        )
    };
    let (x1, v1, b1) = run(1);
    let (x37, v37, b37) = run(37);
    assert_eq!(b1, b37);
    assert!(x1 == x37 && v1 == v37, "positions or velocities differ");
}
