//! Mesh generators against geometry: volumes against analytic values (within 1 % at the
//! default sizes of docs/generators.md, O(h²) under refinement), no inverted or flat tets,
//! a minimum dihedral angle bound, named sets lying on their surfaces, block and course
//! counts, and coincident faces between neighbouring masonry blocks (mortar joints found by
//! `insert_between`, one per shared triangle).

mod common;

use fdem::joints::JointLaw;
use fdem::material::{Formulation, Material};
use fdem::math::{Real, Vec3};
use fdem::mesh::masonry::{self, Arch, Assembly, CloisterVault, Dome, ProfileOn, Ribs, Wall};
use fdem::mesh::solids::{self, NotchedBeam};
use fdem::mesh::{Mesh, TET_FACES};
use fdem::{Layout, Simulation};
use std::f64::consts::PI;

/// Default cases (the table of docs/generators.md).
fn disc() -> Mesh {
    solids::cylinder(0.05, 0.025, 0.01).unwrap()
}
fn cylinder() -> Mesh {
    solids::cylinder(0.5, 2.0, 0.1).unwrap()
}
fn sphere() -> Mesh {
    solids::sphere(1.0, 0.125).unwrap()
}
fn tube() -> Mesh {
    solids::hollow_cylinder(0.5, 1.0, 1.0, 0.1).unwrap()
}
const BEAM: NotchedBeam = NotchedBeam {
    length: 0.5,
    height: 0.1,
    width: 0.05,
    notch_depth: 0.03,
    notch_width: 0.004,
    span: 0.4,
};
fn beam() -> Mesh {
    solids::notched_beam(&BEAM, 0.01).unwrap()
}
const ARCH: Arch = Arch {
    radius: 2.0,
    thickness: 0.3,
    depth: 0.5,
    voussoirs: 15,
    span_angle: 180.0,
};
const WALL: Wall = Wall {
    courses: 6,
    bricks_per_course: 4,
    brick: [0.24, 0.07, 0.115],
    head_gap: 0.0,
    bed_gap: 0.0,
};
const DOME: Dome = Dome {
    radius: 5.0,
    thickness: 0.4,
    courses: 8,
    blocks_per_course: 24,
    oculus: 10.0,
    base: 90.0,
};

fn arch_volume(a: &Arch) -> Real {
    0.5 * a.span_angle.to_radians()
        * ((a.radius + a.thickness).powi(2) - a.radius.powi(2))
        * a.depth
}
fn dome_volume(d: &Dome) -> Real {
    2.0 * PI / 3.0
        * ((d.radius + d.thickness).powi(3) - d.radius.powi(3))
        * (d.oculus.to_radians().cos() - d.base.to_radians().cos())
}

fn rel(v: Real, exact: Real) -> Real {
    (v - exact) / exact
}

fn assert_valid(name: &str, m: &Mesh, min_dihedral: Real) {
    let bad = m.check();
    assert!(
        bad.is_empty(),
        "{name}: {} bad tets, first {}",
        bad.len(),
        bad[0]
    );
    let q = m.quality().unwrap();
    assert!(
        q.min_dihedral_deg >= min_dihedral,
        "{name}: min dihedral {:.2}° < {min_dihedral}°",
        q.min_dihedral_deg
    );
}

/// Every named face set is non-empty and all its vertices satisfy `on`.
fn assert_faces_on(m: &Mesh, set: &str, on: impl Fn(&Vec3) -> bool) {
    let faces = m
        .sets
        .faces
        .get(set)
        .unwrap_or_else(|| panic!("no face set '{set}'"));
    assert!(!faces.is_empty(), "face set '{set}' is empty");
    for &(t, l) in faces {
        for c in TET_FACES[l as usize] {
            let p = m.nodes[m.tets[t as usize][c] as usize];
            assert!(on(&p), "'{set}': face vertex {p:?} is off the surface");
        }
    }
    assert!(!m.sets.nodes[set].is_empty());
}

/// Insert joints between all blocks; returns how many.
fn joints_between(a: &Assembly) -> usize {
    let mut sim = Simulation::new();
    let mat =
        sim.add_material(Material::new(Formulation::SmallStrain, 2000.0, 1e9, 0.2, 0.0).unwrap());
    for (i, b) in a.blocks.iter().enumerate() {
        sim.add_body(&format!("block_{i}"), &b.mesh, mat, Layout::Continuous)
            .unwrap();
    }
    let law = sim.joints.add_law(JointLaw::Tied {
        normal_penalty: 1e10,
        tangential_penalty: 1e10,
    });
    let tol = sim.length_tolerance();
    let refs: Vec<&fdem::state::Body> = sim.bodies.iter().collect();
    let x0 = sim.nodes.x0.clone();
    let mut joints = sim.joints.clone();
    joints.insert_between(&refs, &x0, law, tol)
}

#[test]
fn quality_table() {
    // Printed with --nocapture: the numbers of docs/generators.md.
    let mut rows: Vec<(String, Real, Real, usize, Real)> = Vec::new();
    let mut row = |name: &str, m: &Mesh, exact: Real| {
        let q = m.quality().unwrap();
        rows.push((
            name.into(),
            q.min_dihedral_deg,
            q.max_aspect_ratio,
            m.tets.len(),
            rel(m.volume(), exact),
        ));
    };
    row("disc", &disc(), PI * 0.05 * 0.05 * 0.025);
    row("cylinder", &cylinder(), PI * 0.25 * 2.0);
    row("sphere", &sphere(), 4.0 / 3.0 * PI);
    row("hollow", &tube(), PI * (1.0 - 0.25));
    let b = BEAM;
    row(
        "beam",
        &beam(),
        b.length * b.height * b.width - b.notch_depth * b.notch_width * b.width,
    );
    for (name, a, exact) in [
        (
            "arch",
            masonry::arch(&ARCH, 0.1).unwrap(),
            arch_volume(&ARCH),
        ),
        (
            "wall",
            masonry::wall(&WALL, 0.03).unwrap(),
            6.0 * 4.0 * 0.24 * 0.07 * 0.115,
        ),
        (
            "dome",
            masonry::dome(&DOME, 0.25).unwrap(),
            dome_volume(&DOME),
        ),
        (
            "cloister vault (corners)",
            masonry::cloister_vault(&VAULT, VAULT_SIZE).unwrap(),
            VAULT.web_volume().unwrap(),
        ),
        (
            "cloister vault, Florence (corners)",
            masonry::cloister_vault(&FLORENCE, 1.0).unwrap(),
            FLORENCE.web_volume().unwrap(),
        ),
    ] {
        let q = a.quality().unwrap();
        rows.push((
            format!("{name} ({} blocks)", a.blocks.len()),
            q.min_dihedral_deg,
            q.max_aspect_ratio,
            a.n_tets(),
            rel(a.volume(), exact),
        ));
    }
    for (n, d, ar, t, e) in &rows {
        println!("| {n} | {d:.1}° | {ar:.2} | {t} | {:+.3} % |", e * 100.0);
    }
}

#[test]
fn solid_volumes_are_within_one_percent_and_tets_are_valid() {
    let r = 0.05;
    let cases: [(&str, Mesh, Real, Real); 5] = [
        ("disc", disc(), PI * r * r * 0.025, 20.0),
        ("cylinder", cylinder(), PI * 0.25 * 2.0, 20.0),
        ("sphere", sphere(), 4.0 / 3.0 * PI, 25.0),
        ("hollow cylinder", tube(), PI * (1.0 - 0.25) * 1.0, 20.0),
        (
            "notched beam",
            beam(),
            BEAM.length * BEAM.height * BEAM.width
                - BEAM.notch_depth * BEAM.notch_width * BEAM.width,
            10.0,
        ),
    ];
    for (name, m, exact, min_dihedral) in cases {
        assert_valid(name, &m, min_dihedral);
        let e = rel(m.volume(), exact);
        // Inscribed polyhedra: the volume is always a little low.
        assert!(
            e <= 1e-12 && e > -0.01,
            "{name}: volume error {:.3} %",
            e * 100.0
        );
        if name == "notched beam" {
            assert!(e.abs() < 1e-12, "the beam is exact: {e:e}");
        }
        assert_eq!(m.sets.elements["all"].len(), m.tets.len());
    }
}

