//! Mesh generators against geometry: volumes against analytic values (within 1 % at the
//! default sizes of docs/generators.md, O(h²) under refinement), no inverted or flat tets,
//! a minimum dihedral angle bound, named sets lying on their surfaces, block and course
//! counts, and coincident faces between neighbouring masonry blocks (mortar joints found by
//! `insert_between`, one per shared triangle).

use fdem::joints::JointLaw;
use fdem::material::{Formulation, Material};
use fdem::math::{Real, Vec3};
use fdem::mesh::masonry::{self, Arch, Assembly, Dome, Wall};
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
"#;
    let dir = std::env::temp_dir().join(format!("fdem-gen-script-{}", std::process::id()));
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
}
