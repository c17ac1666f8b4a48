//! Whole-step throughput of the elastic core: `cargo bench --bench elastic`.
//!
//! Runs the `fdem bench` elastic case for every law and both layouts at 200k tetrahedra and
//! prints one JSON line each (seconds per stage keyed by stage module name). Targets live here
//! and in docs/performance.md, never in timed tests: ≥ 20 M tet-steps/s for a whole elastic
//! step of a 200k-tet jointed box on 2 cores.

fn main() {
    let tets: usize = std::env::var("FDEM_BENCH_TETS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(200_000);
    let steps: u64 = std::env::var("FDEM_BENCH_STEPS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(200);
    for layout in ["jointed", "continuous"] {
        for law in [
            "elastic/small_strain",
            "elastic/st_venant_kirchhoff",
            "elastic/munjiza",
            "elastic/neo_hookean",
        ] {
            match fdem::cli::bench("elastic", tets, steps, law, "builtin", layout) {
                Ok(r) => println!("{r}"),
                Err(e) => eprintln!("{law} {layout}: {e}"),
            }
        }
    }
}