#[test]
fn solid_sets_lie_on_their_surfaces() {
    let tol = 1e-9;
    let m = cylinder();
    let r = |p: &Vec3| p.x.hypot(p.y);
    assert_faces_on(&m, "top", |p| (p.z - 2.0).abs() < tol);
    assert_faces_on(&m, "bottom", |p| p.z.abs() < tol);
    assert_faces_on(&m, "side", |p| (r(p) - 0.5).abs() < tol);
    // The three sets cover the boundary.
    let nb = fdem::mesh::boundary_faces(&m).len();
    assert_eq!(
        m.sets.faces["top"].len() + m.sets.faces["bottom"].len() + m.sets.faces["side"].len(),
        nb
    );
    let s = sphere();
    assert_faces_on(&s, "surface", |p| (p.norm() - 1.0).abs() < tol);
    assert_eq!(
        s.sets.faces["surface"].len(),
        fdem::mesh::boundary_faces(&s).len()
    );
    let t = tube();
    assert_faces_on(&t, "inner", |p| (r(p) - 0.5).abs() < tol);
    assert_faces_on(&t, "outer", |p| (r(p) - 1.0).abs() < tol);
    assert_faces_on(&t, "top", |p| (p.z - 1.0).abs() < tol);
    assert_faces_on(&t, "bottom", |p| p.z.abs() < tol);
    // The tube is closed around: no boundary face other than the four surfaces.
    let n: usize = ["inner", "outer", "top", "bottom"]
        .iter()
        .map(|s| t.sets.faces[*s].len())
        .sum();
    assert_eq!(n, fdem::mesh::boundary_faces(&t).len());
}

#[test]
fn notched_beam_sets_resolve_the_notch_and_the_three_point_bending_lines() {
    let b = BEAM;
    let m = beam();
    let tol = 1e-9;
    let xc = 0.5 * b.length;
    assert_faces_on(&m, "top", |p| (p.z - b.height).abs() < tol);
    assert_faces_on(&m, "bottom", |p| p.z.abs() < tol);
    assert_faces_on(&m, "left_end", |p| p.x.abs() < tol);
    assert_faces_on(&m, "right_end", |p| (p.x - b.length).abs() < tol);
    assert_faces_on(&m, "notch", |p| {
        (p.x - xc).abs() <= 0.5 * b.notch_width + tol && p.z <= b.notch_depth + tol
    });
    // Notch area: two walls a × width and the tip notch_width × width.
    let area = |set: &str| -> Real {
        m.sets.faces[set]
            .iter()
            .map(|&(t, l)| {
                let p = TET_FACES[l as usize].map(|c| m.nodes[m.tets[t as usize][c] as usize]);
                0.5 * (p[1] - p[0]).cross(&(p[2] - p[0])).norm()
            })
            .sum()
    };
    let notch = (2.0 * b.notch_depth + b.notch_width) * b.width;
    assert!((area("notch") - notch).abs() < 1e-12, "{}", area("notch"));
    assert!((area("bottom") - (b.length - b.notch_width) * b.width).abs() < 1e-12);
    // Load line: the top nodes at mid-span, one per grid line across the width (0.05 / 0.01).
    let on_line = |set: &str, x: Real, z: Real| {
        let nodes = &m.sets.nodes[set];
        assert_eq!(nodes.len(), 6, "{set}");
        for &n in nodes {
            let p = m.nodes[n as usize];
            assert!(
                (p.x - x).abs() < tol && (p.z - z).abs() < tol,
                "{set}: {p:?}"
            );
        }
    };
    on_line("load_line", xc, b.height);
    on_line("support_left", xc - 0.5 * b.span, 0.0);
    on_line("support_right", xc + 0.5 * b.span, 0.0);
    assert_eq!(m.sets.nodes["supports"].len(), 12);
    // Symmetric about mid-span: mirrored node coordinates are nodes too.
    let mut xs: Vec<i64> = m
        .nodes
        .iter()
        .map(|p| ((p.x - xc) * 1e9).round() as i64)
        .collect();
    xs.sort_unstable();
    let mut mirrored: Vec<i64> = xs.iter().map(|x| -x).collect();
    mirrored.sort_unstable();
    assert_eq!(xs, mirrored);
}

#[test]
fn volume_converges_at_second_order() {
    // Sizes chosen so that halving h exactly doubles the cells on each curve.
    let q = PI / 2.0; // quarter circle of unit radius
    type VolumeAt = Box<dyn Fn(Real) -> Real>;
    let pairs: [(&str, VolumeAt, Real); 4] = [
        (
            "cylinder",
            Box::new(|h| solids::cylinder(1.0, 1.0, h).unwrap().volume()),
            PI,
        ),
        (
            "sphere",
            Box::new(|h| solids::sphere(1.0, h).unwrap().volume()),
            4.0 / 3.0 * PI,
        ),
        (
            "hollow cylinder",
            Box::new(|h| solids::hollow_cylinder(1.0, 2.0, 0.5, h).unwrap().volume()),
            PI * 3.0 * 0.5,
        ),
        (
            "dome",
            Box::new(|h| {
                let d = Dome {
                    courses: 4,
                    blocks_per_course: 8,
                    ..DOME
                };
                masonry::dome(&d, h).unwrap().volume()
            }),
            dome_volume(&Dome {
                courses: 4,
                blocks_per_course: 8,
                ..DOME
            }),
        ),
    ];
    for (name, volume, exact) in pairs {
        let h = if name == "dome" { 0.5 } else { q / 6.0 };
        let e1 = rel(volume(h), exact).abs();
        let e2 = rel(volume(h / 2.0), exact).abs();
        let ratio = e2 / e1;
        println!("{name}: error {e1:.3e} at h, {e2:.3e} at h/2, ratio {ratio:.3}");
        assert!((0.2..0.3).contains(&ratio), "{name}: ratio {ratio}");
    }
}

#[test]
fn arch_voussoirs_have_their_sets_and_glue_face_to_face() {
    let a = masonry::arch(&ARCH, 0.1).unwrap();
    assert_eq!(a.blocks.len(), 15);
    assert_eq!(a.courses, 1);
    let springers: Vec<usize> = a
        .blocks
        .iter()
        .filter(|b| b.springer)
        .map(|b| b.index)
        .collect();
    assert_eq!(springers, vec![0, 14]);
    let e = rel(a.volume(), arch_volume(&ARCH));
    assert!(e.abs() < 0.01 && e <= 0.0, "{e}");
    let (r0, r1) = (ARCH.radius, ARCH.radius + ARCH.thickness);
    let rad = |p: &Vec3| p.x.hypot(p.z);
    for b in &a.blocks {
        assert_valid("voussoir", &b.mesh, 20.0);
        assert_faces_on(&b.mesh, "intrados", |p| (rad(p) - r0).abs() < 1e-9);
        assert_faces_on(&b.mesh, "extrados", |p| (rad(p) - r1).abs() < 1e-9);
        assert_faces_on(&b.mesh, "front", |p| (p.y + 0.25).abs() < 1e-9);
        assert_faces_on(&b.mesh, "back", |p| (p.y - 0.25).abs() < 1e-9);
        // Joint faces lie on the radial planes at the voussoir's two angles.
        let d = PI / 15.0;
        for (set, t) in [
            ("joint_right", b.index as Real * d),
            ("joint_left", (b.index + 1) as Real * d),
        ] {
            assert_faces_on(&b.mesh, set, |p| {
                (p.z * t.cos() - p.x * t.sin()).abs() < 1e-9
            });
        }
    }
    // Springing faces are horizontal, on z = 0.
    for i in [0, 14] {
        assert_faces_on(&a.blocks[i].mesh, "springing", |p| p.z.abs() < 1e-9);
    }
    // Each of the 14 joints: (t/h = 3 radial) × (depth/h = 5) quads × 2 triangles.
    let per_joint = 3 * 5 * 2;
    assert_eq!(a.blocks[0].mesh.sets.faces["joint_left"].len(), per_joint);
    assert_eq!(joints_between(&a), 14 * per_joint);
    // A segmental arch: 120°, springings on the rays at 30° and 150°.
    let s = masonry::arch(
        &Arch {
            span_angle: 120.0,
            voussoirs: 7,
            ..ARCH
        },
        0.1,
    )
    .unwrap();
    let exact = arch_volume(&Arch {
        span_angle: 120.0,
        ..ARCH
    });
    assert!(rel(s.volume(), exact).abs() < 0.01);
    let t = 30f64.to_radians();
    assert_faces_on(&s.blocks[0].mesh, "springing", |p| {
        (p.z * t.cos() - p.x * t.sin()).abs() < 1e-9
    });
    assert_eq!(joints_between(&s), 6 * per_joint);
}

