use fdem::loads::ground_motion::*;
use std::path::Path;
#[test]
fn print_numbers() {
    for f in ["IELC180.AT2", "elCentro_Peknold.AT2"] {
        let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/ground_motion").join(f);
        let gm = GroundMotion::read(&p, &ReadOptions::default()).unwrap();
        let pga = gm.pga();
        let maxpos = gm.acc.iter().cloned().fold(f64::MIN, f64::max) / G;
        let pgv = gm.pgv();
        println!("{f}: n={} dur={} pga={:.6} g idx={} t={} maxpos={:.6} pgv={:.5} at {} arias={:.5} d595={:.3} pgd={:?}", gm.acc.len(), gm.duration(), pga.value/G, pga.index, pga.time, maxpos, pgv.value, pgv.time, gm.arias(), gm.significant_duration(), gm.pgd());
        let t = [0.2, 0.5, 1.0, 2.0];
        let a: Vec<f64> = gm.spectrum(&t, 0.05).iter().map(|x| x / G).collect();
        let b: Vec<f64> = gm.spectrum_newmark(&t, 0.05).iter().map(|x| x / G).collect();
        println!("  exact {a:.5?}\n  newmark {b:.5?}");
        let bc = gm.baseline_corrected();
        println!("  bc v_end {:e} u_end {:e} u(50) {:e} pgd {:?}", bc.velocity().last().unwrap(), bc.displacement().last().unwrap(), bc.displacement_at(50.0), bc.pgd());
    }
}
