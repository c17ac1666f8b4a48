//! ParaView and CSV output, read back by independent readers: vtkio (Rust) for base64 frames,
//! Python's meshio for raw frames (the default). Values must come back bit for bit.

mod common;

use common::temp_dir;
use fdem::script::{run_source, RunOptions};
use std::path::{Path, PathBuf};

/// A small model with both layouts, stress and motion, run a few steps, with one frame
/// written at the end (so the frame holds exactly the final state).
fn model(encoding: &str) -> String {
    format!(
        r#"let sim = simulation(#{{ name: "frames", vtk_encoding: "{encoding}", stress_output: "pk1", energy_every: 5 }});
let m = material("elastic/neo_hookean", #{{ density: 1000.0, young: 1.0e6, poisson: 0.3 }});
let a = sim.add_body("a", box(#{{ min: [0.0, 0.0, 0.0], max: [1.0, 0.5, 0.5] }}).mesh(#{{ divisions: [4, 2, 2] }}), m, #{{ layout: "jointed" }});
let b = sim.add_body("b", box(#{{ min: [0.0, 0.0, 1.0], max: [1.0, 0.5, 1.5] }}).mesh(#{{ divisions: [4, 2, 2] }}), m);
sim.fix(a.nodes(half_space(#{{ point: [0.0, 0.0, 0.0], normal: [-1.0, 0.0, 0.0] }})));
sim.gravity([0.0, 0.0, -9.81]);
sim.initial_velocity(b.nodes(), [0.3, -0.1, 0.2]);
let e = sim.monitor("kinetic", #{{ every: 5 }}, |s| s.kinetic_energy());
sim.write_vtk();
sim.run(#{{ steps: 40 }});
sim.write_vtk();
"#
    )
}

fn run(encoding: &str, test: &str) -> (PathBuf, fdem::script::ScriptReport) {
    let dir = temp_dir(&format!("{test}-{encoding}"));
    let opts = RunOptions {
        out_dir: Some(dir.clone()),
        quiet: true,
        ..Default::default()
    };
    let report = run_source(&dir.join("frames.rhai"), &model(encoding), opts)
        .unwrap_or_else(|e| panic!("{e}"));
    (dir, report)
}

/// The single piece of a `.vtu` file, read by vtkio.
fn vtkio_piece(path: &Path) -> vtkio::model::UnstructuredGridPiece {
    use vtkio::model::DataSet;
    let vtk = vtkio::Vtk::import(path)
        .unwrap_or_else(|e| panic!("vtkio cannot read {}: {e}", path.display()));
    let DataSet::UnstructuredGrid { pieces, .. } = vtk.data else {
        panic!("not an unstructured grid")
    };
    pieces
        .into_iter()
        .next()
        .unwrap()
        .into_loaded_piece_data(Some(path))
        .unwrap()
}

fn bits(v: impl IntoIterator<Item = f64>) -> Vec<u64> {
    v.into_iter().map(f64::to_bits).collect()
}

#[test]
fn vtkio_reads_base64_frames_bit_for_bit() {
    use vtkio::model::{Attribute, IOBuffer, VertexNumbers};
    let (dir, report) = run("base64", "vtkio");
    let st = report.sims[0].0.borrow();
    let sim = &st.sim;
    let piece = vtkio_piece(&dir.join("frames_000001.vtu"));
    let IOBuffer::F64(points) = piece.points else {
        panic!("points are not f64")
    };
    assert_eq!(
        bits(points),
        bits(sim.nodes.x.iter().flat_map(|p| [p.x, p.y, p.z]))
    );
    let VertexNumbers::XML {
        connectivity,
        offsets,
    } = piece.cells.cell_verts
    else {
        panic!("cells")
    };
    assert_eq!(
        connectivity,
        sim.tets
            .nodes
            .iter()
            .flat_map(|t| t.map(u64::from))
            .collect::<Vec<_>>()
    );
    assert_eq!(
        offsets,
        (1..=sim.tets.len() as u64)
            .map(|c| 4 * c)
            .collect::<Vec<_>>()
    );
    assert!(
        piece.cells.types.iter().all(|&t| t as u8 == 10),
        "all cells are VTK_TETRA"
    );
    let arrays = |attrs: Vec<Attribute>| -> Vec<(String, IOBuffer)> {
        attrs
            .into_iter()
            .map(|a| match a {
                Attribute::DataArray(d) => (d.name, d.data),
                Attribute::Field { name, .. } => panic!("unexpected field {name}"),
            })
            .collect()
    };
    let point = arrays(piece.data.point);
    let cell = arrays(piece.data.cell);
    // vtkio silently drops arrays it cannot decode: check the names first.
    let names = |v: &[(String, IOBuffer)]| v.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
    assert_eq!(names(&point), ["displacement", "velocity"]);
    assert_eq!(
        names(&cell),
        [
            "stress",
            "von_mises",
            "principal_stress",
            "body",
            "material",
            "stress_pk1"
        ]
    );
    let IOBuffer::F64(disp) = &point[0].1 else {
        panic!()
    };
    assert_eq!(
        bits(disp.iter().copied()),
        bits(sim.nodes.x.iter().zip(&sim.nodes.x0).flat_map(|(x, x0)| [
            x.x - x0.x,
            x.y - x0.y,
            x.z - x0.z
        ]))
    );
    let IOBuffer::F64(vel) = &point[1].1 else {
        panic!()
    };
    assert_eq!(
        bits(vel.iter().copied()),
        bits(sim.nodes.v.iter().flat_map(|v| [v.x, v.y, v.z]))
    );
    let IOBuffer::F64(stress) = &cell[0].1 else {
        panic!()
    };
    for e in 0..sim.tets.len() {
        let f = fdem::elements::deformation_gradient(&sim.tets, &sim.nodes.x, e);
        let s = sim.materials[0].stress(&f, fdem::material::StressMeasure::Cauchy);
        for (k, v) in stress[9 * e..9 * e + 9].iter().enumerate() {
            assert_eq!(
                v.to_bits(),
                s[(k / 3, k % 3)].to_bits(),
                "stress of tet {e}"
            );
        }
    }
    let IOBuffer::I32(body) = &cell[3].1 else {
        panic!("body ids are Int32")
    };
    assert_eq!(
        body,
        &sim.tets.body.iter().map(|&b| b as i32).collect::<Vec<_>>()
    );
    // The model really moved and is stressed (the comparison is not between zeros).
    assert!(disp.iter().any(|d| d.abs() > 1e-6));
    assert!(stress.iter().any(|s| s.abs() > 1.0));
}

#[test]
fn pvd_and_csv_files_are_complete() {
    let (dir, report) = run("raw", "pvd");
    let st = report.sims[0].0.borrow();
    let pvd = std::fs::read_to_string(dir.join("frames.pvd")).unwrap();
    assert!(
        pvd.contains("file=\"frames_000000.vtu\"") && pvd.contains("file=\"frames_000001.vtu\""),
        "{pvd}"
    );
    assert!(
        pvd.contains(&format!("timestep=\"{:?}\"", st.sim.time)),
        "{pvd}"
    );
    let energy = std::fs::read_to_string(dir.join("energy.csv")).unwrap();
    let mut lines = energy.lines();
    assert_eq!(lines.next().unwrap(), "step,time,kinetic,strain,gravity_work,force_work,reaction_work,mass_damping,viscous_damping,joint,fracture,contact,friction,balance_error");
    assert_eq!(lines.count(), st.sim.energy_history.len());
    let kin = std::fs::read_to_string(dir.join("kinetic.csv")).unwrap();
    assert_eq!(kin.lines().next().unwrap(), "step,time,kinetic");
    assert_eq!(
        kin.lines().count(),
        1 + 1 + 40 / 5,
        "header, the value at the start, one every 5 steps"
    );
    // No temporary files are left behind.
    assert!(std::fs::read_dir(&dir).unwrap().all(|e| !e
        .unwrap()
        .file_name()
        .to_string_lossy()
        .ends_with(".tmp")));
}

/// Python's meshio (installed by .ci/run) reads the default raw frames: point and cell
/// counts, cell type, and displacement values bit for bit (printed by Python as hex).
#[test]
fn meshio_reads_raw_frames_bit_for_bit() {
    let (dir, report) = run("raw", "meshio");
    let probe = std::process::Command::new("python3")
        .args(["-c", "import meshio"])
        .output();
    if !probe.as_ref().is_ok_and(|o| o.status.success()) {
        if std::env::var_os("FDEM_SKIP_PYTHON_READERS").is_some() {
            eprintln!("meshio is not installed and FDEM_SKIP_PYTHON_READERS is set: skipped");
            return;
        }
        panic!("python3 with meshio is needed (pip install -r requirements-dev.txt, as .ci/run does); set FDEM_SKIP_PYTHON_READERS=1 to skip");
    }
    let path = dir.join("frames_000001.vtu");
    let script = r#"
import sys, meshio
m = meshio.read(sys.argv[1])
print(len(m.points), sum(len(c.data) for c in m.cells), ",".join(c.type for c in m.cells))
print(" ".join(float(v).hex() for v in m.point_data["displacement"].ravel()))
print(" ".join(float(v).hex() for v in m.cell_data["von_mises"][0]))
"#;
    let out = std::process::Command::new("python3")
        .args(["-c", script])
        .arg(&path)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "meshio failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    let mut lines = text.lines();
    let st = report.sims[0].0.borrow();
    let sim = &st.sim;
    assert_eq!(
        lines.next().unwrap(),
        format!("{} {} tetra", sim.nodes.len(), sim.tets.len())
    );
    let parse = |l: &str| l.split(' ').map(hexf).collect::<Vec<f64>>();
    let disp = parse(lines.next().unwrap());
    assert_eq!(
        bits(disp),
        bits(sim.nodes.x.iter().zip(&sim.nodes.x0).flat_map(|(x, x0)| [
            x.x - x0.x,
            x.y - x0.y,
            x.z - x0.z
        ]))
    );
    let vm = parse(lines.next().unwrap());
    let expected: Vec<f64> = (0..sim.tets.len())
        .map(|e| {
            let f = fdem::elements::deformation_gradient(&sim.tets, &sim.nodes.x, e);
            let s = sim.materials[0].stress(&f, fdem::material::StressMeasure::Cauchy);
            fdem::math::von_mises(&s)
        })
        .collect();
    assert_eq!(bits(vm), bits(expected));
    let _ = Path::new("");
}

/// Parse Python's float.hex() ("0x1.8p+1", "-0x0.0p+0").
fn hexf(s: &str) -> f64 {
    let (neg, s) = s.strip_prefix('-').map_or((false, s), |r| (true, r));
    let s = s.strip_prefix("0x").unwrap();
    let (mant, exp) = s.split_once('p').unwrap();
    let (int, frac) = mant.split_once('.').unwrap_or((mant, ""));
    let mut m = u64::from_str_radix(int, 16).unwrap() as f64;
    let mut scale = 1.0 / 16.0;
    for c in frac.chars() {
        m += c.to_digit(16).unwrap() as f64 * scale;
        scale /= 16.0;
    }
    let v = m * 2f64.powi(exp.parse::<i32>().unwrap());
    if neg {
        -v
    } else {
        v
    }
}

/// The crack surface read back by vtkio: one triangle (VTK type 5) per broken joint, with the
/// time of breaking and the mode bit for bit as in the break events.
#[test]
fn crack_surface_reads_back_with_the_break_events() {
    use vtkio::model::{Attribute, IOBuffer, VertexNumbers};
    let dir = temp_dir("cracks");
    let script = r#"let sim = simulation(#{ name: "bar", vtk_encoding: "base64" });
let m = material("elastic/munjiza", #{ density: 2500.0, young: 1.0e10, poisson: 0.0 });
let bar = sim.add_body("bar", box(#{ min: [0.0, 0.0, 0.0], max: [1.0, 0.1, 0.1] }).mesh(#{ divisions: [10, 2, 2] }), m, #{ layout: "jointed" });
sim.insert_joints(#{ within: bar, law: joint_law("cohesive/munjiza", #{ tensile_strength: 1.0e6, cohesion: 3.0e6, g_i: 50.0, g_ii: 200.0 }) });
sim.prescribe_velocity(bar.nodes(half_space(#{ point: [0.0, 0.0, 0.0], normal: [-1.0, 0.0, 0.0] })), #{ x: 0.0 });
sim.prescribe_velocity(bar.nodes(half_space(#{ point: [1.0, 0.0, 0.0], normal: [1.0, 0.0, 0.0] })), #{ x: table([[0.0, 0.0], [2.5e-3, 0.01]]) });
sim.run(#{ max_time: 0.03, stop_when: |s| s.fragments().count > 1, check_every: 100 });
sim.write_vtk();
"#;
    let opts = RunOptions {
        out_dir: Some(dir.clone()),
        quiet: true,
        ..Default::default()
    };
    let report = run_source(&dir.join("bar.rhai"), script, opts).unwrap_or_else(|e| panic!("{e}"));
    let st = report.sims[0].0.borrow();
    let events = &st.sim.break_events;
    assert!(!events.is_empty(), "the bar broke");
    let piece = vtkio_piece(&dir.join("bar_cracks_000000.vtu"));
    assert!(piece.cells.types.iter().all(|&t| t as u8 == 5), "triangles");
    assert_eq!(piece.cells.types.len(), events.len());
    let VertexNumbers::XML { offsets, .. } = piece.cells.cell_verts else {
        panic!("cells")
    };
    assert_eq!(
        offsets,
        (1..=events.len() as u64).map(|c| 3 * c).collect::<Vec<_>>()
    );
    let cell: Vec<(String, IOBuffer)> = piece
        .data
        .cell
        .into_iter()
        .map(|a| match a {
            Attribute::DataArray(d) => (d.name, d.data),
            Attribute::Field { name, .. } => panic!("unexpected field {name}"),
        })
        .collect();
    assert_eq!(
        cell.iter().map(|(n, _)| n.as_str()).collect::<Vec<_>>(),
        ["time", "mode", "body", "joint"]
    );
    let IOBuffer::F64(time) = &cell[0].1 else {
        panic!("time is f64")
    };
    assert_eq!(
        bits(time.iter().copied()),
        bits(events.iter().map(|e| e.time))
    );
    let IOBuffer::I32(mode) = &cell[1].1 else {
        panic!("mode is i32")
    };
    assert!(mode.iter().all(|&m| (1..=3).contains(&m)));
}