#[test]
fn wall_is_running_bond_with_straight_ends_and_coincident_joints() {
    let w = masonry::wall(&WALL, 0.03).unwrap();
    // Even courses: 4 bricks; odd: 2 halves + 3 bricks.
    assert_eq!(w.blocks.len(), 3 * 4 + 3 * 5);
    assert_eq!(w.courses, 6);
    for c in 0..6 {
        let course: Vec<_> = w.blocks.iter().filter(|b| b.course == c).collect();
        assert_eq!(course.len(), if c % 2 == 0 { 4 } else { 5 });
        let (lo, hi) = course.iter().fold((Real::MAX, Real::MIN), |(lo, hi), b| {
            let (a, z) = b.mesh.bounds();
            (lo.min(a.x), hi.max(z.x))
        });
        assert!(
            lo.abs() < 1e-12 && (hi - 0.96).abs() < 1e-12,
            "course {c}: [{lo}, {hi}]"
        );
    }
    let exact = 24.0 * 0.24 * 0.07 * 0.115;
    assert!(rel(w.volume(), exact).abs() < 1e-12);
    for b in &w.blocks {
        assert_valid("brick", &b.mesh, 30.0);
        let (lo, hi) = b.mesh.bounds();
        assert_faces_on(&b.mesh, "top", |p| (p.z - hi.z).abs() < 1e-12);
        assert_faces_on(&b.mesh, "bottom", |p| (p.z - lo.z).abs() < 1e-12);
        assert_eq!(b.springer, b.course == 0);
    }
    // Cells: brick 0.24 → 2·4 along x (0.03), 0.115 → 4 across, 0.07 → 2 high.
    // Head joints: per course (pieces − 1) faces of 4 × 2 quads; bed joints: 5 courses of
    // 32 × 4 quads; 2 triangles per quad.
    let head = (3 * 3 + 3 * 4) * 4 * 2 * 2;
    let bed = 5 * 32 * 4 * 2;
    assert_eq!(joints_between(&w), head + bed);
    // With gaps nothing touches.
    let gapped = masonry::wall(
        &Wall {
            head_gap: 0.01,
            bed_gap: 0.01,
            ..WALL
        },
        0.03,
    )
    .unwrap();
    let hi = gapped
        .blocks
        .iter()
        .fold(Vec3::zeros(), |hi, b| hi.sup(&b.mesh.bounds().1));
    assert!((hi.x - (4.0 * 0.24 + 3.0 * 0.01)).abs() < 1e-12);
    assert!((hi.z - (6.0 * 0.07 + 5.0 * 0.01)).abs() < 1e-12);
}

#[test]
fn dome_courses_blocks_volume_sets_and_joints() {
    let d = masonry::dome(&DOME, 0.25).unwrap();
    assert_eq!(d.blocks.len(), 8 * 24);
    assert_eq!(d.courses, 8);
    assert_eq!(d.blocks.iter().filter(|b| b.springer).count(), 24);
    let e = rel(d.volume(), dome_volume(&DOME));
    assert!(e <= 0.0 && e > -0.01, "{e}");
    let (r0, r1) = (DOME.radius, DOME.radius + DOME.thickness);
    let polar = |p: &Vec3| (p.z / p.norm()).acos().to_degrees();
    let dt = (90.0 - 10.0) / 8.0;
    for b in &d.blocks {
        assert_valid("dome block", &b.mesh, 12.0);
        assert_faces_on(&b.mesh, "intrados", |p| (p.norm() - r0).abs() < 1e-9);
        assert_faces_on(&b.mesh, "extrados", |p| (p.norm() - r1).abs() < 1e-9);
        let (low, up) = (
            90.0 - b.course as Real * dt,
            90.0 - (b.course + 1) as Real * dt,
        );
        assert_faces_on(&b.mesh, "bed_lower", |p| (polar(p) - low).abs() < 1e-7);
        assert_faces_on(&b.mesh, "bed_upper", |p| (polar(p) - up).abs() < 1e-7);
        // Running bond: odd courses are offset by half a block (7.5°).
        let f0 = 15.0 * b.index as Real + if b.course % 2 == 1 { 7.5 } else { 0.0 };
        for (set, f) in [("head_left", f0), ("head_right", f0 + 15.0)] {
            let f = f.to_radians();
            assert_faces_on(&b.mesh, set, |p| {
                (p.y * f.cos() - p.x * f.sin()).abs() < 1e-9
            });
        }
        if b.course == 0 {
            assert_faces_on(&b.mesh, "base", |p| p.z.abs() < 1e-9);
        }
    }
    // Expected shared triangles: head joints (24 per course, n_θ(c) × n_r quads) and bed
    // joints between courses (the whole φ grid × n_r quads), 2 triangles per quad.
    let mut expected = 0;
    for c in 0..8 {
        let b = d.blocks.iter().find(|b| b.course == c).unwrap();
        expected += 24 * b.mesh.sets.faces["head_left"].len();
        if c > 0 {
            expected += 24 * b.mesh.sets.faces["bed_lower"].len();
        }
    }
    assert_eq!(joints_between(&d), expected);
}

#[test]
fn bad_parameters_are_errors_naming_the_key_and_range() {
    let e = solids::sphere(-1.0, 0.1).unwrap_err();
    assert!(e.contains("'radius' must be > 0, got -1"), "{e}");
    let e = solids::notched_beam(
        &NotchedBeam {
            notch_width: 0.5,
            ..BEAM
        },
        0.01,
    )
    .unwrap_err();
    assert!(e.contains("'notch_width'"), "{e}");
    let e = masonry::arch(
        &Arch {
            voussoirs: 2,
            ..ARCH
        },
        0.1,
    )
    .unwrap_err();
    assert!(e.contains("'voussoirs' must be ≥ 3, got 2"), "{e}");
    let e = masonry::dome(
        &Dome {
            oculus: 0.0,
            ..DOME
        },
        0.1,
    )
    .unwrap_err();
    assert!(e.contains("'oculus' must lie in (0, base = 90)"), "{e}");
    let e = masonry::wall(
        &Wall {
            head_gap: -0.01,
            ..WALL
        },
        0.1,
    )
    .unwrap_err();
    assert!(e.contains("'head_gap'"), "{e}");
    let e = solids::cylinder(1.0, 1.0, 1e-4).unwrap_err();
    assert!(e.contains("too many"), "{e}");
    // Cloister vault: each key named, with its range.
    let vault_err = |v: CloisterVault, h: Real| masonry::cloister_vault(&v, h).unwrap_err();
    for (v, h, want) in [
        (
            CloisterVault { span: 0.0, ..VAULT },
            0.25,
            "'span' must be > 0, got 0",
        ),
        (
            CloisterVault {
                thickness: -1.0,
                ..VAULT
            },
            0.25,
            "'thickness' must be > 0, got -1",
        ),
        (VAULT, 0.0, "'size' must be > 0, got 0"),
        (
            CloisterVault {
                courses: 0,
                ..VAULT
            },
            0.25,
            "'courses' must be ≥ 1, got 0",
        ),
        (
            CloisterVault {
                blocks_per_web: 0,
                ..VAULT
            },
            0.25,
            "'blocks_per_web' must be ≥ 1, got 0",
        ),
        (
            CloisterVault {
                profile_ratio: 0.49,
                ..VAULT
            },
            0.25,
            "'profile_ratio' must be ≥ 1/2 = 0.500000 with profile \"corners\"",
        ),
        (
            CloisterVault {
                profile_ratio: 0.45,
                profile: ProfileOn::Webs,
                ..VAULT
            },
            0.25,
            "'profile_ratio' must be ≥ cos(22.5°)/2 = 0.461940 with profile \"webs\"",
        ),
        (
            CloisterVault {
                oculus: 10.0,
                ..VAULT
            },
            0.25,
            "'oculus' must lie in (0, span = 10) m, got 10",
        ),
        (
            CloisterVault {
                oculus: 0.0,
                ..VAULT
            },
            0.25,
            "'oculus' must lie in (0, span = 10) m, got 0",
        ),
        (
            CloisterVault {
                ribs: Some(Ribs {
                    width: None,
                    depth: 0.0,
                }),
                ..VAULT
            },
            0.25,
            "'rib_depth' must be > 0, got 0",
        ),
        (
            CloisterVault {
                ribs: Some(Ribs {
                    width: Some(4.2),
                    depth: 0.3,
                }),
                ..VAULT
            },
            0.25,
            "'rib_width' must lie in (0, side length at the springing = 4.142136) m, got 4.2",
        ),
        (VAULT, 1e-3, "too many"),
    ] {
        let e = vault_err(v, h);
        assert!(e.contains(want), "{e}");
    }
    // The least ratios (r = R_c on the corners, r = a on the webs: round crowns) are allowed.
    for (on, least) in [(ProfileOn::Corners, 0.5), (ProfileOn::Webs, 0.5 * COS8)] {
        let round = CloisterVault {
            profile_ratio: least,
            profile: on,
            ..VAULT
        };
        assert!(masonry::cloister_vault(&round, 0.5).is_ok());
    }
}

