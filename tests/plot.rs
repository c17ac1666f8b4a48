//! Plots written by fdem itself (`sim.plot`, `sim.plot_energy`, `fdem plot DIR`) and the
//! headless frame renderer (scripts/plot/render_frame.py).
//!
//! A plot cannot be compared with a reference picture, but what it must hold can be read
//! back: the PNG decodes (with the `png` crate, an independent decoder) to the size asked
//! for and is not blank; the SVG holds the axis labels with their units, one legend entry per
//! series and one polyline per series with exactly as many points as the CSV has rows (no
//! decimation below 4 × width points, src/io/plot.rs); the same CSV gives the same bytes;
//! bad input is an error that names what is allowed. The renderer's outer surface of a box
//! of 10 × 2 × 2 cells must have exactly 2·(10·2·4 + 2·2·2) = 176 triangles: it finds them
//! by matching faces by position, and a wrong reference configuration or matching gives
//! another number (it gave 400 while it used the current positions of a broken bar).

mod common;
use common::{fdem, run_script, temp_dir};
use std::path::Path;

/// A small elastic column settling under gravity, two monitors every 5 steps, plotted.
const TINY: &str = r#"
let sim = simulation(#{ name: "tiny", energy_every: 10 });
let m = material("elastic/munjiza", #{ density: 2000.0, young: 1.0e7, poisson: 0.25 });
let b = sim.add_body("b", box(#{ min: [0.0, 0.0, 0.0], max: [0.2, 0.2, 0.4] }).mesh(#{ divisions: [1, 1, 2] }), m);
let base = b.nodes(half_space(#{ point: [0.0, 0.0, 0.001], normal: [0.0, 0.0, -1.0] }));
let top = b.nodes(half_space(#{ point: [0.0, 0.0, 0.399], normal: [0.0, 0.0, 1.0] }));
sim.fix(base);
sim.gravity([0.0, 0.0, -9.81]);
let settle = sim.monitor("top", #{ every: 5 }, |s| s.displacement(top)[2]);
let reaction = sim.monitor("reaction", #{ every: 5 }, |s| s.reaction(base)[2]);
sim.run(#{ steps: 300 });
let a = sim.plot(#{ file: "top_vs_time", y: "top", width: 640, height: 400 });
let b2 = sim.plot(#{ file: "reaction_vs_top", x: settle, y: [reaction], x_label: "settlement [m]", y_label: "reaction [N]", title: "Reaction against settlement", format: "svg" });
let e = sim.plot_energy(#{ format: "both" });
print(`plotted ${a.len() + b2.len() + e.len()} files`);
"#;

/// Run TINY into `dir/out`; its output directory.
fn tiny_run(dir: &Path) -> std::path::PathBuf {
    let (ok, out, err) = run_script(dir, "tiny", TINY, &[]);
    assert!(ok, "{out}\n{err}");
    assert!(out.contains("plotted 5 files"), "{out}");
    dir.join("out")
}

/// Width, height and the RGB(A) pixels of a PNG file, decoded by the `png` crate.
fn decode_png(path: &Path) -> (u32, u32, Vec<u8>, usize) {
    let dec = png::Decoder::new(std::fs::File::open(path).unwrap());
    let mut reader = dec.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    buf.truncate(info.buffer_size());
    (info.width, info.height, buf, info.color_type.samples())
}

/// Not blank: the share of pixels that are not white, and the variance of the grey levels.
fn ink(pixels: &[u8], samples: usize) -> (f64, f64) {
    let grey: Vec<f64> = pixels
        .chunks(samples)
        .map(|p| p[..3.min(samples)].iter().map(|&c| c as f64).sum::<f64>() / 3.0)
        .collect();
    let n = grey.len() as f64;
    let mean = grey.iter().sum::<f64>() / n;
    let var = grey.iter().map(|g| (g - mean).powi(2)).sum::<f64>() / n;
    let dark = grey.iter().filter(|&&g| g < 250.0).count() as f64 / n;
    (dark, var)
}

/// Data rows of a CSV file.
fn csv_rows(path: &Path) -> usize {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .count()
}

/// Point counts of the SVG's polylines drawn in `color` (`#RRGGBB`).
fn polylines(svg: &str, color: &str) -> Vec<usize> {
    svg.lines()
        .filter(|l| l.starts_with("<polyline") && l.contains(&format!("stroke=\"{color}\"")))
        .map(|l| {
            let pts = l
                .split("points=\"")
                .nth(1)
                .unwrap()
                .split('"')
                .next()
                .unwrap();
            pts.split_whitespace().count()
        })
        .collect()
}

fn assert_png(path: &Path, w: u32, h: u32) {
    let (pw, ph, px, samples) = decode_png(path);
    assert_eq!((pw, ph), (w, h), "{}", path.display());
    let (dark, var) = ink(&px, samples);
    // Axes, ticks, labels and a line: a few per cent of the pixels, never all of them. A
    // blank (all white) picture has 0 and 0; a picture without text has under 1 %.
    assert!(dark > 0.01 && dark < 0.5, "{}: {dark}", path.display());
    assert!(var > 100.0, "{}: grey variance {var}", path.display());
}

#[test]
fn sim_plot_writes_monitors_and_the_energy_account_as_png_and_svg() {
    let dir = temp_dir("sim_plot");
    let out = tiny_run(&dir);
    let rows = csv_rows(&out.join("top.csv"));
    assert_eq!(rows, 61, "300 steps, every 5, and the first");
    // Monitor against time: both files, the size asked for.
    assert_png(&out.join("top_vs_time.png"), 640, 400);
    let svg = std::fs::read_to_string(out.join("top_vs_time.svg")).unwrap();
    // Time runs to ~1e-3 s or more here: scaled by an SI prefix or not, it says [.s].
    assert!(
        svg.contains("time [ms]") || svg.contains("time [s]"),
        "x label"
    );
    // A monitor does not know its unit: the label says so.
    assert!(svg.contains("unit not recorded"), "y label");
    assert!(svg.contains(">\ntop\n</text>"), "legend entry");
    let lines = polylines(&svg, "#1F77B4");
    assert!(
        lines.contains(&rows),
        "a polyline of {rows} points: {lines:?}"
    );
    // Monitor against monitor, the user's labels drawn as given, SVG only.
    assert!(!out.join("reaction_vs_top.png").exists());
    let svg = std::fs::read_to_string(out.join("reaction_vs_top.svg")).unwrap();
    for text in [
        "settlement [m]",
        "reaction [N]",
        "Reaction against settlement",
    ] {
        assert!(svg.contains(text), "{text}");
    }
    assert!(polylines(&svg, "#1F77B4").contains(&rows));
    // The energy account: the terms that are not zero, and the balance error panel.
    assert_png(&out.join("energy.png"), 1000, 800);
    let svg = std::fs::read_to_string(out.join("energy.svg")).unwrap();
    for text in [
        "kinetic",
        "strain",
        "gravity_work",
        "balance error [",
        "energy [",
    ] {
        assert!(svg.contains(text), "{text}");
    }
    let e_rows = csv_rows(&out.join("energy.csv"));
    assert!(e_rows > 10);
    assert!(polylines(&svg, "#1F77B4").contains(&e_rows));
}

#[test]
fn fdem_plot_draws_a_finished_run_and_is_deterministic() {
    let dir = temp_dir("cli_plot");
    let out = tiny_run(&dir);
    let plot = |extra: &[&str]| {
        let o = fdem().arg("plot").arg(&out).args(extra).output().unwrap();
        (
            o.status.success(),
            String::from_utf8_lossy(&o.stdout).into_owned(),
            String::from_utf8_lossy(&o.stderr).into_owned(),
        )
    };
    let (ok, stdout, stderr) = plot(&["--width", "640", "--height", "400"]);
    assert!(ok, "{stderr}");
    // energy, top, reaction: PNG and SVG each (no cracks.csv: no joints).
    assert_eq!(
        stdout.lines().filter(|l| l.starts_with("wrote ")).count(),
        6,
        "{stdout}"
    );
    assert_png(&out.join("top.png"), 640, 400);
    assert_png(&out.join("reaction.png"), 640, 400);
    assert_png(&out.join("energy.png"), 640, 533);
    let svg1 = std::fs::read(out.join("energy.svg")).unwrap();
    let png1 = std::fs::read(out.join("top.png")).unwrap();
    let (ok, _, _) = plot(&["--width", "640", "--height", "400"]);
    assert!(ok);
    assert_eq!(
        svg1,
        std::fs::read(out.join("energy.svg")).unwrap(),
        "same CSV, same SVG"
    );
    assert_eq!(
        png1,
        std::fs::read(out.join("top.png")).unwrap(),
        "same CSV, same PNG"
    );
    // Chosen columns from two files, matched on step.
    let (ok, stdout, stderr) = plot(&["--x", "top", "--y", "reaction", "--format", "svg"]);
    assert!(ok, "{stderr}");
    assert!(stdout.contains("reaction_vs_top.svg"), "{stdout}");
    let svg = std::fs::read_to_string(out.join("reaction_vs_top.svg")).unwrap();
    let rows = csv_rows(&out.join("top.csv"));
    assert!(polylines(&svg, "#1F77B4").contains(&rows));
    // A name in several files: a monitor's own file first (a monitor named "strain" against
    // the strain energy of energy.csv), else FILE:COLUMN says which.
    let top = std::fs::read_to_string(out.join("top.csv")).unwrap();
    std::fs::write(
        out.join("strain.csv"),
        top.replacen("step,time,top", "step,time,strain", 1),
    )
    .unwrap();
    let (ok, _, stderr) = plot(&["--x", "strain", "--y", "reaction", "--format", "svg"]);
    assert!(ok, "{stderr}");
    let svg = std::fs::read_to_string(out.join("reaction_vs_strain.svg")).unwrap();
    // The monitor's (its label says its unit is not recorded), not the energy's [J].
    assert!(svg.contains("\nstrain (") && !svg.contains("\nstrain ["));
    assert!(polylines(&svg, "#1F77B4").contains(&rows));
    let (ok, _, stderr) = plot(&["--y", "energy:strain", "--format", "svg"]);
    assert!(ok, "{stderr}");
    let svg = std::fs::read_to_string(out.join("strain_vs_time.svg")).unwrap();
    assert!(
        svg.contains("strain [") && svg.contains("J]"),
        "the strain energy"
    );
    std::fs::write(out.join("b.csv"), "step,time,q\n0,0,1\n5,0.1,2\n").unwrap();
    std::fs::write(out.join("c.csv"), "step,time,q\n0,0,3\n5,0.1,4\n").unwrap();
    let (ok, _, stderr) = plot(&["--y", "q"]);
    assert!(!ok, "ambiguous");
    assert!(
        stderr.contains("column 'q' is in b.csv and c.csv: say which with FILE:COLUMN"),
        "{stderr}"
    );
    let (ok, _, stderr) = plot(&["--y", "c:q", "--format", "svg"]);
    assert!(ok, "{stderr}");
    let svg = std::fs::read_to_string(out.join("q_vs_time.svg")).unwrap();
    assert!(polylines(&svg, "#1F77B4").contains(&2));
    // Errors: an unknown column names the columns there; a bad format names the formats.
    let (ok, _, stderr) = plot(&["--y", "nope"]);
    assert!(!ok);
    assert!(stderr.contains("no column 'nope'"), "{stderr}");
    let listed = stderr.split("the columns are: ").nth(1).unwrap_or_default();
    let listed: Vec<&str> = listed.trim().split(", ").collect();
    for c in ["kinetic", "reaction", "step", "time", "top"] {
        assert!(listed.contains(&c), "{c} not listed: {stderr}");
    }
    let (ok, _, stderr) = plot(&["--format", "jpg"]);
    assert!(
        !ok && stderr.contains("\"png\", \"svg\", \"both\""),
        "{stderr}"
    );
    let (ok, _, stderr) = plot(&["--width", "5"]);
    assert!(!ok && stderr.contains("[200, 8000]"), "{stderr}");
    // A directory without CSV files.
    let empty = temp_dir("cli_plot_empty");
    let o = fdem().arg("plot").arg(&empty).output().unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && stderr.contains("no CSV files"),
        "{stderr}"
    );
}

#[test]
fn sim_plot_errors_name_what_is_allowed() {
    let dir = temp_dir("sim_plot_errors");
    let head = TINY.split("let a = sim.plot").next().unwrap();
    let cases = [
        (
            "sim.plot(#{ file: \"f\", y: \"top\", colour: \"red\" });",
            "unknown key 'colour'; allowed keys: file, y, x, x_label, y_label, title, format, width, height",
        ),
        (
            "sim.plot(#{ file: \"f\", y: \"tip\" });",
            "no monitor named \"tip\"; its monitors are \"top\", \"reaction\"",
        ),
        ("sim.plot(#{ y: \"top\" });", "missing required key 'file'"),
        (
            "sim.plot(#{ file: \"f\", y: \"top\", format: \"gif\" });",
            "\"png\", \"svg\", \"both\"",
        ),
        ("sim.plot(#{ file: \"a/b\", y: \"top\" });", "cannot name a file"),
        ("sim.plot_energy(#{ size: 3 });", "allowed keys: file, title, format, width, height"),
    ];
    for (i, (call, msg)) in cases.iter().enumerate() {
        let text = format!("{head}{call}\n");
        let (ok, out, err) = run_script(&dir, &format!("e{i}"), &text, &[]);
        assert!(!ok, "{call}: {out}");
        assert!(err.contains(msg), "{call}:\n{err}");
        // The script's line and column are given.
        assert!(err.contains(&format!("e{i}.rhai")), "{err}");
    }
}

/// PNG needs no system font: the binary links neither fontconfig nor freetype (the font
/// is bundled, data/fonts/), so a machine without them draws the same text.
#[cfg(target_os = "linux")]
#[test]
fn the_binary_links_no_font_library() {
    let Ok(o) = std::process::Command::new("ldd")
        .arg(env!("CARGO_BIN_EXE_fdem"))
        .output()
    else {
        eprintln!("ldd is not installed: nothing to check");
        return;
    };
    let libs = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{libs}");
    for lib in ["fontconfig", "freetype", "expat"] {
        assert!(!libs.contains(lib), "fdem links {lib}:\n{libs}");
    }
}

/// Run scripts/tension_bar.rhai in quick mode (the bar breaks in two) into `dir/tb`.
fn quick_tension_bar(dir: &Path) -> std::path::PathBuf {
    let out = dir.join("tb");
    let o = fdem()
        .args(["run", "--quiet", "--set", "quick=true", "--out"])
        .arg(&out)
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/tension_bar.rhai"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    out
}

/// The headless picture of the cracked state: scripts/tension_bar.rhai in quick mode breaks
/// the bar in two (8 joints of one section); the renderer draws its last frame with the crack
/// surface.
#[test]
#[ignore = "needs python3 with meshio and matplotlib"]
fn render_frame_draws_the_cracked_state_headless() {
    let dir = temp_dir("render");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = quick_tension_bar(&dir);
    let broken = csv_rows(&out.join("cracks.csv"));
    assert!(broken > 0);
    let png = dir.join("frame.png");
    let o = std::process::Command::new("python3")
        .arg(root.join("scripts/plot/render_frame.py"))
        .arg(&out)
        .args(["--cracks", "--scale", "20", "--out"])
        .arg(&png)
        .env("MPLBACKEND", "Agg")
        .env_remove("DISPLAY")
        .output()
        .expect("python3 (pip install -r requirements-dev.txt)");
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    // 10 × 2 × 2 cells of 6 tetrahedra: 176 outer triangles; every broken joint drawn.
    assert!(stdout.contains("(176 outer faces"), "{stdout}");
    assert!(
        stdout.contains(&format!("{broken} broken joints")),
        "{stdout}"
    );
    let (w, h, px, samples) = decode_png(&png);
    assert!(w > 300 && h > 200, "{w} × {h}");
    let (dark, var) = ink(&px, samples);
    assert!(dark > 0.02 && var > 100.0, "{dark} {var}");
}

/// `--hide-bodies` leaves bodies out of the picture (a container's walls): two separate
/// boxes of one cell (6 tetrahedra, 12 outer triangles each) give 24 outer faces, 12 with
/// body 1 hidden, the same 12 with "1-1"; a malformed list and a list hiding everything are
/// errors that say so.
#[test]
#[ignore = "needs python3 with meshio and matplotlib"]
fn render_frame_hides_the_bodies_it_is_told_to() {
    let dir = temp_dir("render_hide");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = r#"
let sim = simulation(#{ name: "two" });
let m = material("elastic/munjiza", #{ density: 2000.0, young: 1.0e7, poisson: 0.25 });
sim.add_body("a", box(#{ min: [0.0, 0.0, 0.0], max: [1.0, 1.0, 1.0] }).mesh(#{ divisions: [1, 1, 1] }), m);
sim.add_body("b", box(#{ min: [2.0, 0.0, 0.0], max: [3.0, 1.0, 1.0] }).mesh(#{ divisions: [1, 1, 1] }), m);
sim.run(#{ steps: 1 });
sim.write_vtk();
"#;
    let (ok, _, err) = run_script(&dir, "two", text, &[]);
    assert!(ok, "{err}");
    let render = |extra: &[&str]| {
        let o = std::process::Command::new("python3")
            .arg(root.join("scripts/plot/render_frame.py"))
            .arg(dir.join("out"))
            .args(["--field", "body", "--out"])
            .arg(dir.join("two.png"))
            .args(extra)
            .env("MPLBACKEND", "Agg")
            .env_remove("DISPLAY")
            .output()
            .expect("python3 (pip install -r requirements-dev.txt)");
        (
            o.status.success(),
            format!(
                "{}{}",
                String::from_utf8_lossy(&o.stdout),
                String::from_utf8_lossy(&o.stderr)
            ),
        )
    };
    let (ok, out) = render(&[]);
    assert!(ok && out.contains("(24 outer faces"), "{out}");
    for spec in ["1", "1-1"] {
        let (ok, out) = render(&["--hide-bodies", spec]);
        assert!(ok && out.contains("(12 outer faces"), "{spec}: {out}");
    }
    let (ok, out) = render(&["--hide-bodies", "one"]);
    assert!(!ok && out.contains("expected ids and ranges"), "{out}");
    let (ok, out) = render(&["--hide-bodies", "0-1"]);
    assert!(!ok && out.contains("hides every tetrahedron"), "{out}");
}

/// Monitors with a `unit`: the CSV header says `name [unit]`, reads back as the name and the
/// unit, and plots put the unit on the axis. Reference values: the column settles by
/// ~1e-4 m (ρgH²/2E = 1.6e-4 m, with overshoot), so its axis is in µm; the stress at the
/// base, ~8e-3 MPa, is in ×10⁻³ MPa (MPa takes no second prefix); the weight 3.1e2 N in N.
#[test]
fn monitor_units_reach_the_csv_header_and_the_plot_axes() {
    let dir = temp_dir("plot_units");
    let text = TINY
        .replace(
            r#"sim.monitor("top", #{ every: 5 }"#,
            r#"sim.monitor("top", #{ every: 5, unit: "m" }"#,
        )
        .replace(
            r#"sim.monitor("reaction", #{ every: 5 }"#,
            r#"sim.monitor("reaction", #{ every: 5, unit: "N" }"#,
        )
        .replace(
            "sim.run(#{ steps: 300 });",
            r#"let stress = sim.monitor("stress", #{ every: 5, unit: "MPa" }, |s| s.reaction(base)[2] / 0.04 / 1.0e6);
sim.monitor("count", #{ every: 5, unit: "-" }, |s| s.broken_joints());
sim.run(#{ steps: 300 });
sim.plot(#{ file: "mixed", y: ["top", "stress"], format: "svg" });"#,
        );
    assert!(text.contains("unit: \"m\"") && text.contains("unit: \"N\""));
    let (ok, out, err) = run_script(&dir, "units", &text, &[]);
    assert!(ok, "{out}\n{err}");
    let out = dir.join("out");
    // The header round trip.
    let head = |f: &str| {
        std::fs::read_to_string(out.join(f))
            .unwrap()
            .lines()
            .next()
            .unwrap()
            .to_string()
    };
    assert_eq!(head("top.csv"), "step,time,top [m]");
    assert_eq!(head("stress.csv"), "step,time,stress [MPa]");
    assert_eq!(head("count.csv"), "step,time,count [-]");
    let t = fdem::io::plot::read_csv(&out.join("top.csv")).unwrap();
    assert_eq!(t.columns, ["step", "time", "top"]);
    assert_eq!(t.units[2].as_deref(), Some("m"));
    // sim.plot: the unit on the axis, scaled by a prefix; no "unit not recorded".
    let svg = std::fs::read_to_string(out.join("top_vs_time.svg")).unwrap();
    assert!(svg.contains("top [µm]"), "y label with its unit");
    assert!(!svg.contains("unit not recorded"));
    // Two units on one axis: each in its legend entry.
    let svg = std::fs::read_to_string(out.join("mixed.svg")).unwrap();
    assert!(svg.contains("units in the legend"), "mixed axis");
    assert!(svg.contains(">\ntop [m]\n</text>") && svg.contains(">\nstress [MPa]\n</text>"));
    // fdem plot DIR reads the units back from the headers.
    let o = fdem()
        .arg("plot")
        .arg(&out)
        .args(["--format", "svg"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for (file, label) in [
        ("top.svg", "top [µm]"),
        ("stress.svg", "stress [×10⁻³ MPa]"),
        ("reaction.svg", "reaction [N]"),
        ("count.svg", "\ncount\n"),
    ] {
        let svg = std::fs::read_to_string(out.join(file)).unwrap();
        assert!(svg.contains(label), "{file}: {label}");
        assert!(!svg.contains("unit not recorded"), "{file}");
    }
    // Columns are chosen by name, without the unit.
    let o = fdem()
        .arg("plot")
        .arg(&out)
        .args(["--x", "top", "--y", "reaction", "--format", "svg"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let svg = std::fs::read_to_string(out.join("reaction_vs_top.svg")).unwrap();
    assert!(svg.contains("top [µm]") && svg.contains("reaction [N]"));
}

/// `unit` is a key of `sim.monitor`: an unknown key is still an error naming the allowed
/// keys, and a unit that cannot be read back from a header is refused.
#[test]
fn monitor_keys_and_units_are_checked() {
    let dir = temp_dir("monitor_keys");
    let head = TINY.split("let settle").next().unwrap();
    let cases = [
        (
            r#"sim.monitor("x", #{ every: 5, units: "m" }, |s| 0.0);"#,
            "unknown key 'units' (did you mean 'unit'?); allowed keys: every, unit",
        ),
        (
            r#"sim.monitor("x", #{ unit: "[m]" }, |s| 0.0);"#,
            "without brackets",
        ),
        (
            r#"sim.monitor("x", #{ unit: "" }, |s| 0.0);"#,
            "unit \"\" cannot",
        ),
        (r#"sim.monitor("x", #{ unit: 3 }, |s| 0.0);"#, "'unit'"),
    ];
    for (i, (call, msg)) in cases.iter().enumerate() {
        let text = format!("{head}{call}\n");
        let (ok, out, err) = run_script(&dir, &format!("k{i}"), &text, &[]);
        assert!(!ok, "{call}: {out}");
        assert!(err.contains(msg), "{call}:\n{err}");
        assert!(err.contains(&format!("k{i}.rhai")), "{err}");
    }
}

/// scripts/plot/rc_beam_impact_frame.py drew the concrete at points + displacement, but fdem
/// writes the points at their current place: the displacement was added twice (the bars,
/// drawn at their points, sat away from the concrete). Reference: the last frame of the quick
/// tension bar (broken in two) against its first: the positions drawn are the frame's points
/// exactly, and the reference positions (points − displacement) are the same in both frames
/// though the nodes moved between them, to 1e-12 m (roundoff of x − X on coordinates of
/// order 1 m).
#[test]
#[ignore = "needs python3 with meshio and matplotlib"]
fn rc_beam_frame_draws_the_current_positions_once() {
    let dir = temp_dir("rc_frame");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = quick_tension_bar(&dir);
    let check = r#"
import glob, sys
import meshio, numpy as np
sys.path.insert(0, sys.argv[1])
import rc_beam_impact_frame as f
frames = sorted(p for p in glob.glob(sys.argv[2] + "/tension_bar_[0-9]*.vtu"))
first, last = meshio.read(frames[0]), meshio.read(frames[-1])
x, x0 = f.places(last)
u = np.abs(last.point_data["displacement"] - first.point_data["displacement"]).max()
assert u > 1e-6, u
assert np.array_equal(x, last.points)
err = np.abs(x0 - f.places(first)[1]).max()
assert err < 1e-12, err
print(f"displacement up to {u:.3e} m; reference places within {err:.1e} m")
"#;
    let o = std::process::Command::new("python3")
        .arg("-c")
        .arg(check)
        .arg(root.join("scripts/plot"))
        .arg(&out)
        .env("MPLBACKEND", "Agg")
        .output()
        .expect("python3 (pip install -r requirements-dev.txt)");
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(stdout.contains("reference places within"), "{stdout}");
}

/// One figure script of docs/applications and the quick run it draws from.
struct PageFigures {
    /// The bundled script, run with `quick=true` (and `set`) into `dir/<script>`.
    script: &'static str,
    set: &'static [&'static str],
    /// scripts/plot/<plot>.py, called with these arguments ("{out}": the run's directory,
    /// "{img}": the image directory, "{dir}": the test's directory).
    plot: &'static str,
    args: &'static [&'static str],
    /// The PNGs it must write into the image directory (none for a script that prints).
    pngs: &'static [&'static str],
    /// Text its output must hold.
    says: &'static [&'static str],
}

/// Every figure script behind the pictures of docs/applications (scripts/plot/*.py) draws
/// from a run of its case, headless: the pages' figures are rerunnable, not hand-made. Each
/// case runs in quick mode (the same runs as tests/scripts.rs, with their self-checks), the
/// figure script reads its CSV histories and last ParaView frames, and every PNG it writes
/// must decode at a readable size with ink on it (more than 2 % of the pixels not white, grey
/// levels varying: a blank or single-colour canvas fails). The scripts that print tables
/// must print the run's own figures (the Brazilian disc's σ_t/f_t as the run printed it; the
/// beam's row with its test's measured values).
#[test]
#[ignore = "needs python3 with meshio and matplotlib"]
fn the_application_figures_are_drawn_from_quick_runs() {
    let dir = temp_dir("page_figures");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let img = dir.join("img");
    let cases = [
        PageFigures {
            script: "brazilian_disc",
            set: &[],
            plot: "brazilian_disc",
            args: &["{out}", "{img}"],
            pngs: &[
                "brazilian_disc_load.png",
                "brazilian_disc_cracks.png",
                "brazilian_disc_energy.png",
            ],
            says: &["wrote"],
        },
        PageFigures {
            script: "brazilian_disc",
            set: &[],
            plot: "brazilian_disc_study",
            args: &["{dir}/brazilian_disc.log"],
            pngs: &[],
            says: &["| brazilian_disc.log | structured |"],
        },
        PageFigures {
            script: "notched_beam",
            set: &[],
            plot: "notched_beam",
            args: &["{out}", "{img}"],
            pngs: &[
                "notched_beam_load.png",
                "notched_beam_energy.png",
                "notched_beam_cracks.png",
            ],
            says: &[],
        },
        PageFigures {
            // ucs.py reads a study directory: the quick run stands for its 12.5 mm runs.
            script: "ucs",
            set: &[],
            plot: "ucs",
            args: &["{dir}/ucs_study", "{img}"],
            pngs: &["ucs_stress_strain.png", "ucs_speed.png", "ucs_cracks.png"],
            says: &[],
        },
        PageFigures {
            script: "laminated_glass",
            set: &[],
            plot: "laminated_glass",
            args: &["{out}", "{img}", "quick"],
            pngs: &[
                "laminated_glass_quick_histories.png",
                "laminated_glass_quick_cracks.png",
                "laminated_glass_quick_section.png",
            ],
            says: &["peak deceleration"],
        },
        PageFigures {
            script: "rc_beam_impact",
            set: &[],
            plot: "rc_beam_impact",
            args: &["{out}", "{img}", "quick", "211", "0", "0"],
            pngs: &[
                "rc_beam_impact_quick_histories.png",
                "rc_beam_impact_quick_cracks.png",
            ],
            says: &[],
        },
        PageFigures {
            script: "rc_beam_impact",
            set: &[],
            plot: "rc_beam_impact_frame",
            args: &["{out}", "{img}/rc_beam_impact_frame.png", "1"],
            pngs: &["rc_beam_impact_frame.png"],
            says: &[],
        },
        PageFigures {
            // The seven-test table reads DIR/run.log and DIR/out of each test's run.
            script: "rc_beam_impact",
            set: &[],
            plot: "rc_beam_impact_table",
            args: &["SS2a={dir}/rc_table"],
            pngs: &[],
            says: &["| SS2a | 200 mm | 211 kg | 10.0 / 0.5 |"],
        },
        PageFigures {
            script: "dome_earthquake",
            set: &[],
            plot: "dome_earthquake",
            args: &["{out}", "{img}"],
            pngs: &[
                "dome_earthquake_histories.png",
                "dome_earthquake_spectrum.png",
                "dome_earthquake_energy.png",
                "dome_earthquake_cracks.png",
            ],
            says: &["wrote"],
        },
    ];
    for case in &cases {
        let out = dir.join(case.script);
        if !out.exists() {
            let o = fdem()
                .args(["run", "--set", "quick=true", "--overwrite", "--out"])
                .arg(&out)
                .args(case.set.iter().flat_map(|s| ["--set", s]))
                .arg(root.join(format!("scripts/{}.rhai", case.script)))
                .output()
                .unwrap();
            let log = [o.stdout.as_slice(), o.stderr.as_slice()].concat();
            std::fs::write(dir.join(format!("{}.log", case.script)), &log).unwrap();
            assert!(
                o.status.success(),
                "{}: {}",
                case.script,
                String::from_utf8_lossy(&log)
            );
        }
        if case.script == "ucs" {
            let study = dir.join("ucs_study");
            std::fs::create_dir_all(&study).unwrap();
            for name in ["v0.25", "s0.0125"] {
                let link = study.join(name);
                if !link.exists() {
                    std::os::unix::fs::symlink(&out, link).unwrap();
                }
            }
        }
        if case.plot == "rc_beam_impact_table" {
            let table = dir.join("rc_table");
            std::fs::create_dir_all(&table).unwrap();
            std::fs::copy(dir.join("rc_beam_impact.log"), table.join("run.log")).unwrap();
            if !table.join("out").exists() {
                std::os::unix::fs::symlink(&out, table.join("out")).unwrap();
            }
        }
        let fill = |a: &str| {
            a.replace("{out}", out.to_str().unwrap())
                .replace("{img}", img.to_str().unwrap())
                .replace("{dir}", dir.to_str().unwrap())
        };
        std::fs::create_dir_all(&img).unwrap();
        let o = std::process::Command::new("python3")
            .arg(root.join(format!("scripts/plot/{}.py", case.plot)))
            .args(case.args.iter().map(|a| fill(a)))
            .env("MPLBACKEND", "Agg")
            .env_remove("DISPLAY")
            .output()
            .expect("python3 (pip install -r requirements-dev.txt)");
        let said = format!(
            "{}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(o.status.success(), "{}.py: {said}", case.plot);
        for text in case.says {
            assert!(
                said.contains(text),
                "{}.py does not say {text:?}: {said}",
                case.plot
            );
        }
        for png in case.pngs {
            let path = img.join(png);
            assert!(path.exists(), "{}.py wrote no {png}: {said}", case.plot);
            let (w, h, px, samples) = decode_png(&path);
            assert!(w >= 300 && h >= 200, "{png}: {w} × {h}");
            let (dark, var) = ink(&px, samples);
            assert!(
                dark > 0.02 && var > 100.0,
                "{png}: ink {dark}, variance {var}"
            );
        }
    }
    // The study table repeats the run's σ_t/f_t as the run printed it.
    let log = std::fs::read_to_string(dir.join("brazilian_disc.log")).unwrap();
    let printed = log
        .split("σ_t/f_t = ")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .expect("the Brazilian disc prints σ_t/f_t");
    let o = std::process::Command::new("python3")
        .arg(root.join("scripts/plot/brazilian_disc_study.py"))
        .arg(dir.join("brazilian_disc.log"))
        .output()
        .unwrap();
    let table = String::from_utf8_lossy(&o.stdout);
    assert!(
        table.contains(&format!("**{printed}**")),
        "σ_t/f_t {printed} not in the study table:\n{table}"
    );
}