#[test]
fn script_generators_build_meshes_and_blocks_glued_by_joints() {
    let text = r#"
let sim = simulation(#{ name: "gen" });
let stone = material("elastic/small_strain", #{ density: 2000.0, young: 1.0e9, poisson: 0.2 });
let c = cylinder(#{ base: [0.0, 0.0, 0.0], axis: [1.0, 0.0, 0.0], radius: 0.5, length: 2.0 }).mesh(#{ size: 0.1 });
expect_near("cylinder volume", c.volume, PI() * 0.25 * 2.0, 0.01);
expect_within("cylinder min dihedral", c.quality().min_dihedral, 20.0, 90.0);
let s = sphere(#{ center: [0.0, 0.0, 0.0], radius: 1.0 }).mesh(#{});
expect_near("sphere volume", s.volume, 4.0 / 3.0 * PI(), 0.01);
let t = hollow_cylinder(#{ inner_radius: 0.5, outer_radius: 1.0, length: 1.0, axis: [0.0, 1.0, 0.0] });
expect_near("tube volume", t.volume, PI() * 0.75, 0.01);
let d = disc(#{ radius: 0.05, thickness: 0.025 });
expect_near("disc volume", d.volume, PI() * 0.05 * 0.05 * 0.025, 0.01);
let b = notched_beam(#{ length: 0.5, height: 0.1, width: 0.05, notch_depth: 0.03, notch_width: 0.004 });
expect_near("beam volume", b.volume, 0.5 * 0.1 * 0.05 - 0.03 * 0.004 * 0.05, 1.0e-9);
let a = arch(#{ radius: 2.0, thickness: 0.3, depth: 0.5, voussoirs: 5, size: 0.1 });
if a.len() != 5 || a.n_courses != 1 || !a.block(0).springer || a.block(2).springer { throw "arch blocks"; }
let bodies = sim.add_blocks(a, stone, #{ prefix: "v" });
if bodies[3].name != "v_3" { throw "names"; }
let law = joint_law("tied", #{});
let n = sim.insert_joints(#{ between: bodies, law: law });
if n != 4 * 3 * 5 * 2 { throw `joints ${n}`; }
let v = cloister_vault(#{ span: 10.0, thickness: 0.5, courses: 2, blocks_per_web: 2, oculus: 2.0, ribs: true, rib_depth: 0.3, size: 0.5, center: [0.0, 0.0, 20.0] });
if v.kind != "cloister_vault" || v.n_courses != 2 || v.len() != 8 * (1 + 2) + 8 * (1 + 3) { throw `vault blocks ${v.len()}`; }
if !v.block(0).springer || v.block(24).springer || v.block(24).course != 1 { throw "vault courses"; }
if !v.mesh(23).sets().contains("rib") || v.mesh(0).sets().contains("rib") { throw "vault ribs"; }
let vb = sim.add_blocks(v, stone, #{ prefix: "vault" });
let nv = sim.insert_joints(#{ between: vb, law: law });
if nv != @VAULT_JOINTS@ { throw `vault joints ${nv}`; }
let vc = cloister_vault(#{ span: 10.0, thickness: 0.5, courses: 2, blocks_per_web: 2, oculus: 2.0, size: 0.5, profile: "corners" });
let vw = cloister_vault(#{ span: 10.0, thickness: 0.5, courses: 2, blocks_per_web: 2, oculus: 2.0, size: 0.5, profile: "webs" });
expect_near("vault volume, corners", vc.volume, @CORNERS_VOLUME@, 1.0e-12);
expect_near("vault volume, webs", vw.volume, @WEBS_VOLUME@, 1.0e-12);
"#;
    let script_vault = CloisterVault {
        span: 10.0,
        thickness: 0.5,
        courses: 2,
        blocks_per_web: 2,
        profile_ratio: 0.8,
        profile: ProfileOn::Corners,
        oculus: 2.0,
        ribs: Some(Ribs {
            width: None,
            depth: 0.3,
        }),
    };
    let vault_joints = joints_between(&masonry::cloister_vault(&script_vault, 0.5).unwrap());
    let mut text = text.replace("@VAULT_JOINTS@", &vault_joints.to_string());
    // Without ribs, the profile key: "corners" (the default) and "webs" give the Rust
    // generator's meshes.
    for (on, tag) in [
        (ProfileOn::Corners, "@CORNERS_VOLUME@"),
        (ProfileOn::Webs, "@WEBS_VOLUME@"),
    ] {
        let plain = CloisterVault {
            profile: on,
            ribs: None,
            ..script_vault
        };
        let volume = masonry::cloister_vault(&plain, 0.5).unwrap().volume();
        text = text.replace(tag, &format!("{volume:e}"));
    }
    let text = text.as_str();
    let dir = common::temp_dir("gen-script");
    let path = dir.join("gen.rhai");
    let report = fdem::script::run_source(
        &path,
        text,
        fdem::script::RunOptions {
            quiet: true,
            out_dir: Some(dir.join("out")),
            ..Default::default()
        },
    );
    assert!(report.is_ok(), "{}", report.err().unwrap());
    // Parameter errors name the function and the key.
    let bad = "let w = wall(#{ courses: 2, bricks_per_course: 0, brick: [0.2, 0.1, 0.1] });";
    let e = fdem::script::run_source(&path, bad, Default::default())
        .err()
        .unwrap();
    assert!(
        e.0.contains("wall(): key 'bricks_per_course' must be ≥ 1, got 0"),
        "{e}"
    );
    let bad = "let m = half_space(#{ point: [0.0, 0.0, 0.0], normal: [0.0, 0.0, 1.0] }).mesh(#{ size: 0.1 });";
    let e = fdem::script::run_source(&path, bad, Default::default())
        .err()
        .unwrap();
    assert!(e.0.contains("selection region only"), "{e}");
    for (bad, want) in [
        (
            "let v = cloister_vault(#{ span: 10.0, thickness: 0.5, courses: 2, blocks_per_web: 2, rib_width: 1.0 });",
            "cloister_vault(): key 'rib_width' applies only with 'ribs: true'",
        ),
        (
            "let v = cloister_vault(#{ span: 10.0, thickness: 0.5, courses: 2, blocks_per_web: 2, profile_ratio: 0.48 });",
            "cloister_vault(): 'profile_ratio' must be ≥ 1/2 = 0.500000 with profile \"corners\"",
        ),
        (
            "let v = cloister_vault(#{ span: 10.0, thickness: 0.5, courses: 2, blocks_per_web: 2, profile_ratio: 0.4, profile: \"webs\" });",
            "cloister_vault(): 'profile_ratio' must be ≥ cos(22.5°)/2 = 0.461940 with profile \"webs\"",
        ),
        (
            "let v = cloister_vault(#{ span: 10.0, thickness: 0.5, courses: 2, blocks_per_web: 2, profile: \"ribs\" });",
            "cloister_vault(): profile \"ribs\" is not \"corners\" or \"webs\"",
        ),
        (
            "let v = cloister_vault(#{ span: 10.0, thickness: 0.5, courses: 2, blocks_per_web: 0 });",
            "cloister_vault(): key 'blocks_per_web' must be ≥ 1, got 0",
        ),
    ] {
        let e = fdem::script::run_source(&path, bad, Default::default())
            .err()
            .unwrap();
        assert!(e.0.contains(want), "{e}");
    }
}

// ─── Cloister vault ──────────────────────────────────────────────────────────────
//
// The references below are written from the geometry stated in docs/generators.md, not
// from the generator's code: web k of the octagon (corner 0 on +x) faces n_k at (k + ½)·45°;
// its point (ψ, ρ, ξ) is s = κ (c + ρ cos ψ) along n_k, ξ·s·tan 22.5° along the side,
// z = ρ sin ψ, with a = span/2, D_c = 2a/cos 22.5°, r = ratio·D_c and, for the circle on the
// corners, c = q_c = D_c/2 − r and κ = cos 22.5° (the corner-plane distance q = s/cos 22.5°
// is c + ρ cos ψ); for the circle on the webs' mid-lines, c = s_c = a − r and κ = 1.

const VAULT: CloisterVault = CloisterVault {
    span: 10.0,
    thickness: 0.5,
    courses: 6,
    blocks_per_web: 3,
    profile_ratio: 0.8,
    profile: ProfileOn::Corners,
    oculus: 1.5,
    ribs: None,
};
const PROFILES: [ProfileOn; 2] = [ProfileOn::Corners, ProfileOn::Webs];
const COS8: Real = 0.9238795325112867; // cos 22.5°
const VAULT_SIZE: Real = 0.25;
const TAN8: Real = 0.41421356237309503; // tan 22.5° = √2 − 1

/// (a, r, c, κ) of a vault: apothem, radius, the circle's centre (distance from the axis in
/// the section that carries it) and κ = s / (that section's distance).
fn vault_arc(v: &CloisterVault) -> (Real, Real, Real, Real) {
    let a = 0.5 * v.span;
    let dc = 2.0 * a / COS8;
    let r = v.profile_ratio * dc;
    match v.profile {
        ProfileOn::Corners => (a, r, 0.5 * dc - r, COS8),
        ProfileOn::Webs => (a, r, a - r, 1.0),
    }
}

/// Web k's point at (ψ, ρ, ξ).
fn web_point(v: &CloisterVault, k: usize, psi: Real, rho: Real, xi: Real) -> Vec3 {
    let (_, _, c, kappa) = vault_arc(v);
    let beta = (k as Real + 0.5) * PI / 4.0;
    let (n, e) = ([beta.cos(), beta.sin()], [-beta.sin(), beta.cos()]);
    let s = kappa * (c + rho * psi.cos());
    let lat = xi * s * TAN8;
    Vec3::new(
        s * n[0] + lat * e[0],
        s * n[1] + lat * e[1],
        rho * psi.sin(),
    )
}

/// The web of a point (by its azimuth; a point on a corner plane may get either web) and the
/// point's (ψ, ρ, ξ) in it.
fn web_coords(v: &CloisterVault, p: &Vec3) -> (usize, Real, Real, Real) {
    let (_, _, c, kappa) = vault_arc(v);
    let phi = p.y.atan2(p.x).rem_euclid(2.0 * PI);
    let k = ((phi / (PI / 4.0)).floor() as usize).min(7);
    let beta = (k as Real + 0.5) * PI / 4.0;
    let s = p.x * beta.cos() + p.y * beta.sin();
    let lat = -p.x * beta.sin() + p.y * beta.cos();
    let (ds, z) = (s / kappa - c, p.z);
    (k, z.atan2(ds), ds.hypot(z), lat / (s * TAN8))
}

/// The face vertices of a set.
fn set_points(m: &Mesh, set: &str) -> Vec<Vec3> {
    m.sets.faces[set]
        .iter()
        .flat_map(|&(t, l)| TET_FACES[l as usize].map(|c| m.nodes[m.tets[t as usize][c] as usize]))
        .collect()
}

/// Sorted node positions of a node set.
fn set_nodes(m: &Mesh, set: &str) -> Vec<Vec3> {
    let mut p: Vec<Vec3> = m.sets.nodes[set]
        .iter()
        .map(|&n| m.nodes[n as usize])
        .collect();
    p.sort_by(|a, b| (a.x, a.y, a.z).partial_cmp(&(b.x, b.y, b.z)).unwrap());
    p
}

/// Distinct ψ of the nodes of web 0's intrados (the ψ grid, the same in every block of a
/// course), sorted.
fn vault_psi_grid(v: &CloisterVault, a: &Assembly) -> Vec<Real> {
    let mut psi: Vec<Real> = Vec::new();
    for b in &a.blocks {
        for p in set_points(&b.mesh, "intrados") {
            psi.push(web_coords(v, &p).1);
        }
    }
    psi.sort_by(|a, b| a.partial_cmp(b).unwrap());
    psi.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
    psi
}

/// Volume between the arcs of radii ρ0 < ρ1 replaced by their chords at the nodes `psi`
/// (what a mesh with nodes on both arcs encloses), times the web width 2 s tan 22.5°
/// integrated over the mid-plane cross-section, for `fraction` of each side, 8 sides [m³].
/// In the section of the circle (distance d = c + ρ cos ψ from the axis), triangle (centre,
/// ρ at ψ_i, ρ at ψ_{i+1}) has area ρ² sin Δψ / 2 and first moment of d: area × the mean d
/// of its vertices. The mid-plane is that section scaled horizontally by κ (s = κ d), which
/// maps chords to chords and multiplies the area by κ and the moment of s by κ².
fn chord_volume(v: &CloisterVault, rho0: Real, rho1: Real, psi: &[Real], fraction: Real) -> Real {
    let (_, _, c, kappa) = vault_arc(v);
    let tri = |rho: Real, a: Real, b: Real| {
        0.5 * rho * rho * (b - a).sin() * (3.0 * c + rho * a.cos() + rho * b.cos()) / 3.0
    };
    let cross: Real = psi
        .windows(2)
        .map(|w| tri(rho1, w[0], w[1]) - tri(rho0, w[0], w[1]))
        .sum();
    8.0 * fraction * 2.0 * TAN8 * kappa * kappa * cross
}

/// ∫ 2 s tan 22.5° dA over the mid-plane image of the annular sector ρ0..ρ1, 0..ψ_top
/// (s = κ (c + ρ cos ψ), dA = κ ρ dρ dψ), split into the term of c (negative) and the term
/// of ρ cos ψ, per side.
fn vault_volume_terms(v: &CloisterVault, rho0: Real, rho1: Real, psi_top: Real) -> (Real, Real) {
    let (_, _, c, kappa) = vault_arc(v);
    let k2 = kappa * kappa;
    let a = k2 * 2.0 * TAN8 * c * psi_top * (rho1 * rho1 - rho0 * rho0) / 2.0;
    let m = k2 * 2.0 * TAN8 * psi_top.sin() * (rho1.powi(3) - rho0.powi(3)) / 3.0;
    (a, m)
}

/// Every boundary face of the blocks is either glued to a neighbour (counted twice) or in
/// one of the free sets; returns (joints, free faces, boundary faces).
fn vault_face_account(a: &Assembly) -> (usize, usize, usize) {
    let joints = joints_between(a);
    let mut free = 0;
    let mut total = 0;
    for b in &a.blocks {
        let m = &b.mesh;
        total += fdem::mesh::boundary_faces(m).len();
        let n = |s: &str| m.sets.faces.get(s).map_or(0, |f| f.len());
        // `rib` = outer face (also `extrados`) + the two flanks beyond the web.
        let flanks = if m.sets.faces.contains_key("rib") {
            n("rib") - n("extrados")
        } else {
            0
        };
        free += n("intrados") + n("extrados") + n("base") + n("oculus") + flanks;
    }
    (joints, free, total)
}

#[test]
fn cloister_vault_blocks_sets_joints_and_corners() {
    for on in PROFILES {
        vault_blocks_sets_joints_and_corners(CloisterVault {
            profile: on,
            ..VAULT
        });
    }
}

fn vault_blocks_sets_joints_and_corners(v: CloisterVault) {
    println!("profile \"{}\"", v.profile.name());
    let a = masonry::cloister_vault(&v, VAULT_SIZE).unwrap();
    assert_eq!(a.kind, "cloister_vault");
    assert_eq!(a.courses, 6);
    assert_eq!(a.blocks.len(), 6 * 8 * 3);
    assert_eq!(a.blocks.iter().filter(|b| b.springer).count(), 24);
    let p = v.profile().unwrap();
    let (_, r, c, kappa) = vault_arc(&v);
    let t = v.thickness;
    let scale = v.span;
    let dpsi = p.psi_top / 6.0;
    for b in &a.blocks {
        assert_valid("vault block", &b.mesh, 10.0);
        let m = &b.mesh;
        assert_faces_on(m, "intrados", |p| {
            (web_coords(&v, p).2 - r).abs() < 1e-9 * r
        });
        assert_faces_on(m, "extrados", |p| {
            (web_coords(&v, p).2 - r - t).abs() < 1e-9 * r
        });
        let (lo, up) = (b.course as Real * dpsi, (b.course + 1) as Real * dpsi);
        assert_faces_on(m, "bed_lower", |p| (web_coords(&v, p).1 - lo).abs() < 1e-9);
        assert_faces_on(m, "bed_upper", |p| (web_coords(&v, p).1 - up).abs() < 1e-9);
        // Head faces: on one vertical plane through the axis.
        for set in ["head_left", "head_right"] {
            let q = set_points(m, set)[0];
            assert_faces_on(m, set, |p| {
                (p.x * q.y - p.y * q.x).abs() < 1e-9 * scale * scale && p.x * q.x + p.y * q.y > 0.0
            });
        }
        if b.course == 0 {
            assert_faces_on(m, "base", |p| p.z.abs() < 1e-12);
        }
        if b.course == 5 {
            assert_faces_on(m, "oculus", |p| {
                (web_coords(&v, p).1 - p_top(&v)).abs() < 1e-9
            });
        }
        assert!(!m.sets.faces.contains_key("rib"));
    }
    // The oculus: its intrados edge on the mid-lines is oculus/2 from the axis, at r sin ψ_top.
    let top = web_point(&v, 3, p.psi_top, r, 0.0);
    assert!((top.x.hypot(top.y) - 0.75).abs() < 1e-12 && (top.z - p.oculus_height).abs() < 1e-12);
    // Running bond: in odd courses one block straddles each corner (nodes strictly on both
    // sides of the corner plane), in even courses none does.
    for c in 0..6 {
        let straddling = a
            .blocks
            .iter()
            .filter(|b| b.course == c)
            .filter(|b| {
                (0..8).any(|k| {
                    let f = k as Real * PI / 4.0;
                    let side = |p: &Vec3| -p.x * f.sin() + p.y * f.cos();
                    let near = |p: &Vec3| p.x * f.cos() + p.y * f.sin() > 0.0;
                    let n = &b.mesh.nodes;
                    n.iter().any(|p| near(p) && side(p) > 1e-6)
                        && n.iter().any(|p| near(p) && side(p) < -1e-6)
                })
            })
            .count();
        assert_eq!(straddling, if c % 2 == 1 { 8 } else { 0 }, "course {c}");
    }
    // Corner nodes: a node on the corner plane between webs k−1 and k is, to 1e-12 of the
    // span, both web k's point at ξ = −1 and web k−1's at ξ = +1 for its (ψ, ρ).
    let mut on_corners = 0;
    for b in &a.blocks {
        for p in &b.mesh.nodes {
            let phi = p.y.atan2(p.x).rem_euclid(2.0 * PI);
            let k = (phi / (PI / 4.0)).round() as usize % 8;
            let f = k as Real * PI / 4.0;
            if (-p.x * f.sin() + p.y * f.cos()).abs() > 1e-9 * scale {
                continue;
            }
            on_corners += 1;
            // The corner plane's distance q, as the section's distance (c + ρ cos ψ).
            let d = p.x.hypot(p.y) * COS8 / kappa - c;
            let (psi, rho) = (p.z.atan2(d), d.hypot(p.z));
            let from_k = web_point(&v, k, psi, rho, -1.0);
            let from_prev = web_point(&v, (k + 7) % 8, psi, rho, 1.0);
            assert!((from_k - p).norm() < 1e-12 * scale, "{p:?} vs {from_k:?}");
            assert!(
                (from_prev - p).norm() < 1e-12 * scale,
                "{p:?} vs {from_prev:?}"
            );
        }
    }
    assert!(on_corners > 0);
    // Neighbours in a course share their head faces node for node (across the corners too).
    for c in 0..6 {
        let course: Vec<_> = a.blocks.iter().filter(|b| b.course == c).collect();
        for (i, b) in course.iter().enumerate() {
            let next = course[(i + 1) % course.len()];
            assert_eq!(next.index, (b.index + 1) % course.len());
            let (x, y) = (
                set_nodes(&b.mesh, "head_right"),
                set_nodes(&next.mesh, "head_left"),
            );
            assert_eq!(x.len(), y.len());
            for (p, q) in x.iter().zip(&y) {
                assert!(
                    (p - q).norm() <= 1e-12 * scale,
                    "course {c} block {i}: {p:?} {q:?}"
                );
            }
        }
    }
    // Every head and bed face is glued to its neighbour; nothing else is left but the
    // intrados, the extrados, the base and the oculus.
    let (joints, free, total) = vault_face_account(&a);
    assert!(joints > 0);
    assert_eq!(total, 2 * joints + free);
    let paired: usize = a
        .blocks
        .iter()
        .map(|b| {
            let n = |s: &str| b.mesh.sets.faces.get(s).map_or(0, |f| f.len());
            n("head_left") + n("head_right") + n("bed_lower") + n("bed_upper")
                - n("base")
                - n("oculus")
        })
        .sum();
    assert_eq!(paired, 2 * joints);
}

fn p_top(v: &CloisterVault) -> Real {
    v.profile().unwrap().psi_top
}

#[test]
fn cloister_vault_profile_is_the_stated_circle_with_a_pointed_crown() {
    let dc = VAULT.span / COS8;
    // The crown heights in closed form (D_c units, ratio 4/5): D_c √(p − 1/4) with the
    // circle on the corners, D_c √(p cos 22.5° − cos² 22.5°/4) = √(2ra − a²) on the webs.
    let closed = |on: ProfileOn, p: Real| match on {
        ProfileOn::Corners => dc * (p - 0.25).sqrt(),
        ProfileOn::Webs => dc * (p * COS8 - COS8 * COS8 / 4.0).sqrt(),
    };
    assert!((closed(ProfileOn::Corners, 0.8) / dc - 0.741620).abs() < 1e-6);
    assert!((closed(ProfileOn::Webs, 0.8) / dc - 0.725063).abs() < 1e-6);
    for on in PROFILES {
        let v = CloisterVault {
            profile: on,
            ..VAULT
        };
        let a = masonry::cloister_vault(&v, VAULT_SIZE).unwrap();
        let (aa, r, c, kappa) = vault_arc(&v);
        // The section that carries the circle: the corner plane of corner 2 (+y) or the
        // mid-plane of web 2. Its intrados nodes (those on that plane) lie on the circle of
        // radius r about (c, 0), to 1e-9; its extrados nodes at r + t.
        let beta = match on {
            ProfileOn::Corners => 2.0 * PI / 4.0,
            ProfileOn::Webs => 2.5 * PI / 4.0,
        };
        // The other section (web 2's mid-plane or corner 2's plane) is the circle scaled
        // horizontally: its nodes at distance x from the axis lie on
        // (x·λ − c)² + z² = ρ², λ = 1/κ on the mid-plane, cos 22.5°/κ on the corner plane.
        let (other, lambda) = match on {
            ProfileOn::Corners => (2.5 * PI / 4.0, 1.0 / kappa),
            ProfileOn::Webs => (2.0 * PI / 4.0, COS8 / kappa),
        };
        let in_plane = |p: &Vec3, beta: Real| {
            let (x, lat) = (
                p.x * beta.cos() + p.y * beta.sin(),
                -p.x * beta.sin() + p.y * beta.cos(),
            );
            (lat.abs() < 1e-9 * v.span && x > 0.0).then_some(x)
        };
        let mut line: Vec<(Real, Real)> = Vec::new();
        let mut n_other = 0;
        for b in &a.blocks {
            for (set, radius) in [("intrados", r), ("extrados", r + v.thickness)] {
                for p in set_points(&b.mesh, set) {
                    if let Some(x) = in_plane(&p, beta) {
                        assert!(
                            ((x - c).hypot(p.z) - radius).abs() < 1e-9 * radius,
                            "{}: {p:?}",
                            on.name()
                        );
                        if set == "intrados" {
                            line.push((x, p.z));
                        }
                    }
                    if let Some(x) = in_plane(&p, other) {
                        assert!(
                            ((x * lambda - c).hypot(p.z) - radius).abs() < 1e-9 * radius,
                            "{}: {p:?}",
                            on.name()
                        );
                        n_other += 1;
                    }
                }
            }
        }
        assert!(n_other > 0);
        line.sort_by(|a, b| a.1.partial_cmp(&b.1).unwrap());
        line.dedup_by(|a, b| (a.1 - b.1).abs() < 1e-12);
        assert!(line.len() >= 3, "{}", line.len());
        // The circle through three of those nodes, and where it meets the axis: the crown.
        let (p1, p2, p3) = (line[0], line[line.len() / 2], line[line.len() - 1]);
        let d = 2.0 * (p1.0 * (p2.1 - p3.1) + p2.0 * (p3.1 - p1.1) + p3.0 * (p1.1 - p2.1));
        let n = |p: (Real, Real)| p.0 * p.0 + p.1 * p.1;
        let cs = (n(p1) * (p2.1 - p3.1) + n(p2) * (p3.1 - p1.1) + n(p3) * (p1.1 - p2.1)) / d;
        let cz = (n(p1) * (p3.0 - p2.0) + n(p2) * (p1.0 - p3.0) + n(p3) * (p2.0 - p1.0)) / d;
        let rad = (p1.0 - cs).hypot(p1.1 - cz);
        assert!((cs - c).abs() < 1e-9 * r && cz.abs() < 1e-9 * r && (rad - r).abs() < 1e-9 * r);
        // It leaves the springing with a vertical tangent at the octagon's corner (R_c) or
        // side (a).
        let springing = match on {
            ProfileOn::Corners => 0.5 * dc,
            ProfileOn::Webs => aa,
        };
        assert!((cs + rad - springing).abs() < 1e-9 * r);
        let crown = cz + (rad * rad - cs * cs).sqrt();
        let want = closed(on, 0.8);
        assert!((crown - want).abs() < 1e-9 * dc, "{crown} vs {want}");
        let p = v.profile().unwrap();
        assert!((p.crown_height - want).abs() < 1e-12 * dc);
        assert!(
            (p.crown_height - (2.0 * r * springing - springing * springing).sqrt()).abs()
                < 1e-12 * dc
        );
        // The crown is pointed: the arc meets the axis below its own top (ψ_crown < 90°), and
        // the vault stops below it, at the oculus.
        assert!(p.psi_crown < PI / 2.0 && p.psi_top < p.psi_crown);
        let zmax = a
            .blocks
            .iter()
            .map(|b| b.mesh.bounds().1.z)
            .fold(0.0, Real::max);
        assert!(zmax < p.crown_height + v.thickness);
        // The least ratio: r = the springing's distance from the axis (R_c, ratio 1/2, or a,
        // ratio cos 22.5°/2), a round crown at that height (ψ_crown = 90°).
        let least = match on {
            ProfileOn::Corners => 0.5,
            ProfileOn::Webs => 0.5 * COS8,
        };
        let round = CloisterVault {
            profile_ratio: least,
            ..v
        }
        .profile()
        .unwrap();
        assert!(
            (round.crown_height - springing).abs() < 1e-9 * springing
                && (round.psi_crown - PI / 2.0).abs() < 1e-7
        );
    }
    // The ratio that gives the circle on the webs the crown of the circle on the corners
    // with ratio p: (p − 1/4 + cos² 22.5°/4)/cos 22.5° ≈ 0.826 for 4/5.
    let p_eq = (0.8 - 0.25 + COS8 * COS8 / 4.0) / COS8;
    let eq = CloisterVault {
        profile_ratio: p_eq,
        profile: ProfileOn::Webs,
        ..VAULT
    };
    let crown_corners = VAULT.profile().unwrap().crown_height;
    assert!((eq.profile().unwrap().crown_height - crown_corners).abs() < 1e-12 * dc);
    assert!((crown_corners - dc * 0.55f64.sqrt()).abs() < 1e-12 * dc);
    assert!((p_eq - 0.826).abs() < 5e-4);
}

#[test]
fn cloister_vault_volume_against_quadrature() {
    for on in PROFILES {
        vault_volume_against_quadrature(CloisterVault {
            profile: on,
            ..VAULT
        });
    }
}

fn vault_volume_against_quadrature(v: CloisterVault) {
    let name = v.profile.name();
    let p = v.profile().unwrap();
    let (_, r, _, _) = vault_arc(&v);
    let t = v.thickness;
    // 1. The closed form against a numerical integral of |det J| of the map (ψ, ρ, ξ) → x
    //    (central differences, composite Simpson: 400 × 2 × 2 intervals; the integrand is
    //    quadratic in ρ and constant in ξ, smooth in ψ).
    let simpson = |n: usize, lo: Real, hi: Real, f: &dyn Fn(Real) -> Real| {
        let h = (hi - lo) / n as Real;
        (0..=n)
            .map(|i| {
                let w = if i == 0 || i == n {
                    1.0
                } else if i % 2 == 1 {
                    4.0
                } else {
                    2.0
                };
                w * f(lo + i as Real * h)
            })
            .sum::<Real>()
            * h
            / 3.0
    };
    let jac = |psi: Real, rho: Real, xi: Real| {
        let e = 1e-6;
        let d = |dp: Real, dr: Real, dx: Real| {
            (web_point(&v, 0, psi + dp, rho + dr, xi + dx)
                - web_point(&v, 0, psi - dp, rho - dr, xi - dx))
                / (2.0 * e)
        };
        d(e, 0.0, 0.0)
            .cross(&d(0.0, e, 0.0))
            .dot(&d(0.0, 0.0, e))
            .abs()
    };
    let quad = 8.0
        * simpson(400, 0.0, p.psi_top, &|psi| {
            simpson(2, r, r + t, &|rho| {
                simpson(2, -1.0, 1.0, &|xi| jac(psi, rho, xi))
            })
        });
    let exact = v.web_volume().unwrap();
    assert!(rel(quad, exact).abs() < 1e-8, "{name}: {quad} vs {exact}");
    // 2. The mesh is the polyhedron whose only approximation is the chords of the arcs in ψ
    //    (bed and head faces are planar, straight along the sides): its volume equals that
    //    chord volume to rounding.
    let a = masonry::cloister_vault(&v, VAULT_SIZE).unwrap();
    let psi = vault_psi_grid(&v, &a);
    assert!((psi[0]).abs() < 1e-12 && (psi[psi.len() - 1] - p.psi_top).abs() < 1e-9);
    let chords = chord_volume(&v, r, r + t, &psi, 1.0);
    assert!(
        rel(a.volume(), chords).abs() < 1e-12,
        "{} vs {chords}",
        a.volume()
    );
    // 3. Against the exact volume, within the faceting bound: a chord over Δψ keeps
    //    sin Δψ/Δψ ≥ 1 − Δψ²/6 of a sector's area (the s_c term, negative) and
    //    cos²(Δψ/2) ≥ 1 − Δψ²/4 of its moment (the ρ cos ψ term), so
    //    |error| ≤ (|A|/6 + M/4)·Δψ_max² / V.
    let (ta, tm) = vault_volume_terms(&v, r, r + t, p.psi_top);
    assert!((8.0 * (ta + tm) - exact).abs() < 1e-12 * exact);
    let dmax = psi.windows(2).map(|w| w[1] - w[0]).fold(0.0, Real::max);
    let bound = 8.0 * (ta.abs() / 6.0 + tm / 4.0) * dmax * dmax / exact;
    let e = rel(a.volume(), exact);
    println!("vault ({name}) volume {:.6} m³, exact {exact:.6}, error {:.3e} (bound {bound:.3e}, Δψ_max {dmax:.4})", a.volume(), e);
    assert!(e.abs() <= bound && e < 0.0, "{e} vs {bound}");
    // 4. Second order: halving `size` multiplies the ψ cells by n₂/n₁ (about 1.8: the ψ cells
    //    follow the geometric mean of size and the around-cell width, and the around-grid is
    //    rounded to whole pairs of cells per block), and the error by (n₁/n₂)².
    let err_cells = |h: Real| {
        let a = masonry::cloister_vault(&v, h).unwrap();
        (rel(a.volume(), exact), vault_psi_grid(&v, &a).len() - 1)
    };
    let ((e1, n1), (e2, n2)) = (err_cells(0.25), err_cells(0.125));
    let predicted = (n1 as Real / n2 as Real).powi(2);
    println!("vault ({name}): error {e1:.3e} ({n1} ψ cells), {e2:.3e} ({n2}): ratio {:.3}, (n₁/n₂)² {predicted:.3}", e2 / e1);
    assert!((e2 / e1 / predicted - 1.0).abs() < 0.1);
}

/// Where the head faces of a block are around the octagon, in sides from corner 0
/// (U = k + (ξ + 1)/2 on web k, modulo 8): [left, right]. A head face is a vertical plane
/// through the axis, so every node of it gives the same U.
fn head_u(v: &CloisterVault, b: &masonry::Block) -> [Real; 2] {
    ["head_left", "head_right"].map(|set| {
        let p = set_nodes(&b.mesh, set)[0];
        let (k, _, _, xi) = web_coords(v, &p);
        (k as Real + 0.5 * (xi + 1.0)).rem_euclid(8.0)
    })
}

/// Width of a block around the octagon, in sides.
fn width_u(v: &CloisterVault, b: &masonry::Block) -> Real {
    let [l, r] = head_u(v, b);
    let w = (r - l).rem_euclid(8.0);
    if w > 7.999 {
        w - 8.0
    } else {
        w
    }
}

#[test]
fn cloister_vault_ribs_straddle_the_corners_and_glue_to_the_webs() {
    for on in PROFILES {
        vault_ribs(CloisterVault {
            profile: on,
            ..VAULT
        });
    }
}

fn vault_ribs(base: CloisterVault) {
    println!("profile \"{}\"", base.profile.name());
    let depth = 0.3;
    let v = CloisterVault {
        ribs: Some(Ribs { width: None, depth }),
        ..base
    };
    let a = masonry::cloister_vault(&v, VAULT_SIZE).unwrap();
    // Per course 8 ribs; between two ribs 3 web blocks (even courses) or a half block at
    // each end and 2 full ones (odd).
    for c in 0..6 {
        let n = a.blocks.iter().filter(|b| b.course == c).count();
        assert_eq!(n, 8 + 8 * if c % 2 == 0 { 3 } else { 4 }, "course {c}");
    }
    let (_, r, _, _) = vault_arc(&v);
    let (r1, r2) = (r + v.thickness, r + v.thickness + depth);
    let ribs: Vec<&masonry::Block> = a
        .blocks
        .iter()
        .filter(|b| b.mesh.sets.faces.contains_key("rib"))
        .collect();
    assert_eq!(ribs.len(), 6 * 8);
    for b in &a.blocks {
        assert_valid("vault block", &b.mesh, 8.0);
    }
    for b in &ribs {
        let m = &b.mesh;
        assert_faces_on(m, "intrados", |p| {
            (web_coords(&v, p).2 - r).abs() < 1e-9 * r
        });
        assert_faces_on(m, "extrados", |p| {
            (web_coords(&v, p).2 - r2).abs() < 1e-9 * r
        });
        // `rib`: the outer face and the flanks beyond the web extrados.
        assert_faces_on(m, "rib", |p| web_coords(&v, p).2 >= r1 - 1e-9 * r);
        // A rib straddles a corner; by default it is one block wide (the same width as an
        // even-course web block).
        let [l, rr] = head_u(&v, b);
        assert_ne!(
            l.floor() as usize,
            rr.floor() as usize % 8,
            "a rib spans a corner"
        );
        let web = a
            .blocks
            .iter()
            .find(|w| w.course == 0 && !w.mesh.sets.faces.contains_key("rib"))
            .unwrap();
        assert!((width_u(&v, b) - width_u(&v, web)).abs() < 1e-9);
    }
    // The last block of every course is the rib at corner 0, straddling +x.
    for c in 0..6 {
        let last = a.blocks.iter().rfind(|b| b.course == c).unwrap();
        let [l, rr] = head_u(&v, last);
        assert!(
            last.mesh.sets.faces.contains_key("rib") && l > 7.0 && rr < 1.0,
            "{l} {rr}"
        );
    }
    // Neighbours in a course: the web block's head face is part of the rib's, node for node.
    for c in 0..6 {
        let course: Vec<_> = a.blocks.iter().filter(|b| b.course == c).collect();
        for (i, b) in course.iter().enumerate() {
            let next = course[(i + 1) % course.len()];
            let (x, y) = (
                set_nodes(&b.mesh, "head_right"),
                set_nodes(&next.mesh, "head_left"),
            );
            let (small, large) = if x.len() <= y.len() { (x, y) } else { (y, x) };
            for p in &small {
                assert!(
                    large.iter().any(|q| (p - q).norm() <= 1e-12 * v.span),
                    "{p:?}"
                );
            }
        }
    }
    let (joints, free, total) = vault_face_account(&a);
    assert_eq!(total, 2 * joints + free);
    let q = a.quality().unwrap();
    println!(
        "ribbed vault: {} blocks, {} tets, {joints} joint triangles, min dihedral {:.1}°, max aspect {:.2}",
        a.blocks.len(),
        a.n_tets(),
        q.min_dihedral_deg,
        q.max_aspect_ratio
    );
    // Volume: the shell's chord volume plus the ribs' part beyond the web (their fraction of
    // each side, from the ξ of their heads).
    let fraction = width_u(&v, ribs[0]);
    let psi = vault_psi_grid(&v, &a);
    let expected = chord_volume(&v, r, r1, &psi, 1.0) + chord_volume(&v, r1, r2, &psi, fraction);
    assert!(
        rel(a.volume(), expected).abs() < 1e-12,
        "{} vs {expected}",
        a.volume()
    );
    // A given width is rounded to an even number of cells: within one cell of it.
    let w = 0.5;
    let vw = CloisterVault {
        ribs: Some(Ribs {
            width: Some(w),
            depth,
        }),
        ..base
    };
    let aw = masonry::cloister_vault(&vw, VAULT_SIZE).unwrap();
    let rib = aw
        .blocks
        .iter()
        .find(|b| b.mesh.sets.faces.contains_key("rib"))
        .unwrap();
    let side = v.span * TAN8;
    let got = width_u(&vw, rib) * side;
    // A half block (the first block of an odd course) is m/2 cells: the cell width.
    let half = aw
        .blocks
        .iter()
        .find(|b| b.course == 1 && b.index == 0)
        .unwrap();
    let mut us: Vec<Real> = set_nodes(&half.mesh, "bed_lower")
        .iter()
        .map(|p| {
            let (k, _, _, xi) = web_coords(&vw, p);
            k as Real + 0.5 * (xi + 1.0)
        })
        .collect();
    us.sort_by(|a, b| a.partial_cmp(b).unwrap());
    us.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
    let cell = width_u(&vw, half) * side / (us.len() - 1) as Real;
    println!("rib width asked {w} m, got {got:.4} m (cell {cell:.4} m)");
    assert!((got - w).abs() <= cell + 1e-9, "{got} vs {w}");
    let (joints, free, total) = vault_face_account(&aw);
    assert_eq!(total, 2 * joints + free);
}

/// The Florence-size vault of docs/generators.md: span 45 m across flats, shell 2.2 m,
/// quinto acuto on the corners (the default), oculus 5.6 m, 12 courses × 4 blocks per web,
/// size 1 m.
const FLORENCE: CloisterVault = CloisterVault {
    span: 45.0,
    thickness: 2.2,
    courses: 12,
    blocks_per_web: 4,
    profile_ratio: 0.8,
    profile: ProfileOn::Corners,
    oculus: 5.6,
    ribs: None,
};

/// The smallest dihedral angle of each course [°].
fn min_dihedral_per_course(a: &Assembly) -> Vec<Real> {
    let mut out = vec![Real::INFINITY; a.courses];
    for b in &a.blocks {
        let q = b.mesh.quality().unwrap();
        out[b.course] = out[b.course].min(q.min_dihedral_deg);
    }
    out
}

#[test]
fn cloister_vault_florence_numbers() {
    // Printed with --nocapture for docs/generators.md.
    let v = FLORENCE;
    let p = v.profile().unwrap();
    let t0 = std::time::Instant::now();
    let a = masonry::cloister_vault(&v, 1.0).unwrap();
    let dt = t0.elapsed();
    let q = a.quality().unwrap();
    let exact = v.web_volume().unwrap();
    let e = rel(a.volume(), exact);
    println!(
        "Florence: a {:.3} m, D_c {:.3} m, r {:.3} m, q_c {:.3} m, ψ_top {:.2}°, ψ_crown {:.2}°, crown {:.3} m, top bed {:.3} m",
        p.apothem,
        p.corner_span,
        p.radius,
        p.centre,
        p.psi_top.to_degrees(),
        p.psi_crown.to_degrees(),
        p.crown_height,
        p.oculus_height
    );
    println!(
        "  {} blocks, {} tets, min dihedral {:.1}°, max aspect {:.2}, mean aspect {:.2}, generated in {:.0} ms",
        a.blocks.len(),
        a.n_tets(),
        q.min_dihedral_deg,
        q.max_aspect_ratio,
        q.mean_aspect_ratio,
        dt.as_secs_f64() * 1e3
    );
    println!(
        "  volume {:.0} m³ (exact {exact:.0} m³, error {:+.3} %)",
        a.volume(),
        e * 100.0
    );
    for rho in [1800.0, 1900.0, 2000.0] {
        println!("  mass at {rho} kg/m³: {:.0} t", exact * rho / 1000.0);
    }
    // What one shell leaves out, with the same formula: a second, coaxial shell 1.2 m
    // outside the first, 0.6 or 0.9 m thick, over the same ψ range.
    let (_, r, _, _) = vault_arc(&v);
    for to in [0.6, 0.9] {
        let r0 = r + v.thickness + 1.2;
        let (ta, tm) = vault_volume_terms(&v, r0, r0 + to, p.psi_top);
        println!("  outer shell {to} m: {:.0} m³", 8.0 * (ta + tm));
    }
    // With corner ribs as wide as the 1420 programme's corner spurs at their foot (7 braccia,
    // 4.1 m) and as deep as the gap between the shells (1.2 m).
    let ribbed = CloisterVault {
        ribs: Some(Ribs {
            width: Some(4.1),
            depth: 1.2,
        }),
        ..v
    };
    let t0 = std::time::Instant::now();
    let ar = masonry::cloister_vault(&ribbed, 1.0).unwrap();
    let dtr = t0.elapsed();
    let qr = ar.quality().unwrap();
    println!(
        "  ribbed: {} blocks, {} tets, min dihedral {:.1}°, max aspect {:.2}, volume {:.0} m³ (+{:.0} m³ of ribs), {:.0} ms",
        ar.blocks.len(),
        ar.n_tets(),
        qr.min_dihedral_deg,
        qr.max_aspect_ratio,
        ar.volume(),
        ar.volume() - a.volume(),
        dtr.as_secs_f64() * 1e3
    );
    assert!(ar.blocks.iter().all(|b| b.mesh.check().is_empty()));
    assert_eq!(a.blocks.len(), 12 * 32);
    assert!(a.blocks.iter().all(|b| b.mesh.check().is_empty()));
    assert!(q.min_dihedral_deg > 10.0);
    assert!(e < 0.0 && e > -1e-3, "{e}");
    // Crown of the quinto acuto on the corners: D_c √(0.8 − 1/4).
    assert!((p.crown_height / p.corner_span - 0.741620).abs() < 1e-6);
    // Where the quality drops: the smallest dihedral angle per course, here and on the
    // table's vault (with and without ribs 0.3 m deep).
    let show = |what: &str, a: &Assembly| {
        let per: Vec<String> = min_dihedral_per_course(a)
            .iter()
            .map(|d| format!("{d:.1}"))
            .collect();
        println!("  {what}: min dihedral per course [{}]°", per.join(", "));
    };
    show("Florence", &a);
    for on in PROFILES {
        let tv = CloisterVault {
            profile: on,
            ..VAULT
        };
        show(
            &format!("table's vault ({})", on.name()),
            &masonry::cloister_vault(&tv, VAULT_SIZE).unwrap(),
        );
    }
    let ribbed_table = CloisterVault {
        ribs: Some(Ribs {
            width: None,
            depth: 0.3,
        }),
        ..VAULT
    };
    show(
        "table's vault, ribs 0.3 m",
        &masonry::cloister_vault(&ribbed_table, VAULT_SIZE).unwrap(),
    );
    // The same vault with the circle on the webs' mid-lines, for comparison.
    let w = CloisterVault {
        profile: ProfileOn::Webs,
        ..v
    };
    let pw = w.profile().unwrap();
    let aw = masonry::cloister_vault(&w, 1.0).unwrap();
    let qw = aw.quality().unwrap();
    let exact_w = w.web_volume().unwrap();
    println!(
        "  profile \"webs\": s_c {:.3} m, ψ_top {:.2}°, ψ_crown {:.2}°, crown {:.3} m, top bed {:.3} m; {} tets, min dihedral {:.1}°, max aspect {:.2}, volume {:.0} m³ (exact {exact_w:.0} m³, error {:+.3} %)",
        pw.centre,
        pw.psi_top.to_degrees(),
        pw.psi_crown.to_degrees(),
        pw.crown_height,
        pw.oculus_height,
        aw.n_tets(),
        qw.min_dihedral_deg,
        qw.max_aspect_ratio,
        aw.volume(),
        rel(aw.volume(), exact_w) * 100.0
    );
    assert!((pw.crown_height / pw.corner_span - 0.725063).abs() < 1e-6);
}
