//! Fuzzing (issue 15): the mesh, record and table readers, the writers, the command line and
//! the script API are fed mutated valid inputs and random, hostile ones. Every input must end
//! in a result or a clear error: a panic, a hang (a case over its time limit), an allocation
//! beyond the cap below or an abort fails the test and prints the input (and writes it to
//! `target/tmp/fuzz/findings/`).
//!
//! Each target is one test. Without settings they try a few thousand inputs between them (a
//! few seconds, for CI). The campaign (docs/validation.md, "Fuzzing") multiplies the counts:
//!
//! ```text
//! FDEM_FUZZ_SCALE=200 cargo test --release --test fuzz -- --test-threads=1
//! ```
//!
//! Each target prints (and appends to `target/tmp/fuzz/summary.txt`) its number of inputs,
//! how many were accepted and refused, its time and its slowest case.
//!
//! `FDEM_FUZZ_SEED=N` changes the inputs (default 1); every input is a function of its target,
//! the seed and its index, so a reported case is reproduced by its seed and index
//! (`FDEM_FUZZ_CASE=i` runs case i alone and prints it; `FDEM_FUZZ_VERBOSE=1` prints why
//! inputs were refused). Every crash found is kept as a named regression test
//! (`regression_*`, beside its target).

mod common;

use std::alloc::{GlobalAlloc, Layout, System};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Mutex, Once};
use std::time::{Duration, Instant};

// ─── Harness ────────────────────────────────────────────────────────────────────

/// A deterministic generator (fdem's SplitMix64): inputs are reproduced from their seed.
#[derive(Clone)]
struct Rng(fdem::math::SplitMix64);

impl Rng {
    fn new(seed: u64) -> Self {
        Rng(fdem::math::SplitMix64(seed))
    }
    fn u64(&mut self) -> u64 {
        self.0.next_u64()
    }
    /// 0 ..= n − 1 (n > 0).
    fn below(&mut self, n: usize) -> usize {
        (self.u64() % n as u64) as usize
    }
    /// lo ..= hi.
    fn int(&mut self, lo: i64, hi: i64) -> i64 {
        lo + (self.u64() % (hi - lo + 1) as u64) as i64
    }
    /// Uniform in [0, 1).
    fn unit(&mut self) -> f64 {
        self.0.uniform()
    }
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
    fn chance(&mut self, p: f64) -> bool {
        self.unit() < p
    }
    fn pick<'a, T>(&mut self, xs: &'a [T]) -> &'a T {
        &xs[self.below(xs.len())]
    }
    fn word<'a>(&mut self, xs: &[&'a str]) -> &'a str {
        xs[self.below(xs.len())]
    }
}

/// The multiplier of every target's number of inputs (`FDEM_FUZZ_SCALE`, default 1).
fn scale() -> f64 {
    std::env::var("FDEM_FUZZ_SCALE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1.0)
}

/// `FDEM_FUZZ_VERBOSE=1`: print why inputs were refused (to see what the generators reach).
fn verbose() -> bool {
    std::env::var_os("FDEM_FUZZ_VERBOSE").is_some()
}

fn base_seed() -> u64 {
    std::env::var("FDEM_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1)
}

/// Where findings and work files go (under `target/tmp`).
fn fuzz_dir(sub: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("fuzz")
        .join(sub);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A fresh, empty work directory for one target.
fn work_dir(target: &str) -> PathBuf {
    let d = fuzz_dir(&format!("work-{}-{target}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The input each running target is trying: (target, case, seed, input, started).
struct Current {
    target: &'static str,
    case: u64,
    seed: u64,
    input: Vec<u8>,
    started: Instant,
    limit: Duration,
    active: bool,
}

static CURRENT: Mutex<Vec<Current>> = Mutex::new(Vec::new());

/// The table of running cases (a panic while it was held does not make it unusable).
fn current() -> std::sync::MutexGuard<'static, Vec<Current>> {
    CURRENT.lock().unwrap_or_else(|e| e.into_inner())
}

/// Allocations above this (one block) or live memory above [`MAX_LIVE`] are refused: the
/// input that asked is reported and the process stops, as an allocation failure would stop
/// `fdem` (and before it takes the shared machine's memory).
const MAX_ONE: usize = 1 << 30;
const MAX_LIVE: usize = 4 << 30;

struct Capped;
static LIVE: AtomicUsize = AtomicUsize::new(0);

#[global_allocator]
static ALLOC: Capped = Capped;

fn admit(size: usize) -> bool {
    let live = LIVE.fetch_add(size, Ordering::Relaxed) + size;
    if size > MAX_ONE || live > MAX_LIVE {
        LIVE.fetch_sub(size, Ordering::Relaxed);
        report_allocation(size);
        return false;
    }
    true
}

/// Write `s` to stderr without allocating.
fn raw_stderr(s: &[u8]) {
    unsafe {
        libc::write(2, s.as_ptr().cast(), s.len());
    }
}

/// An allocation was refused: print the inputs being tried (without allocating) before the
/// allocation failure aborts the process.
fn report_allocation(size: usize) {
    let mut digits = [0u8; 24];
    let mut n = size;
    let mut i = digits.len();
    loop {
        i -= 1;
        digits[i] = b'0' + (n % 10) as u8;
        n /= 10;
        if n == 0 {
            break;
        }
    }
    raw_stderr(b"\nFUZZ FINDING: an allocation of ");
    raw_stderr(&digits[i..]);
    raw_stderr(b" bytes exceeds the fuzzing cap; the inputs being tried:\n");
    if let Ok(cur) = CURRENT.try_lock() {
        for c in cur.iter().filter(|c| c.active) {
            raw_stderr(b"--- target ");
            raw_stderr(c.target.as_bytes());
            raw_stderr(b":\n");
            raw_stderr(&c.input[..c.input.len().min(20_000)]);
            raw_stderr(b"\n");
        }
    }
}

unsafe impl GlobalAlloc for Capped {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        if !admit(l.size()) {
            return std::ptr::null_mut();
        }
        let p = System.alloc(l);
        if p.is_null() {
            LIVE.fetch_sub(l.size(), Ordering::Relaxed);
        }
        p
    }
    unsafe fn alloc_zeroed(&self, l: Layout) -> *mut u8 {
        if !admit(l.size()) {
            return std::ptr::null_mut();
        }
        let p = System.alloc_zeroed(l);
        if p.is_null() {
            LIVE.fetch_sub(l.size(), Ordering::Relaxed);
        }
        p
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        System.dealloc(p, l);
        LIVE.fetch_sub(l.size(), Ordering::Relaxed);
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, new: usize) -> *mut u8 {
        if new > l.size() && !admit(new - l.size()) {
            return std::ptr::null_mut();
        }
        let q = System.realloc(p, l, new);
        if q.is_null() {
            if new > l.size() {
                LIVE.fetch_sub(new - l.size(), Ordering::Relaxed);
            }
        } else if new < l.size() {
            LIVE.fetch_sub(l.size() - new, Ordering::Relaxed);
        }
        q
    }
}

/// Start the watchdog (once): a case running longer than its limit is a hang; its input is
/// printed and written to the findings directory, and the process aborts.
fn init() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // One worker thread: the campaign stays on one core, and `--threads N` in the CLI
        // target is refused (the pool exists) instead of resizing this process's pool.
        let _ = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build_global();
        std::thread::spawn(|| loop {
            std::thread::sleep(Duration::from_millis(250));
            let cur = current();
            if let Some(c) = cur
                .iter()
                .find(|c| c.active && c.started.elapsed() > c.limit)
            {
                let path = fuzz_dir("findings").join(format!("hang-{}-{}.txt", c.target, c.seed));
                let _ = std::fs::write(&path, &c.input);
                eprintln!(
                    "\nFUZZ FINDING: target {} case {} (seed {}) ran longer than {:?}: a hang. Input (also in {}):\n{}",
                    c.target,
                    c.case,
                    c.seed,
                    c.limit,
                    path.display(),
                    String::from_utf8_lossy(&c.input[..c.input.len().min(20_000)])
                );
                std::process::abort();
            }
        });
    });
}

/// How a case ended (a panic is not one of them).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Outcome {
    Ok,
    Err,
}

impl<T, E> From<Result<T, E>> for Outcome {
    fn from(r: Result<T, E>) -> Self {
        if r.is_ok() {
            Outcome::Ok
        } else {
            Outcome::Err
        }
    }
}

/// What one case gets: its generator and a place to put its input before it is tried.
struct Case {
    rng: Rng,
    index: usize,
}

impl Case {
    /// Record the input about to be tried (printed if it panics, hangs or over-allocates).
    fn input(&mut self, bytes: &[u8]) {
        let mut cur = current();
        let c = &mut cur[self.index];
        c.input.clear();
        c.input.extend_from_slice(bytes);
    }
}

/// A panic's message.
fn panic_message(p: &(dyn std::any::Any + Send)) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "(non-string panic)".into())
}

/// Run `ci_cases × FDEM_FUZZ_SCALE` cases of `target`. Each case gets its own generator;
/// `run` records its input with [`Case::input`] before trying it and returns the outcome.
/// Panics are collected and reported at the end with their inputs; the counts and the time
/// are printed (docs/validation.md quotes them).
fn campaign(
    target: &'static str,
    ci_cases: u64,
    limit: Duration,
    mut run: impl FnMut(&mut Case) -> Outcome,
) {
    init();
    let cases = ((ci_cases as f64) * scale()).round().max(1.0) as u64;
    let seed0 = base_seed().wrapping_mul(0x100_0000_01B3).wrapping_add(
        target.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
            (h ^ b as u64).wrapping_mul(0x100_0000_01B3)
        }),
    );
    let index = {
        let mut cur = current();
        cur.push(Current {
            target,
            case: 0,
            seed: 0,
            input: Vec::new(),
            started: Instant::now(),
            limit,
            active: false,
        });
        cur.len() - 1
    };
    let start = Instant::now();
    let (mut ok, mut errs, mut slowest) = (0u64, 0u64, (Duration::ZERO, 0u64));
    let mut failures: Vec<String> = Vec::new();
    // `FDEM_FUZZ_CASE=i`: only case i (its input is printed), to reproduce a report.
    let only: Option<u64> = std::env::var("FDEM_FUZZ_CASE")
        .ok()
        .and_then(|s| s.parse().ok());
    for i in 0..cases {
        if only.is_some_and(|k| k != i) {
            continue;
        }
        let seed = seed0.wrapping_add(i.wrapping_mul(0x9E37_79B9));
        {
            let mut cur = current();
            let c = &mut cur[index];
            c.case = i;
            c.seed = seed;
            c.input.clear();
            c.started = Instant::now();
            c.active = true;
        }
        let t = Instant::now();
        let mut case = Case {
            rng: Rng::new(seed),
            index,
        };
        let r = catch_unwind(AssertUnwindSafe(|| run(&mut case)));
        let took = t.elapsed();
        if only.is_some() {
            eprintln!(
                "case {i} (seed {seed}), {:.1} ms: {r:?}\n{}",
                took.as_secs_f64() * 1e3,
                String::from_utf8_lossy(&current()[index].input)
            );
        }
        if took > slowest.0 {
            slowest = (took, i);
        }
        let mut cur = current();
        cur[index].active = false;
        match r {
            Ok(Outcome::Ok) => ok += 1,
            Ok(Outcome::Err) => errs += 1,
            Err(p) => {
                let input = cur[index].input.clone();
                drop(cur);
                let path = fuzz_dir("findings").join(format!("panic-{target}-{seed}.txt"));
                let _ = std::fs::write(&path, &input);
                failures.push(format!(
                    "case {i} (seed {seed}): panic: {}\ninput (also in {}):\n{}",
                    panic_message(&*p),
                    path.display(),
                    String::from_utf8_lossy(&input[..input.len().min(4000)])
                ));
                if failures.len() >= 10 {
                    break;
                }
            }
        }
    }
    let secs = start.elapsed().as_secs_f64();
    let summary = format!(
        "fuzz {target}: {} inputs in {secs:.1} s ({:.0}/s): {ok} ok, {errs} errors, {} panics; slowest case {} ({:.1} ms); scale {}, seed {}",
        ok + errs + failures.len() as u64,
        (ok + errs) as f64 / secs,
        failures.len(),
        slowest.1,
        slowest.0.as_secs_f64() * 1e3,
        scale(),
        base_seed()
    );
    eprintln!("{summary}");
    // Also appended to target/tmp/fuzz/summary.txt (the test harness hides the output of
    // tests that pass).
    use std::io::Write;
    if let Ok(mut f) = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(fuzz_dir("").join("summary.txt"))
    {
        let _ = writeln!(f, "{summary}");
    }
    assert!(
        failures.is_empty(),
        "fuzz {target}: {} input(s) panicked:\n\n{}",
        failures.len(),
        failures.join("\n\n")
    );
}

// ─── Mutation ───────────────────────────────────────────────────────────────────

/// Tokens that break counts, tags and numbers.
const INTERESTING_TOKENS: &[&str] = &[
    "0",
    "-1",
    "1",
    "2",
    "3",
    "4",
    "15",
    "2147483647",
    "2147483648",
    "4294967295",
    "4294967296",
    "9223372036854775807",
    "9223372036854775808",
    "18446744073709551615",
    "18446744073709551616",
    "-9223372036854775808",
    "99999999999999999999",
    "1e308",
    "1e309",
    "-1e309",
    "1e-320",
    "nan",
    "NaN",
    "inf",
    "-inf",
    "0.5",
    "1.5",
    "-0",
    "",
    "\"",
    "\"a\"",
    ",",
    "\t",
    "é",
    "\u{feff}",
    "\r",
];

const INTERESTING_U64: &[u64] = &[
    0,
    1,
    2,
    3,
    4,
    0x7fff_ffff,
    0x8000_0000,
    0xffff_ffff,
    1 << 32,
    1 << 62,
    u64::MAX,
    u64::MAX - 1,
];

/// Byte ranges of the whitespace-separated tokens of `b`.
fn token_spans(b: &[u8]) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut i = 0;
    while i < b.len() {
        while i < b.len() && b[i].is_ascii_whitespace() {
            i += 1;
        }
        let s = i;
        while i < b.len() && !b[i].is_ascii_whitespace() {
            i += 1;
        }
        if i > s {
            spans.push((s, i));
        }
    }
    spans
}

/// Line ranges of `b` (without their `\n`).
fn line_spans(b: &[u8]) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut s = 0;
    for (i, &c) in b.iter().enumerate() {
        if c == b'\n' {
            spans.push((s, i));
            s = i + 1;
        }
    }
    if s < b.len() {
        spans.push((s, b.len()));
    }
    spans
}

/// One random structure-aware mutation of `b`: byte edits, token replacement with
/// interesting numbers and words, integer fields overwritten (binary), line duplication,
/// deletion and swaps, truncation, splices with `other`, and `extra` tokens (section names,
/// header keys) inserted.
fn mutate(rng: &mut Rng, b: &mut Vec<u8>, other: &[u8], extra: &[&str]) {
    let n = b.len();
    match rng.below(13) {
        0 => b.truncate(rng.below(n + 1)),
        1 if n > 0 => {
            let s = rng.below(n);
            let e = (s + 1 + rng.below(16)).min(n);
            b.drain(s..e);
        }
        2 if n > 0 => {
            let s = rng.below(n);
            let e = (s + 1 + rng.below(64)).min(n);
            let copy = b[s..e].to_vec();
            let at = rng.below(n + 1);
            b.splice(at..at, copy);
        }
        3 if n > 0 => {
            for _ in 0..1 + rng.below(8) {
                let i = rng.below(n);
                b[i] = rng.u64() as u8;
            }
        }
        4 if n > 0 => {
            let i = rng.below(n);
            b[i] ^= 1 << rng.below(8);
        }
        5 | 6 => {
            let spans = token_spans(b);
            if !spans.is_empty() {
                let (s, e) = *rng.pick(&spans);
                let tok: &str = if !extra.is_empty() && rng.chance(0.3) {
                    rng.word(extra)
                } else {
                    rng.word(INTERESTING_TOKENS)
                };
                b.splice(s..e, tok.bytes());
            }
        }
        7 if n >= 8 => {
            let v = *rng.pick(INTERESTING_U64);
            let w = if rng.chance(0.5) { 4 } else { 8 };
            let at = rng.below(n - w + 1);
            let bytes = if rng.chance(0.8) {
                v.to_le_bytes()
            } else {
                v.to_be_bytes()
            };
            b[at..at + w].copy_from_slice(&bytes[..w]);
        }
        8 => {
            let lines = line_spans(b);
            if !lines.is_empty() {
                let (s, e) = *rng.pick(&lines);
                let mut copy = b[s..e].to_vec();
                copy.push(b'\n');
                let (at, _) = *rng.pick(&lines);
                b.splice(at..at, copy);
            }
        }
        9 => {
            let lines = line_spans(b);
            if !lines.is_empty() {
                let (s, e) = *rng.pick(&lines);
                b.drain(s..(e + 1).min(b.len()));
            }
        }
        10 => {
            let lines = line_spans(b);
            if lines.len() >= 2 {
                let (i, j) = (rng.below(lines.len()), rng.below(lines.len()));
                let (a, c) = (lines[i.min(j)], lines[i.max(j)]);
                if a.1 <= c.0 {
                    let mut out = b[..a.0].to_vec();
                    out.extend_from_slice(&b[c.0..c.1]);
                    out.extend_from_slice(&b[a.1..c.0]);
                    out.extend_from_slice(&b[a.0..a.1]);
                    out.extend_from_slice(&b[c.1..]);
                    *b = out;
                }
            }
        }
        11 if !other.is_empty() => {
            let cut = rng.below(n + 1);
            let from = rng.below(other.len());
            b.truncate(cut);
            b.extend_from_slice(&other[from..]);
        }
        _ => {
            let at = rng.below(n + 1);
            let tok: &str = if extra.is_empty() {
                rng.word(INTERESTING_TOKENS)
            } else {
                rng.word(extra)
            };
            let mut ins = tok.as_bytes().to_vec();
            ins.push(if rng.chance(0.5) { b'\n' } else { b' ' });
            b.splice(at..at, ins);
        }
    }
}

/// `base` with 1–`max` mutations (one in half the cases, so that many inputs stay close
/// to valid and reach the later stages of a reader).
fn mutated(rng: &mut Rng, base: &[u8], other: &[u8], extra: &[&str], max: usize) -> Vec<u8> {
    let mut b = base.to_vec();
    let n = if rng.chance(0.5) {
        1
    } else {
        1 + rng.below(max)
    };
    for _ in 0..n {
        mutate(rng, &mut b, other, extra);
    }
    b
}

// ─── Target 1: mesh files (MSH 4.1 ASCII and binary, MSH 2.2 ASCII) ───────────────

use fdem::math::Vec3;
use fdem::mesh::gmsh::parse_msh;

/// A valid mesh to write: a box of tetrahedra with a volume group, a face group (the
/// triangles on z = 0, each a face of one tet) and a point group.
struct MshModel {
    nodes: Vec<Vec3>,
    tets: Vec<[u32; 4]>,
    triangles: Vec<[u32; 3]>,
}

fn msh_model(div: [usize; 3]) -> MshModel {
    let m = fdem::mesh::box_mesh(Vec3::zeros(), Vec3::new(1.0, 0.5, 0.25), div);
    let mut triangles = Vec::new();
    for t in &m.tets {
        for skip in 0..4 {
            let f: Vec<u32> = (0..4).filter(|&k| k != skip).map(|k| t[k]).collect();
            if f.iter().all(|&n| m.nodes[n as usize].z == 0.0) {
                triangles.push([f[0], f[1], f[2]]);
            }
        }
    }
    MshModel {
        nodes: m.nodes,
        tets: m.tets,
        triangles,
    }
}

const PHYSICAL_NAMES: &str =
    "$PhysicalNames\n3\n0 5 \"corner\"\n2 2 \"bottom\"\n3 1 \"solid\"\n$EndPhysicalNames\n";

/// MSH 2.2 ASCII.
fn msh22(m: &MshModel) -> Vec<u8> {
    use std::fmt::Write;
    let mut s = String::from("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n");
    s.push_str(PHYSICAL_NAMES);
    let _ = writeln!(s, "$Nodes\n{}", m.nodes.len());
    for (i, p) in m.nodes.iter().enumerate() {
        let _ = writeln!(s, "{} {:?} {:?} {:?}", i + 1, p.x, p.y, p.z);
    }
    s.push_str("$EndNodes\n");
    let _ = writeln!(s, "$Elements\n{}", 1 + m.triangles.len() + m.tets.len());
    let mut tag = 1;
    let _ = writeln!(s, "{tag} 15 2 5 1 1");
    for t in &m.triangles {
        tag += 1;
        let _ = writeln!(s, "{tag} 2 2 2 1 {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    for t in &m.tets {
        tag += 1;
        let _ = writeln!(
            s,
            "{tag} 4 2 1 1 {} {} {} {}",
            t[0] + 1,
            t[1] + 1,
            t[2] + 1,
            t[3] + 1
        );
    }
    s.push_str("$EndElements\n");
    s.into_bytes()
}

/// MSH 4.1 ASCII.
fn msh41_ascii(m: &MshModel) -> Vec<u8> {
    use std::fmt::Write;
    let mut s = String::from("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n");
    s.push_str(PHYSICAL_NAMES);
    s.push_str("$Entities\n1 0 1 1\n1 0 0 0 1 5\n1 0 0 0 1 0.5 0 1 2 0\n1 0 0 0 1 0.5 0.25 1 1 1 1\n$EndEntities\n");
    let n = m.nodes.len();
    let _ = writeln!(s, "$Nodes\n1 {n} 1 {n}\n3 1 0 {n}");
    for i in 0..n {
        let _ = writeln!(s, "{}", i + 1);
    }
    for p in &m.nodes {
        let _ = writeln!(s, "{:?} {:?} {:?}", p.x, p.y, p.z);
    }
    s.push_str("$EndNodes\n");
    let total = 1 + m.triangles.len() + m.tets.len();
    let _ = writeln!(s, "$Elements\n3 {total} 1 {total}\n0 1 15 1\n1 1");
    let _ = writeln!(s, "2 1 2 {}", m.triangles.len());
    let mut tag = 1;
    for t in &m.triangles {
        tag += 1;
        let _ = writeln!(s, "{tag} {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    let _ = writeln!(s, "3 1 4 {}", m.tets.len());
    for t in &m.tets {
        tag += 1;
        let _ = writeln!(
            s,
            "{tag} {} {} {} {}",
            t[0] + 1,
            t[1] + 1,
            t[2] + 1,
            t[3] + 1
        );
    }
    s.push_str("$EndElements\n");
    s.into_bytes()
}

/// MSH 4.1 binary with `size_t` of `st` bytes, little- or big-endian.
fn msh41_binary(m: &MshModel, st: usize, big: bool) -> Vec<u8> {
    let mut b: Vec<u8> = format!("$MeshFormat\n4.1 1 {st}\n").into_bytes();
    let int = |b: &mut Vec<u8>, v: i32| {
        b.extend_from_slice(&if big {
            v.to_be_bytes()
        } else {
            v.to_le_bytes()
        })
    };
    let size = |b: &mut Vec<u8>, v: u64| {
        let bytes = if big {
            v.to_be_bytes()
        } else {
            v.to_le_bytes()
        };
        if st == 8 {
            b.extend_from_slice(&bytes);
        } else if big {
            b.extend_from_slice(&bytes[4..]);
        } else {
            b.extend_from_slice(&bytes[..4]);
        }
    };
    let dbl = |b: &mut Vec<u8>, v: f64| {
        b.extend_from_slice(&if big {
            v.to_be_bytes()
        } else {
            v.to_le_bytes()
        })
    };
    int(&mut b, 1);
    b.extend_from_slice(b"\n$EndMeshFormat\n");
    b.extend_from_slice(PHYSICAL_NAMES.as_bytes());
    b.extend_from_slice(b"$Entities\n");
    for c in [1, 0, 1, 1] {
        size(&mut b, c);
    }
    // point 1 (group 5); surface 1 (group 2); volume 1 (group 1) bounded by surface 1
    int(&mut b, 1);
    for _ in 0..3 {
        dbl(&mut b, 0.0);
    }
    size(&mut b, 1);
    int(&mut b, 5);
    for (tag, group, bounding) in [(1, 2, 0), (1, 1, 1)] {
        int(&mut b, tag);
        for v in [0.0, 0.0, 0.0, 1.0, 0.5, 0.25] {
            dbl(&mut b, v);
        }
        size(&mut b, 1);
        int(&mut b, group);
        size(&mut b, bounding);
        for _ in 0..bounding {
            int(&mut b, 1);
        }
    }
    b.extend_from_slice(b"\n$EndEntities\n$Nodes\n");
    let n = m.nodes.len() as u64;
    for v in [1, n, 1, n] {
        size(&mut b, v);
    }
    int(&mut b, 3);
    int(&mut b, 1);
    int(&mut b, 0);
    size(&mut b, n);
    for i in 1..=n {
        size(&mut b, i);
    }
    for p in &m.nodes {
        for c in [p.x, p.y, p.z] {
            dbl(&mut b, c);
        }
    }
    b.extend_from_slice(b"\n$EndNodes\n$Elements\n");
    let total = (1 + m.triangles.len() + m.tets.len()) as u64;
    for v in [3, total, 1, total] {
        size(&mut b, v);
    }
    let mut tag = 0u64;
    let mut block = |b: &mut Vec<u8>, dim: i32, kind: i32, elems: Vec<Vec<u32>>| {
        int(b, dim);
        int(b, 1);
        int(b, kind);
        size(b, elems.len() as u64);
        for e in elems {
            tag += 1;
            size(b, tag);
            for v in e {
                size(b, v as u64 + 1);
            }
        }
    };
    block(&mut b, 0, 15, vec![vec![0]]);
    block(
        &mut b,
        2,
        2,
        m.triangles.iter().map(|t| t.to_vec()).collect(),
    );
    block(&mut b, 3, 4, m.tets.iter().map(|t| t.to_vec()).collect());
    b.extend_from_slice(b"\n$EndElements\n");
    b
}

/// Valid files in every format the reader takes, of two sizes; each is checked to read.
fn msh_corpus() -> Vec<Vec<u8>> {
    let mut out = Vec::new();
    for div in [[1, 1, 1], [2, 2, 1]] {
        let m = msh_model(div);
        out.push(msh22(&m));
        out.push(msh41_ascii(&m));
        out.push(msh41_binary(&m, 8, false));
        out.push(msh41_binary(&m, 4, false));
        out.push(msh41_binary(&m, 8, true));
        for f in &out[out.len() - 5..] {
            let r = parse_msh(f, "seed.msh").unwrap_or_else(|e| panic!("seed file: {e}"));
            assert_eq!(r.mesh.tets.len(), m.tets.len());
            assert_eq!(r.mesh.sets.faces["bottom"].len(), m.triangles.len());
        }
    }
    out
}

/// Words the mesh mutator inserts besides interesting numbers.
const MSH_WORDS: &[&str] = &[
    "$MeshFormat",
    "$EndMeshFormat",
    "$Nodes",
    "$EndNodes",
    "$Elements",
    "$EndElements",
    "$Entities",
    "$EndEntities",
    "$PhysicalNames",
    "$EndPhysicalNames",
    "$PartitionedEntities",
    "$Comments",
    "$EndComments",
    "$End",
    "$",
    "4.1",
    "2.2",
    "4.0",
    "2",
    "4",
    "5",
    "11",
    "15",
    "92",
    "93",
    "-4",
];

/// What a caller does with a mesh that was read: the checks of `fdem check --mesh`, and a
/// model built from it and stepped when it has no problems.
fn use_mesh(mesh: &fdem::mesh::Mesh) -> Outcome {
    let _ = mesh.volume();
    let _ = mesh.bounds();
    let _ = mesh.sets.summary();
    let _ = mesh.quality();
    if !mesh.problems().is_empty() {
        return Outcome::Err;
    }
    let mut sim = fdem::Simulation::new();
    let m = sim.add_material(common::material(
        fdem::material::Formulation::Munjiza,
        2500.0,
        1e9,
        0.2,
    ));
    let r = sim
        .add_body("m", mesh, m, fdem::Layout::Continuous)
        .map_err(|e| e.to_string())
        .and_then(|_| sim.prepare().map_err(|e| e.to_string()))
        .and_then(|_| sim.step().map_err(|e| e.to_string()));
    r.into()
}

#[test]
fn fuzz_mesh_files() {
    let corpus = msh_corpus();
    campaign("msh", 3000, Duration::from_secs(20), |c| {
        let base = c.rng.pick(&corpus).clone();
        let other = c.rng.pick(&corpus).clone();
        let input = mutated(&mut c.rng, &base, &other, MSH_WORDS, 4);
        c.input(&input);
        match parse_msh(&input, "fuzz.msh") {
            Ok(imported) => use_mesh(&imported.mesh),
            Err(e) => {
                assert!(!e.message.is_empty());
                Outcome::Err
            }
        }
    });
}

// ─── Target 2: earthquake records (AT2, two-column, one-column) and time tables ───────

use fdem::loads::ground_motion::{Format, GroundMotion, ReadOptions};

/// A record's text in `format`, `n` samples at `dt`, numbers written as PEER does
/// (`-.6403182E-02`) or plainly.
fn record_text(rng: &mut Rng, format: Format, n: usize, dt: f64) -> String {
    use std::fmt::Write;
    let values: Vec<f64> = (0..n).map(|_| rng.uniform(-0.3, 0.3)).collect();
    let num = |v: f64, peer: bool| {
        if peer {
            let s = format!("{:.7E}", v);
            s.replacen("0.", ".", 1)
        } else {
            format!("{v}")
        }
    };
    let peer = rng.chance(0.5);
    let mut s = String::new();
    match format {
        Format::At2 => {
            s.push_str("PEER STRONG MOTION DATABASE RECORD. PROCESSING BY PACIFIC ENGINEERING.\n");
            s.push_str("FUZZ VALLEY, STATION 1, 180\n");
            s.push_str("ACCELERATION TIME HISTORY IN UNITS OF G.\n");
            let _ = writeln!(s, "NPTS=  {n}, DT= {dt:.5} SEC");
            for chunk in values.chunks(5) {
                for v in chunk {
                    let _ = write!(s, "  {}", num(*v, peer));
                }
                s.push('\n');
            }
        }
        Format::TwoColumn => {
            if rng.chance(0.5) {
                s.push_str("time, acceleration\n");
            }
            if rng.chance(0.3) {
                s.push_str("# a comment\n");
            }
            let sep = *rng.pick(&[", ", " ", "\t", ","]);
            for (k, v) in values.iter().enumerate() {
                let _ = writeln!(s, "{}{sep}{}", k as f64 * dt, num(*v, peer));
            }
        }
        Format::OneColumn => {
            if rng.chance(0.5) {
                s.push_str("acceleration\n");
            }
            for v in &values {
                let _ = writeln!(s, "{}", num(*v, peer));
            }
        }
    }
    s
}

const RECORD_WORDS: &[&str] = &[
    "NPTS=",
    "DT=",
    "NPTS=  0,",
    "NPTS= 99999999999999999999,",
    "NPTS=18446744073709551615",
    "NPTS=4294967296",
    "NPTS=2305843009213693952",
    "NPTS= 3,",
    "DT= 0",
    "DT=-1",
    "DT=1e-300",
    "DT=1e300",
    "DT=nan",
    "DT=inf",
    "SEC",
    "npts=5, dt=.01",
    "#",
];

/// A number a script could give (finite), often an awkward one.
fn script_number(rng: &mut Rng, plausible: f64) -> f64 {
    match rng.below(10) {
        0 => 0.0,
        1 => -plausible,
        2 => *rng.pick(&[1e-300, 5e-324, 1e300, -1e300, f64::MAX, f64::MIN_POSITIVE]),
        3 => plausible * 1e6,
        4 => plausible * 1e-6,
        _ => plausible * rng.uniform(0.1, 3.0),
    }
}

/// Random reading options, as `ground_motion(path, #{ … })` can give them (numbers finite;
/// `dt` and `pga` positive, as the script checks them).
fn read_options(rng: &mut Rng) -> ReadOptions {
    let mut o = ReadOptions::default();
    if rng.chance(0.3) {
        o.format = Some(*rng.pick(&[Format::At2, Format::TwoColumn, Format::OneColumn]));
    }
    o.units = *rng.pick(&[9.80665, 1.0, 0.01]);
    let positive = |rng: &mut Rng, p: f64| {
        let x = script_number(rng, p);
        if x > 0.0 {
            x
        } else {
            p
        }
    };
    if rng.chance(0.3) {
        o.dt = Some(positive(rng, 0.01));
    }
    if rng.chance(0.2) {
        o.scale = Some(script_number(rng, 1.5));
    }
    if rng.chance(0.2) {
        o.pga = Some(positive(rng, 2.0));
    }
    if rng.chance(0.2) {
        o.start = Some(script_number(rng, 0.05));
    }
    if rng.chance(0.2) {
        o.end = Some(script_number(rng, 0.2));
    }
    o.baseline = rng.chance(0.3);
    o
}

/// Everything a script asks of a record (the properties of `ground_motion(..)`, `at`,
/// `velocity_at`, `displacement_at`, `spectrum`), at awkward times and periods.
fn use_record(rng: &mut Rng, gm: &GroundMotion) {
    let _ = (
        gm.pga(),
        gm.pgv(),
        gm.pgd(),
        gm.arias(),
        gm.significant_duration(),
    );
    let _ = gm.duration();
    let k = gm.kinematics();
    for _ in 0..4 {
        let t = match rng.below(4) {
            0 => *rng.pick(&[
                0.0,
                -1.0,
                f64::NAN,
                f64::INFINITY,
                -f64::INFINITY,
                1e300,
                -1e300,
                5e-324,
            ]),
            _ => rng.uniform(-0.1, 1.2) * gm.duration(),
        };
        let _ = (gm.at(t), k.velocity_at(t), k.displacement_at(t));
    }
    // Periods as `record.spectrum(periods, damping)` accepts them: positive numbers.
    let periods: Vec<f64> = (0..rng.below(3))
        .map(|_| {
            let p = script_number(rng, 0.5).abs();
            if p > 0.0 {
                p
            } else {
                0.5
            }
        })
        .collect();
    let damping = *rng.pick(&[0.0, 0.05, 0.5, 0.999]);
    // Checked as the script checks them; computed when cheap (the fuzzer's time goes to
    // many inputs, not to the 1e8 steps a spectrum may take).
    let steps: f64 = periods
        .iter()
        .map(|&t| fdem::loads::ground_motion::sdof_steps(gm.acc.len(), gm.dt, t))
        .sum();
    if gm.check_spectrum_periods(&periods).is_ok() && steps < 1e5 {
        let _ = gm.spectrum(&periods, damping);
    }
}

#[test]
fn fuzz_records() {
    let real: Vec<String> = ["IELC180.AT2", "elCentro_Peknold.AT2"]
        .iter()
        .map(|f| {
            std::fs::read_to_string(
                Path::new(env!("CARGO_MANIFEST_DIR"))
                    .join("data/ground_motion")
                    .join(f),
            )
            .unwrap()
        })
        .collect();
    campaign("records", 3000, Duration::from_secs(20), |c| {
        let rng = &mut c.rng;
        let format = *rng.pick(&[Format::At2, Format::TwoColumn, Format::OneColumn]);
        let base = if format == Format::At2 && rng.chance(0.02) {
            rng.pick(&real).clone()
        } else {
            let n = 1 + rng.below(40);
            let dt = *rng.pick(&[0.01, 0.005, 0.02]);
            record_text(rng, format, n, dt)
        };
        let other = record_text(rng, format, 5, 0.01);
        let text = mutated(rng, base.as_bytes(), other.as_bytes(), RECORD_WORDS, 3);
        let text = String::from_utf8_lossy(&text).into_owned();
        let opts = read_options(rng);
        let file_format = if rng.chance(0.8) {
            format
        } else {
            *rng.pick(&[Format::At2, Format::TwoColumn, Format::OneColumn])
        };
        let mut input = format!("format {file_format:?}, options {opts:?}\n").into_bytes();
        input.extend_from_slice(text.as_bytes());
        c.input(&input);
        match GroundMotion::from_text(&text, "fuzz.rec", "fuzz.rec", file_format, &opts) {
            Ok(gm) => {
                use_record(&mut c.rng, &gm);
                Outcome::Ok
            }
            Err(e) => {
                assert!(e.contains("fuzz.rec"), "an error without the file: {e}");
                Outcome::Err
            }
        }
    });
}

#[test]
fn fuzz_tables() {
    use fdem::loads::{parse_table, TimeFunction};
    campaign("tables", 3000, Duration::from_secs(20), |c| {
        let rng = &mut c.rng;
        let n = 1 + rng.below(12);
        let base = record_text(rng, Format::TwoColumn, n, 0.1);
        let other = record_text(rng, Format::OneColumn, 3, 0.1);
        let text = mutated(rng, base.as_bytes(), other.as_bytes(), &["#", "t, v"], 3);
        let text = String::from_utf8_lossy(&text).into_owned();
        let scale = script_number(rng, 1.0);
        c.input(format!("scale {scale:?}\n{text}").as_bytes());
        let Ok(points) = parse_table(&text, scale) else {
            return Outcome::Err;
        };
        match TimeFunction::table(points) {
            Ok(f) => {
                for t in [
                    0.0,
                    -1.0,
                    0.35,
                    1e300,
                    f64::NAN,
                    f64::INFINITY,
                    -f64::INFINITY,
                ] {
                    let _ = f.eval(t);
                }
                Outcome::Ok
            }
            Err(_) => Outcome::Err,
        }
    });
}

// ─── Regression tests: every crash the fuzzers found ───────────────────────────────

/// `TimeFunction::eval` at a NaN time indexed the table at usize::MAX (a panic).
#[test]
fn regression_table_at_a_nan_time_is_nan() {
    let f = fdem::loads::TimeFunction::table(vec![(0.0, 0.0), (1.0, 2.0)]).unwrap();
    assert!(f.eval(f64::NAN).is_nan());
    let one = fdem::loads::TimeFunction::table(vec![(0.0, 5.0)]).unwrap();
    assert!(one.eval(f64::NAN).is_nan());
    assert_eq!(f.eval(0.5), 1.0);
}

/// An AT2 header with NPTS = 4294967295 reserved 34 GB for the values before the count was
/// found wrong (an allocation abort).
#[test]
fn regression_at2_with_a_huge_npts_is_an_error_not_an_allocation() {
    let text = "PEER\nX\nUNITS OF G\nNPTS=  4294967295 DT= 0.02000 SEC\n  0.1 0.2\n";
    let e = fdem::loads::ground_motion::parse_at2(text, "big.AT2").unwrap_err();
    assert!(
        e.contains("NPTS = 4294967295") && e.contains("2 values"),
        "{e}"
    );
}

/// A record's velocity or displacement at a time far beyond its end (1e300 s, which a
/// script may give to `record.velocity_at`) turned into an index past the samples (a panic).
#[test]
fn regression_record_kinematics_far_beyond_the_end() {
    let gm = GroundMotion::from_text(
        "0 0.1\n0.01 0.2\n0.02 -0.1\n",
        "r.csv",
        "r.csv",
        Format::TwoColumn,
        &ReadOptions::default(),
    )
    .unwrap();
    let k = gm.kinematics();
    let (v_end, u_end) = (*k.v.last().unwrap(), *k.u.last().unwrap());
    assert_eq!(k.velocity_at(1e300), v_end);
    assert_eq!(k.displacement_at(1e300), u_end + v_end * (1e300 - 0.03));
    assert_eq!(k.velocity_at(f64::INFINITY), v_end);
}

/// `record.spectrum([5e5], ..)` of a record with dt = 1e-8 s reserved 4e14 bytes for the
/// response (an allocation abort), and would have taken 5e13 steps: the periods' total cost
/// is checked first, and the peak no longer keeps the whole response.
#[test]
fn regression_spectrum_of_a_very_long_period_is_refused() {
    let gm = GroundMotion::from_text(
        "0.1\n-0.2\n0.05\n",
        "r.txt",
        "r.txt",
        Format::OneColumn,
        &ReadOptions {
            dt: Some(1e-8),
            ..Default::default()
        },
    )
    .unwrap();
    let e = gm.check_spectrum_periods(&[0.5, 5e5]).unwrap_err();
    assert!(e.contains("steps") && e.contains("1e8"), "{e}");
    assert!(gm.check_spectrum_periods(&[f64::INFINITY]).is_err());
    assert!(gm.check_spectrum_periods(&[1e-7]).is_ok());
    assert!(gm.spectrum(&[1e-7], 0.05)[0].is_finite());
}

// ─── Target 3: writers (VTU frames, PVD series, CSV histories) ──────────────────

use fdem::io::vtu::{encode_pvd, encode_vtu_with, DataArray, Encoding, Field, VtuFrame};

/// Awkward values: NaN, ±∞, ±0, subnormals, extremes, and ordinary numbers.
fn awkward_f64(rng: &mut Rng) -> f64 {
    match rng.below(8) {
        0 => *rng.pick(&[
            f64::NAN,
            -f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            0.0,
            -0.0,
            5e-324,
            f64::MIN_POSITIVE,
            f64::MAX,
            f64::MIN,
            1e15,
            1e15 - 1.0,
            -9007199254740993.0,
            0.1,
        ]),
        1 => f64::from_bits(rng.u64()),
        2 => rng.int(-1_000_000, 1_000_000) as f64,
        _ => rng.uniform(-1e3, 1e3),
    }
}

/// Names of fields and columns: ordinary, with XML and CSV specials, unicode, and invalid.
const ODD_NAMES: &[&str] = &[
    "displacement",
    "velocity",
    "stress",
    "a b",
    "x,y",
    "say \"hi\"",
    "<tag>",
    "a&b",
    "it's",
    "ünïcödé σ",
    "日本",
    "🦀",
    "",
    "tab\there",
    "line\nbreak",
    "nul\0",
    "\u{7f}",
    "\u{85}next",
    "\u{fffe}",
    "\u{ffff}",
    "\u{feff}bom",
    "=1+1",
    "-",
    "_",
];

fn odd_name(rng: &mut Rng) -> String {
    if rng.chance(0.05) {
        "n".repeat(1 + rng.below(5000))
    } else {
        rng.pick(ODD_NAMES).to_string()
    }
}

/// The values of one field, owned.
enum Values {
    Scalar(Vec<f64>),
    Vector(Vec<[f64; 3]>),
    Tensor(Vec<[f64; 9]>),
    Int(Vec<i32>),
}

impl Values {
    fn random(rng: &mut Rng, n: usize) -> Values {
        match rng.below(4) {
            0 => Values::Scalar((0..n).map(|_| awkward_f64(rng)).collect()),
            1 => Values::Vector((0..n).map(|_| [(); 3].map(|_| awkward_f64(rng))).collect()),
            2 => Values::Tensor((0..n).map(|_| [(); 9].map(|_| awkward_f64(rng))).collect()),
            _ => Values::Int((0..n).map(|_| rng.u64() as i32).collect()),
        }
    }
    fn data(&self) -> DataArray<'_> {
        match self {
            Values::Scalar(v) => DataArray::ScalarF64(v),
            Values::Vector(v) => DataArray::VectorF64(v),
            Values::Tensor(v) => DataArray::TensorF64(v),
            Values::Int(v) => DataArray::ScalarI32(v),
        }
    }
    /// The bytes a reader must find in the block (little endian).
    fn bytes(&self) -> Vec<u8> {
        let mut out = Vec::new();
        match self {
            Values::Scalar(v) => v.iter().for_each(|x| out.extend(x.to_le_bytes())),
            Values::Vector(v) => v.iter().flatten().for_each(|x| out.extend(x.to_le_bytes())),
            Values::Tensor(v) => v.iter().flatten().for_each(|x| out.extend(x.to_le_bytes())),
            Values::Int(v) => v.iter().for_each(|x| out.extend(x.to_le_bytes())),
        }
        out
    }
    fn len(&self) -> usize {
        match self {
            Values::Scalar(v) => v.len(),
            Values::Vector(v) => v.len(),
            Values::Tensor(v) => v.len(),
            Values::Int(v) => v.len(),
        }
    }
}

/// Whether `c` may appear in an XML 1.0 document.
fn xml_char(c: char) -> bool {
    matches!(c, '\t' | '\n' | '\r' | '\u{20}'..='\u{d7ff}' | '\u{e000}'..='\u{fffd}' | '\u{10000}'..)
}

fn xml_unescape(s: &str) -> String {
    s.replace("&#9;", "\t")
        .replace("&#10;", "\n")
        .replace("&#13;", "\r")
        .replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&quot;", "\"")
        .replace("&apos;", "'")
        .replace("&amp;", "&")
}

/// The value of attribute `key` in an XML element's text.
fn attribute<'a>(element: &'a str, key: &str) -> Option<&'a str> {
    let i = element.find(&format!(" {key}=\""))? + key.len() + 3;
    let j = element[i..].find('"')? + i;
    Some(&element[i..j])
}

fn base64_decode(s: &[u8]) -> Vec<u8> {
    let val = |c: u8| -> u32 {
        match c {
            b'A'..=b'Z' => (c - b'A') as u32,
            b'a'..=b'z' => (c - b'a' + 26) as u32,
            b'0'..=b'9' => (c - b'0' + 52) as u32,
            b'+' => 62,
            b'/' => 63,
            _ => panic!("not base64: {c}"),
        }
    };
    let mut out = Vec::new();
    for q in s.chunks(4) {
        let pad = q.iter().filter(|&&c| c == b'=').count();
        let n = q[..4 - pad].iter().fold(0u32, |n, &c| (n << 6) | val(c)) << (6 * pad);
        let bytes = [(n >> 16) as u8, (n >> 8) as u8, n as u8];
        out.extend_from_slice(&bytes[..3 - pad]);
    }
    out
}

/// Read a `.vtu` file as a reader would, and check it holds exactly `expected` blocks
/// (name, components, little-endian data) in order, the counts, and valid XML text.
fn check_vtu(bytes: &[u8], n_points: usize, n_cells: usize, expected: &[(String, usize, Vec<u8>)]) {
    let marker = b"   _";
    let at = bytes
        .windows(marker.len())
        .position(|w| w == marker)
        .expect("appended data marker")
        + marker.len();
    let xml = std::str::from_utf8(&bytes[..at]).expect("the XML part is UTF-8");
    assert!(xml.chars().all(xml_char), "a character XML does not allow");
    assert!(bytes.ends_with(b"</AppendedData>\n</VTKFile>\n"));
    let piece = xml.lines().find(|l| l.contains("<Piece")).unwrap();
    assert_eq!(
        attribute(piece, "NumberOfPoints"),
        Some(&*n_points.to_string())
    );
    assert_eq!(
        attribute(piece, "NumberOfCells"),
        Some(&*n_cells.to_string())
    );
    let base64 = xml.contains("encoding=\"base64\"");
    let arrays: Vec<&str> = xml.lines().filter(|l| l.contains("<DataArray")).collect();
    assert_eq!(arrays.len(), expected.len());
    for (a, (name, comps, data)) in arrays.iter().zip(expected) {
        assert_eq!(&xml_unescape(attribute(a, "Name").unwrap()), name);
        let c: usize = attribute(a, "NumberOfComponents").map_or(1, |c| c.parse().unwrap());
        assert_eq!(c, *comps, "{name}");
        let off: usize = attribute(a, "offset").unwrap().parse().unwrap();
        let block = if base64 {
            let len = 4 * (8 + data.len()).div_ceil(3);
            base64_decode(&bytes[at + off..at + off + len])
        } else {
            bytes[at + off..at + off + 8 + data.len()].to_vec()
        };
        let nbytes = u64::from_le_bytes(block[..8].try_into().unwrap());
        assert_eq!(nbytes as usize, data.len(), "{name}");
        assert!(block[8..] == data[..], "{name}: the data differ");
    }
}

#[test]
fn fuzz_vtu_frames() {
    campaign("vtu", 2000, Duration::from_secs(20), |c| {
        let rng = &mut c.rng;
        let n_points = rng.below(12);
        let points: Vec<[f64; 3]> = (0..n_points)
            .map(|_| [(); 3].map(|_| awkward_f64(rng)))
            .collect();
        let index = |rng: &mut Rng| -> u32 {
            if n_points > 0 && rng.chance(0.97) {
                rng.below(n_points) as u32
            } else {
                *rng.pick(&[n_points as u32, n_points as u32 + 1, u32::MAX])
            }
        };
        let n_cells = rng.below(8);
        let kinds = match rng.below(10) {
            0 => [true, true, false],
            1 => [false, true, true],
            2 => [false, false, false],
            k => [k % 3 == 0, k % 3 == 1, k % 3 == 2],
        };
        let count = |on: bool| if on { n_cells } else { 0 };
        let tets: Vec<[u32; 4]> = (0..count(kinds[0]))
            .map(|_| [(); 4].map(|_| index(rng)))
            .collect();
        let triangles: Vec<[u32; 3]> = (0..count(kinds[1]))
            .map(|_| [(); 3].map(|_| index(rng)))
            .collect();
        let lines: Vec<[u32; 2]> = (0..count(kinds[2]))
            .map(|_| [(); 2].map(|_| index(rng)))
            .collect();
        let (stride, cell_type, connectivity): (usize, u8, Vec<u32>) = if !triangles.is_empty() {
            (3, 5, triangles.concat())
        } else if !lines.is_empty() {
            (2, 3, lines.concat())
        } else {
            (4, 10, tets.concat())
        };
        let cells = connectivity.len() / stride;
        let fields = |rng: &mut Rng, n: usize| -> Vec<(String, Values)> {
            (0..rng.below(4))
                .map(|_| {
                    let len = if rng.chance(0.9) { n } else { n + 1 };
                    (odd_name(rng), Values::random(rng, len))
                })
                .collect()
        };
        let point_fields = fields(rng, n_points);
        let cell_fields = fields(rng, cells);
        let encoding = if rng.chance(0.5) {
            Encoding::Raw
        } else {
            Encoding::Base64
        };
        let frame = VtuFrame {
            points: DataArray::VectorF64(&points),
            tets: &tets,
            triangles: &triangles,
            lines: &lines,
            point_data: point_fields
                .iter()
                .map(|(name, v)| Field {
                    name,
                    data: v.data(),
                })
                .collect(),
            cell_data: cell_fields
                .iter()
                .map(|(name, v)| Field {
                    name,
                    data: v.data(),
                })
                .collect(),
        };
        c.input(format!("{frame:#?}\nencoding {encoding:?}").as_bytes());
        // What the writer must refuse, found independently of it.
        let bad_fields = |fs: &[(String, Values)], n: usize| {
            fs.iter().enumerate().any(|(k, (name, v))| {
                name.is_empty()
                    || !name.chars().all(|c| xml_char(c) && !c.is_control())
                    || fs[..k].iter().any(|g| &g.0 == name)
                    || v.len() != n
            })
        };
        let must_fail = kinds.iter().filter(|&&k| k && n_cells > 0).count() > 1
            || bad_fields(&point_fields, n_points)
            || bad_fields(&cell_fields, cells)
            || connectivity.iter().any(|&i| i as usize >= n_points);
        let r = encode_vtu_with(&frame, encoding);
        assert_eq!(
            r.is_err(),
            must_fail,
            "the writer's verdict differs from the expected one: {:?}",
            r.as_ref().err()
        );
        if let Ok(bytes) = &r {
            let mut expected: Vec<(String, usize, Vec<u8>)> = point_fields
                .iter()
                .chain(&cell_fields)
                .map(|(name, v)| {
                    let comps = match v {
                        Values::Vector(_) => 3,
                        Values::Tensor(_) => 9,
                        _ => 1,
                    };
                    (name.clone(), comps, v.bytes())
                })
                .collect();
            let flat: Vec<f64> = points.iter().flatten().copied().collect();
            expected.push(("Points".into(), 3, Values::Scalar(flat).bytes()));
            let conn: Vec<u8> = connectivity
                .iter()
                .flat_map(|&i| (i as i64).to_le_bytes())
                .collect();
            expected.push(("connectivity".into(), 1, conn));
            let offsets: Vec<u8> = (1..=cells as i64)
                .flat_map(|k| (k * stride as i64).to_le_bytes())
                .collect();
            expected.push(("offsets".into(), 1, offsets));
            expected.push(("types".into(), 1, vec![cell_type; cells]));
            check_vtu(bytes, n_points, cells, &expected);
        }
        r.into()
    });
}

#[test]
fn fuzz_pvd_series() {
    campaign("pvd", 2000, Duration::from_secs(20), |c| {
        let rng = &mut c.rng;
        let entries: Vec<(f64, String)> = (0..rng.below(6))
            .map(|_| (awkward_f64(rng), odd_name(rng)))
            .collect();
        c.input(format!("{entries:?}").as_bytes());
        let bytes = encode_pvd(&entries);
        let xml = String::from_utf8(bytes).expect("UTF-8");
        assert!(xml.chars().all(xml_char), "a character XML does not allow");
        let sets: Vec<&str> = xml.lines().filter(|l| l.contains("<DataSet")).collect();
        assert_eq!(sets.len(), entries.len());
        for (l, (t, file)) in sets.iter().zip(&entries) {
            let back: f64 = attribute(l, "timestep").unwrap().parse().unwrap();
            assert!(back == *t || (back.is_nan() && t.is_nan()), "{t} → {back}");
            // Characters XML cannot hold become U+FFFD; every other reads back.
            let kept: String = file
                .chars()
                .map(|c| if xml_char(c) { c } else { '\u{fffd}' })
                .collect();
            assert_eq!(xml_unescape(attribute(l, "file").unwrap()), kept);
        }
        Outcome::Ok
    });
}

/// The fields of an RFC 4180 CSV line (quoted fields may hold commas and doubled quotes).
fn csv_fields(line: &str) -> Vec<String> {
    let mut out = vec![String::new()];
    let mut quoted = false;
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match (c, quoted) {
            ('"', true) if chars.peek() == Some(&'"') => {
                chars.next();
                out.last_mut().unwrap().push('"');
            }
            ('"', _) => quoted = !quoted,
            (',', false) => out.push(String::new()),
            (c, _) => out.last_mut().unwrap().push(c),
        }
    }
    out
}

#[test]
fn fuzz_csv_histories() {
    use fdem::io::{format_number, write_csv, CsvStream};
    let dir = work_dir("csv");
    campaign("csv", 3000, Duration::from_secs(20), |c| {
        let rng = &mut c.rng;
        // Every number written reads back as itself (−0 as 0, NaN as NaN).
        for _ in 0..20 {
            let v = awkward_f64(rng);
            let s = format_number(v);
            let back: f64 = s.parse().unwrap_or_else(|_| panic!("{v:?} → '{s}'"));
            assert!(back == v || (back.is_nan() && v.is_nan()), "{v:?} → '{s}'");
        }
        if !rng.chance(0.1) {
            return Outcome::Ok;
        }
        // A history file: header names (a monitor's name is one) and rows, read back.
        let header: Vec<String> = (0..1 + rng.below(4))
            .map(|_| {
                let n = odd_name(rng);
                if n.chars().any(char::is_control) {
                    "x".into()
                } else {
                    n
                }
            })
            .collect();
        let rows: Vec<Vec<f64>> = (0..rng.below(5))
            .map(|_| (0..header.len()).map(|_| awkward_f64(rng)).collect())
            .collect();
        let streamed = rng.chance(0.5);
        c.input(format!("header {header:?}\nrows {rows:?}\nstreamed {streamed}").as_bytes());
        let path = dir.join("history.csv");
        let names: Vec<&str> = header.iter().map(|s| s.as_str()).collect();
        if streamed {
            let mut s = CsvStream::create(&path, &names).unwrap();
            for r in &rows {
                s.row(r).unwrap();
            }
        } else {
            write_csv(&path, &names, rows.iter().cloned()).unwrap();
        }
        let text = std::fs::read_to_string(&path).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 1 + rows.len(), "{text}");
        assert_eq!(csv_fields(lines[0]), header, "the header reads back");
        for (l, r) in lines[1..].iter().zip(&rows) {
            let back: Vec<f64> = csv_fields(l).iter().map(|f| f.parse().unwrap()).collect();
            assert_eq!(back.len(), r.len());
        }
        Outcome::Ok
    });
}

/// A field named "\u{fffe}" was written into the `.vtu` XML, which XML does not allow (a
/// reader refuses the file): such names are refused like control characters.
#[test]
fn regression_vtu_field_names_xml_cannot_hold_are_refused() {
    let v = [1.0];
    for name in ["\u{fffe}", "a\u{ffff}"] {
        let frame = VtuFrame {
            points: DataArray::VectorF64(&[[0.0; 3]]),
            tets: &[],
            triangles: &[],
            lines: &[],
            point_data: vec![Field {
                name,
                data: DataArray::ScalarF64(&v),
            }],
            cell_data: vec![],
        };
        let e = encode_vtu_with(&frame, Encoding::Raw).unwrap_err();
        assert!(e.contains("XML does not allow"), "{e}");
    }
}

/// `.pvd` entries: a file name with a line break came out raw (a reader reads it back as a
/// space) and one with U+FFFE made the file invalid XML.
#[test]
fn regression_pvd_file_names_stay_well_formed() {
    let xml = String::from_utf8(encode_pvd(&[
        (0.0, "a\nb".into()),
        (1.0, "c\u{fffe}".into()),
    ]))
    .unwrap();
    assert!(xml.contains("file=\"a&#10;b\""), "{xml}");
    assert!(xml.contains("file=\"c\u{fffd}\""), "{xml}");
    assert!(xml.chars().all(xml_char));
}

/// A monitor named "a,b" (or with a quote) wrote a header of four fields over rows of
/// three: header names are quoted as RFC 4180 says.
#[test]
fn regression_csv_header_names_with_commas_and_quotes_are_quoted() {
    assert_eq!(
        fdem::io::csv_header(&["step", "a,b", "say \"hi\""]),
        "step,\"a,b\",\"say \"\"hi\"\"\"\n"
    );
    let dir = work_dir("csv-regression");
    let opts = fdem::script::RunOptions {
        out_dir: Some(dir.clone()),
        overwrite: true,
        quiet: true,
        ..Default::default()
    };
    let script = "let sim = simulation(#{ name: \"m\" });
let mat = material(\"elastic/munjiza\", #{ density: 2500.0, young: 1.0e9, poisson: 0.2 });
sim.add_body(\"b\", box(#{ min: [0.0, 0.0, 0.0], max: [1.0, 1.0, 1.0] }).mesh(#{ divisions: [1, 1, 1] }), mat);
sim.monitor(\"x,y\", #{ every: 1 }, |s| s.time);
sim.run(#{ steps: 2 });
";
    fdem::script::run_source(&dir.join("m.rhai"), script, opts).unwrap();
    let text = std::fs::read_to_string(dir.join("x,y.csv")).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "step,time,\"x,y\"");
    assert_eq!(csv_fields(lines[0]).len(), csv_fields(lines[1]).len());
}

/// A simulation named "\u{fffe}" named its frames in the `.pvd` file with a character XML
/// does not allow: the name is refused where it is given.
#[test]
fn regression_simulation_names_xml_cannot_hold_are_refused() {
    let dir = work_dir("name-regression");
    let e = fdem::script::run_source(
        &dir.join("n.rhai"),
        "let sim = simulation(#{ name: \"a\\ufffe\" });",
        Default::default(),
    )
    .err()
    .unwrap()
    .to_string();
    assert!(e.contains("cannot name a file"), "{e}");
}

// ─── Target 4: the command line ───────────────────────────────────────────────────

use std::ffi::OsString;

/// Files the command lines name: scripts (good, failing, without params), meshes (valid,
/// broken), a record, and paths that are not there or not files.
struct CliFiles {
    scripts: Vec<String>,
    meshes: Vec<String>,
    outs: Vec<String>,
}

fn cli_files(dir: &Path) -> CliFiles {
    let out = dir.join("out");
    let good = format!(
        "let p = params(#{{ rho: 2500.0, quick: false, name: \"cli\" }});
let sim = simulation(#{{ name: \"cli\", out_dir: \"{}\" }});
let mat = material(\"elastic/munjiza\", #{{ density: p.rho, young: 1.0e9, poisson: 0.2 }});
sim.add_body(\"b\", box(#{{ min: [0.0, 0.0, 0.0], max: [1.0, 1.0, 1.0] }}).mesh(#{{ divisions: [1, 1, 1] }}), mat);
sim.monitor(\"t\", #{{ every: 1 }}, |s| s.time);
if p.quick {{ print(\"quick\"); }}
sim.run(#{{ steps: 3 }});
",
        out.display()
    );
    let files: &[(&str, &[u8])] = &[
        ("good.rhai", good.as_bytes()),
        ("noparams.rhai", b"let x = 1;\nprint(x);\n"),
        ("syntax.rhai", b"let x = ;\n"),
        ("fails.rhai", b"let p = params(#{ n: 1 });\nthrow \"no\";\n"),
        ("check.rhai", b"let sim = simulation(#{ name: \"c\" });\n"),
        ("binary.rhai", b"\xff\xfe\x00let"),
        ("empty.rhai", b""),
        ("notes.txt", b"not a mesh\n"),
    ];
    for (name, text) in files {
        std::fs::write(dir.join(name), text).unwrap();
    }
    let corpus = msh_corpus();
    std::fs::write(dir.join("cube.msh"), &corpus[1]).unwrap();
    std::fs::write(dir.join("cube_binary.msh"), &corpus[2]).unwrap();
    let mut broken = corpus[0].clone();
    broken.truncate(broken.len() / 2);
    std::fs::write(dir.join("broken.msh"), broken).unwrap();
    std::fs::create_dir_all(dir.join("adir.msh")).unwrap();
    let p = |n: &str| dir.join(n).display().to_string();
    CliFiles {
        scripts: [
            "good.rhai",
            "good.rhai",
            "noparams.rhai",
            "syntax.rhai",
            "fails.rhai",
            "check.rhai",
            "binary.rhai",
            "empty.rhai",
            "missing.rhai",
            "notes.txt",
        ]
        .iter()
        .map(|n| p(n))
        .chain(["".to_string(), "/".to_string(), "/dev/null".to_string()])
        .collect(),
        meshes: [
            "cube.msh",
            "cube_binary.msh",
            "broken.msh",
            "adir.msh",
            "missing.msh",
            "missing.geo",
            "notes.txt",
            "good.rhai",
        ]
        .iter()
        .map(|n| p(n))
        .chain(["".to_string(), "/dev/null".to_string()])
        .collect(),
        outs: vec![
            p("out"),
            p("out2"),
            p("cube.msh"),
            "/dev/null/out".into(),
            "".into(),
        ],
    }
}

/// A random `fdem` command line: mostly well-formed subcommands with awkward values, and
/// sometimes garbage (unknown flags, missing values, non-UTF-8 bytes).
fn cli_args(rng: &mut Rng, f: &CliFiles) -> Vec<OsString> {
    use std::os::unix::ffi::OsStringExt;
    let mut a: Vec<OsString> = vec!["fdem".into()];
    let s = |a: &mut Vec<OsString>, x: &str| a.push(x.into());
    let count = |rng: &mut Rng| -> String {
        (*rng.pick(&[
            "0",
            "1",
            "2",
            "4",
            "1024",
            "1025",
            "100000",
            "-1",
            "abc",
            "",
            "18446744073709551615",
            "18446744073709551616",
            "1e3",
        ]))
        .into()
    };
    let seconds = |rng: &mut Rng| -> String {
        (*rng.pick(&[
            "0", "-1", "nan", "NaN", "inf", "1e7", "1e8", "0.001", "1e-300", "abc", "", "600",
            "1e309",
        ]))
        .into()
    };
    let sets = [
        "rho=3000",
        "rho=nan",
        "rho=1e309",
        "rho=abc",
        "quick=true",
        "quick=1",
        "name=x",
        "unknown=1",
        "=1",
        "rho",
        "",
        "rho==2",
        " rho = 2 ",
        "rho=-1",
    ];
    match rng.below(20) {
        0..=7 => {
            s(&mut a, "run");
            a.push(rng.pick(&f.scripts).into());
            for _ in 0..rng.below(6) {
                match rng.below(9) {
                    0 => {
                        s(&mut a, "--set");
                        s(&mut a, rng.word(&sets));
                    }
                    1 => {
                        s(&mut a, "--out");
                        a.push(rng.pick(&f.outs).into());
                    }
                    2 => {
                        s(&mut a, "--threads");
                        a.push(count(rng).into());
                    }
                    3 => s(&mut a, "--quiet"),
                    4 => s(&mut a, "--overwrite"),
                    5 => {
                        s(&mut a, "--max-operations");
                        a.push(count(rng).into());
                    }
                    6 => {
                        s(&mut a, "--gmsh-timeout");
                        a.push(seconds(rng).into());
                    }
                    7 => s(&mut a, "--allow-geo-commands"),
                    _ => s(&mut a, &format!("--set={}", rng.pick(&sets))),
                }
            }
        }
        8..=12 => {
            s(&mut a, "check");
            if rng.chance(0.5) {
                s(&mut a, "--mesh");
                a.push(rng.pick(&f.meshes).into());
            }
            if rng.chance(0.6) {
                a.push(rng.pick(&f.scripts).into());
            }
            for _ in 0..rng.below(3) {
                match rng.below(3) {
                    0 => {
                        s(&mut a, "--set");
                        s(&mut a, rng.word(&sets));
                    }
                    1 => {
                        s(&mut a, "--gmsh-timeout");
                        a.push(seconds(rng).into());
                    }
                    _ => s(&mut a, "--mesh"),
                }
            }
        }
        13 => {
            if rng.chance(0.2) {
                s(&mut a, "doc");
            } else {
                s(
                    &mut a,
                    rng.word(&["--help", "-h", "--version", "-V", "help"]),
                );
            }
        }
        14..=16 => {
            s(&mut a, "bench");
            for _ in 0..rng.below(6) {
                match rng.below(8) {
                    0 => {
                        s(&mut a, "--case");
                        s(
                            &mut a,
                            rng.word(&[
                                "elastic",
                                "joints",
                                "detection",
                                "fragmented",
                                "rebars",
                                "rigid",
                                "nope",
                                "",
                            ]),
                        );
                    }
                    1 | 2 => {
                        s(&mut a, "--tets");
                        s(
                            &mut a,
                            rng.word(&[
                                "1",
                                "6",
                                "50",
                                "500",
                                "0",
                                "-1",
                                "100000000000",
                                "18446744073709551615",
                                "1e9",
                            ]),
                        );
                    }
                    3 => {
                        s(&mut a, "--elements");
                        s(
                            &mut a,
                            rng.word(&[
                                "0",
                                "1",
                                "2",
                                "100",
                                "100000000000",
                                "18446744073709551615",
                            ]),
                        );
                    }
                    4 => {
                        s(&mut a, "--steps");
                        s(&mut a, rng.word(&["0", "1", "2", "-1", "x"]));
                    }
                    5 => {
                        s(&mut a, "--material");
                        s(
                            &mut a,
                            rng.word(&["elastic/small_strain", "elastic/neo_hookean", "steel", ""]),
                        );
                    }
                    6 => {
                        s(&mut a, "--layout");
                        s(&mut a, rng.word(&["jointed", "continuous", "rigid", "x"]));
                    }
                    _ => {
                        s(&mut a, "--law");
                        s(&mut a, rng.word(&["builtin", "script", "x"]));
                    }
                }
            }
        }
        _ => {
            // Garbage: random words, flags and bytes.
            for _ in 0..rng.below(5) {
                match rng.below(5) {
                    0 => a.push(OsString::from_vec(
                        (0..rng.below(6)).map(|_| rng.u64() as u8).collect(),
                    )),
                    1 => s(
                        &mut a,
                        rng.word(&["run", "check", "bench", "doc", "--", "-"]),
                    ),
                    2 => s(
                        &mut a,
                        rng.word(&["--nope", "-x", "--set", "--out", "--threads"]),
                    ),
                    3 => a.push(rng.pick(&f.scripts).into()),
                    _ => s(&mut a, rng.word(&sets)),
                }
            }
        }
    }
    // Now and then a word out of place.
    if rng.chance(0.1) && a.len() > 1 {
        let at = 1 + rng.below(a.len());
        a.insert(
            at,
            (*rng.pick(&["--quiet", "extra", "--set", "-", "--"])).into(),
        );
    }
    // Small benchmarks only: the default is 200 000 tets for 200 steps (seconds, not a hang).
    if a.get(1).is_some_and(|w| w == "bench") {
        for (flag, value) in [("--tets", "50"), ("--steps", "1"), ("--elements", "100")] {
            if !a.iter().any(|x| x == flag) {
                s(&mut a, flag);
                s(&mut a, value);
            }
        }
    }
    a
}

#[test]
fn fuzz_command_line() {
    let dir = work_dir("cli");
    let files = cli_files(&dir);
    campaign("cli", 400, Duration::from_secs(60), |c| {
        let args = cli_args(&mut c.rng, &files);
        c.input(format!("{args:?}").as_bytes());
        let code = fdem::cli::run_args(args);
        assert!(
            (0..=2).contains(&code),
            "exit code {code}: not 0 (success), 1 (an error) or 2 (a usage error)"
        );
        if code == 0 {
            Outcome::Ok
        } else {
            Outcome::Err
        }
    });
}

/// The same command lines through the real `fdem` binary (fewer: a process each): exit
/// code 0, 1 or 2, never a signal or a panic.
#[test]
fn fuzz_command_line_processes() {
    let dir = work_dir("cli-processes");
    let files = cli_files(&dir);
    campaign("cli-processes", 25, Duration::from_secs(60), |c| {
        use std::os::unix::ffi::{OsStrExt, OsStringExt};
        // A process argument cannot hold a NUL byte (the in-process target tries them).
        let args: Vec<OsString> = cli_args(&mut c.rng, &files)
            .into_iter()
            .map(|a| OsString::from_vec(a.as_bytes().iter().map(|&b| b.max(1)).collect()))
            .collect();
        c.input(format!("{args:?}").as_bytes());
        let out = common::fdem().args(&args[1..]).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!stderr.contains("panicked"), "fdem panicked: {stderr}");
        let code = out.status.code();
        assert!(
            matches!(code, Some(0..=2)),
            "exit status {:?}: not 0, 1 or 2 (a signal or a panic?)\n{stderr}",
            out.status
        );
        if code == Some(0) {
            Outcome::Ok
        } else {
            Outcome::Err
        }
    });
}

/// `fdem run SCRIPT --max-operations 2` stopped fdem's own stdlib modules while the engine
/// was built, which was a panic ("stdlib/units.rhai: Script terminated"): the limit watches
/// the user's script only.
#[test]
fn regression_a_tiny_operation_limit_stops_the_script_not_the_stdlib() {
    let dir = work_dir("ops-regression");
    let script = dir.join("loop.rhai");
    std::fs::write(&script, "let x = 0;\nloop { x += 1; }\n").unwrap();
    let code = fdem::cli::run_args([
        "fdem",
        "run",
        script.to_str().unwrap(),
        "--max-operations",
        "2",
    ]);
    assert_eq!(code, 1);
    let (ok, _, stderr) = common::run_script(
        &dir,
        "ops",
        "let y = 1;\nloop { y += 1; }\n",
        &["--max-operations", "2"],
    );
    assert!(
        !ok && stderr.contains("operations without a time step"),
        "{stderr}"
    );
}

/// `fdem bench --tets 18446744073709551615` overflowed the box's capacity (a panic), and
/// `--tets 100000000000` or `--elements 100000000000` asked for terabytes (an allocation
/// abort): the benchmark's size is checked against the memory first.
#[test]
fn regression_bench_sizes_beyond_the_memory_are_refused() {
    for args in [
        &["fdem", "bench", "--tets", "18446744073709551615"][..],
        &["fdem", "bench", "--tets", "100000000000"],
        &[
            "fdem",
            "bench",
            "--case",
            "detection",
            "--elements",
            "100000000000",
        ],
    ] {
        assert_eq!(fdem::cli::run_args(args), 1, "{args:?}");
    }
    let out = common::fdem()
        .args(["bench", "--tets", "18446744073709551615"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("bench: --tets 18446744073709551615") && stderr.contains("memory"),
        "{stderr}"
    );
}

// ─── Target 5: the script API ─────────────────────────────────────────────────────

use fdem::params::{DefaultValue, Param};
use fdem::script::api::{FnDoc, API};

/// A registered script function, from the engine's own signatures: its name, its
/// parameter types (`&mut T` first for methods) and its return type.
#[derive(Clone, Debug)]
struct Sig {
    name: String,
    params: Vec<String>,
    ret: String,
}

/// Every function the script engine registers (the engine is the source: a new binding is
/// fuzzed without touching this file).
fn signatures() -> Vec<Sig> {
    let ctx = std::rc::Rc::new(fdem::script::ScriptContext::new(
        Default::default(),
        "sig.rhai".into(),
    ));
    let engine = fdem::script::build_engine(ctx);
    let mut out: Vec<Sig> = engine
        .gen_fn_signatures(false)
        .into_iter()
        .filter_map(|s| {
            let open = s.find('(')?;
            let close = s[open..].find(')')? + open;
            let name = s[..open].trim().to_string();
            let params = s[open + 1..close]
                .split(", ")
                .filter(|p| !p.is_empty())
                .map(|p| p.trim_start_matches("_: ").to_string())
                .collect();
            let ret = s[close + 1..].trim_start_matches(" -> ").to_string();
            Some(Sig { name, params, ret })
        })
        .filter(|s| s.name != "to_string")
        .collect();
    out.sort_by(|a, b| (&a.name, &a.params).cmp(&(&b.name, &b.params)));
    out
}

/// The script type a function returns (None for numbers, arrays, maps, …).
fn script_type(ret: &str) -> Option<&'static str> {
    const TYPES: &[(&str, &str)] = &[
        ("SimHandle", "Simulation"),
        ("BodyHandle", "Body"),
        ("NodeSet", "Nodes"),
        ("ElementSet", "Elements"),
        ("FaceSet", "Faces"),
        ("MeshValue", "Mesh"),
        ("types::Shape", "Shape"),
        ("MaterialValue", "Material"),
        ("AssemblyValue", "Assembly"),
        ("types::Record", "GroundMotion"),
        ("MonitorHandle", "Monitor"),
        ("RebarHandle", "Rebar"),
        ("types::Table", "Table"),
        ("JointLawValue", "JointLaw"),
        ("SteelValue", "Steel"),
        ("BondLawValue", "BondLaw"),
    ];
    if let Some((_, t)) = TYPES.iter().find(|(n, _)| ret.contains(n)) {
        return Some(t);
    }
    ["Nodes", "Elements", "Mesh", "Faces"]
        .into_iter()
        .find(|t| ret == *t)
}

/// The documentation entries of a function name (methods of several types share a name).
fn docs_of(name: &str) -> Vec<&'static FnDoc> {
    let exact: Vec<&'static FnDoc> = API
        .iter()
        .filter(|f| f.name.rsplit('.').next() == Some(name))
        .collect();
    if !exact.is_empty() {
        return exact;
    }
    // Entries that document several functions name them in their signature.
    let call = format!("{name}(");
    API.iter()
        .filter(|f| {
            f.signature.match_indices(&call).any(|(i, _)| {
                f.signature[..i]
                    .chars()
                    .next_back()
                    .is_none_or(|c| !(c.is_alphanumeric() || c == '_'))
            })
        })
        .collect()
}

/// Quoted words in a text (`"continuous"`, `"x"`): the strings a function documents.
fn quoted_words(text: &str) -> Vec<String> {
    text.split('"')
        .skip(1)
        .step_by(2)
        .filter(|w| !w.is_empty() && w.len() <= 40 && !w.contains(' '))
        .map(|w| w.to_string())
        .collect()
}

/// A float as Rhai reads it.
fn rhai_float(x: f64) -> String {
    if x.is_nan() {
        return "nan".into();
    }
    if x.is_infinite() {
        return if x > 0.0 { "inf" } else { "(-inf)" }.into();
    }
    let s = format!("{x:e}");
    let (m, e) = s.split_once('e').unwrap();
    let m = if m.contains('.') {
        m.to_string()
    } else {
        format!("{m}.0")
    };
    if x < 0.0 {
        format!("({m}e{e})")
    } else {
        format!("{m}e{e}")
    }
}

/// Hostile values of any type: non-finite and extreme numbers, odd strings, empty and
/// malformed arrays and maps, wrong-arity closures, and handles of the other simulation.
const HOSTILE: &[&str] = &[
    "nan",
    "inf",
    "(-inf)",
    "0",
    "0.0",
    "(-0.0)",
    "(-1)",
    "(-1.0)",
    "1.0e300",
    "(-1.0e300)",
    "1.0e-300",
    "5.0e-324",
    "9223372036854775807",
    "(-9223372036854775807 - 1)",
    "4294967296",
    "100000000",
    "1000000000000",
    "\"\"",
    "\"..\"",
    "\"a/b\"",
    "\"energy\"",
    "\"\\u00e9\\u65e5\"",
    "\"x,y\\\"z\"",
    "()",
    "true",
    "[]",
    "[nan, 0.0, 0.0]",
    "[1, 2]",
    "[1.0, 2.0, 3.0, 4.0]",
    "[[]]",
    "[\"a\", \"b\", \"c\"]",
    "#{}",
    "#{ x: 1 }",
    "|| 1",
    "|a, b, c| a",
    "Fn(\"nope\")",
    "sim2",
    "body2",
    "nodes2",
    "faces2",
    "elems2",
    "mesh",
    "mat",
];

/// Files the script may read, written once per campaign: valid and mutated meshes,
/// records and tables, and paths that are not there or are not files.
struct ScriptFiles {
    meshes: Vec<String>,
    records: Vec<String>,
    /// Records that read (the prelude's).
    good_records: Vec<String>,
    tables: Vec<String>,
}

fn script_files(dir: &Path, rng: &mut Rng) -> ScriptFiles {
    let p = |n: &str| dir.join(n).display().to_string();
    let corpus = msh_corpus();
    let mut meshes = vec![
        p("missing.msh"),
        p("missing.geo"),
        "".into(),
        "/dev/null".into(),
        p(""),
    ];
    for (k, base) in corpus.iter().enumerate().take(5) {
        let name = format!("m{k}.msh");
        std::fs::write(dir.join(&name), base).unwrap();
        meshes.push(p(&name));
        let bad = format!("bad{k}.msh");
        std::fs::write(dir.join(&bad), mutated(rng, base, &corpus[0], MSH_WORDS, 2)).unwrap();
        meshes.push(p(&bad));
    }
    let mut records = vec![p("missing.AT2"), "".into(), "/dev/null".into()];
    let mut tables = vec![p("missing.csv"), "".into(), "/dev/null".into()];
    let mut good_records = Vec::new();
    for k in 0..6 {
        let format = [Format::At2, Format::TwoColumn, Format::OneColumn][k % 3];
        let ext = ["AT2", "csv", "txt"][k % 3];
        let n = 5 + rng.below(30);
        let text = record_text(rng, format, n, 0.01);
        let name = format!("r{k}.{ext}");
        std::fs::write(dir.join(&name), &text).unwrap();
        records.push(p(&name));
        if format != Format::OneColumn {
            good_records.push(p(&name));
        }
        let bad = format!("rbad{k}.{ext}");
        let b = mutated(rng, text.as_bytes(), b"", RECORD_WORDS, 2);
        std::fs::write(dir.join(&bad), b).unwrap();
        records.push(p(&bad));
        if k % 3 == 1 {
            tables.push(p(&name));
            tables.push(p(&bad));
        }
    }
    ScriptFiles {
        meshes,
        records,
        good_records,
        tables,
    }
}

/// Inputs of every compiled law (joint, friction, criterion, steel, bond) and a wrong one.
const LAW_INPUTS: &[&str] = &[
    "opening",
    "slip",
    "max_opening",
    "max_slip",
    "size",
    "damage",
    "slip_rate",
    "pressure",
    "normal_force",
    "area",
    "time",
    "mu",
    "strain",
    "strain_rate",
    "plastic_strain",
    "history",
    "young",
    "diameter",
    "speed",
];

/// Generates one script: a valid prelude (two simulations, bodies, selections, a record,
/// laws, a monitor), a few law functions with random bodies, then random calls of the
/// registered functions with documented keys, awkward and hostile values, each in its own
/// `try`, their results kept in slots `v0`..`v5` that later calls may use.
struct ScriptGen<'a> {
    rng: Rng,
    sigs: &'a [Sig],
    files: &'a ScriptFiles,
    /// Variables of each type in scope.
    vars: Vec<(String, &'static str)>,
    /// The type the generator last gave each slot.
    slots: [Option<&'static str>; 6],
}

impl ScriptGen<'_> {
    fn script(&mut self) -> String {
        let mut s = String::new();
        for k in 0..3 {
            s.push_str(&self.law_fn(k));
        }
        s.push_str(&self.prelude());
        for _ in 0..1 + self.rng.below(10) {
            s.push_str(&self.statement(0));
            s.push('\n');
        }
        if self.rng.chance(0.7) {
            let report = if verbose() {
                "print(\"final run ok\"); } catch (e) { print(\"final run error: \" + e); }"
            } else {
                "} catch (e) { }"
            };
            s.push_str(&format!(
                "try {{ sim.run(#{{ steps: {} }}); {report}\n",
                1 + self.rng.below(4)
            ));
        }
        if self.rng.chance(0.3) {
            s.push_str("try { sim.write_vtk(); } catch (e) { }\n");
        }
        s
    }

    fn prelude(&mut self) -> String {
        let rng = &mut self.rng;
        let layout = *rng.pick(&["continuous", "jointed", "rigid"]);
        let record = rng.pick(&self.files.good_records).clone();
        let mut s = format!(
            r#"let nan = parse_float("NaN");
let inf = parse_float("inf");
let sim = simulation(#{{ name: "fz" }});
let sim2 = simulation(#{{ name: "fz2" }});
let mat = material("elastic/munjiza", #{{ density: 2500.0, young: 1.0e9, poisson: 0.2 }});
let shape = box(#{{ min: [0.0, 0.0, 0.0], max: [1.0, 1.0, 1.0] }});
let mesh = shape.mesh(#{{ divisions: [2, 1, 1] }});
let body = sim.add_body("b", mesh, mat, #{{ layout: "{layout}" }});
let body2 = sim2.add_body("c", box(#{{ min: [0.0, 0.0, 0.0], max: [1.0, 1.0, 2.0] }}).mesh(#{{ divisions: [1, 1, 2] }}), mat);
let nodes = body.nodes();
let nodes2 = body2.nodes();
let elems = body.elements();
let elems2 = body2.elements();
let faces = body.boundary();
let faces2 = body2.boundary();
let tab = table([[0.0, 0.0], [1.0, 1.0]]);
let jl = joint_law("cohesive/munjiza", #{{ tensile_strength: 1.0e6, cohesion: 2.0e6, g_i: 10.0, g_ii: 50.0 }});
let stl = steel(#{{ yield_stress: 5.0e8 }});
let bnd = bond_law("fib2010", #{{ fcm: 3.0e7 }});
let rec = ground_motion("{record}", #{{ units: "m/s2" }});
let mon = sim.monitor("m", #{{ every: 1 }}, |s| s.time);
let asm = wall(#{{ courses: 1, bricks_per_course: 2, brick: [0.2, 0.1, 0.1] }});
let v0 = (); let v1 = (); let v2 = (); let v3 = (); let v4 = (); let v5 = ();
"#
        );
        // Laws written in the script (law0..law2 above, random bodies: they compile or are
        // refused), joints, contact and motion, so that runs reach stages 2–5.
        let params = "params: #{ a: 0.5, b: 2.0, k: 1.0 }";
        if layout == "jointed" {
            match rng.below(3) {
                0 => s.push_str("sim.insert_joints(#{ within: body, law: jl });\n"),
                1 => s.push_str(&format!(
                    "try {{ sim.insert_joints(#{{ within: body, law: joint_law(\"script\", #{{ function: \"law{}\", {params} }}) }}); }} catch (e) {{ }}\n",
                    rng.below(3)
                )),
                _ => {}
            }
            if rng.chance(0.3) {
                s.push_str(&format!(
                    "try {{ sim.fracture_criterion(#{{ function: \"law{}\", {params} }}); }} catch (e) {{ }}\n",
                    rng.below(3)
                ));
            }
        }
        match rng.below(3) {
            0 => s.push_str("sim.contact_law(\"potential\", #{ friction: 0.3 });\n"),
            1 => s.push_str(&format!(
                "try {{ sim.contact_law(\"potential\", #{{ friction_law: #{{ function: \"law{}\", {params} }} }}); }} catch (e) {{ }}\n",
                rng.below(3)
            )),
            _ => {}
        }
        if rng.chance(0.3) {
            s.push_str("sim.gravity([0.0, 0.0, -9.81]);\n");
        }
        if layout == "rigid" && rng.chance(0.5) {
            s.push_str("sim.integrator(\"central_difference\", #{ dt: 1.0e-4 });\n");
        }
        if rng.chance(0.3) {
            let v = rng.uniform(0.1, 50.0);
            if layout == "rigid" {
                s.push_str(&format!(
                    "body.set_velocity([{}, 0.0, 0.0]);\n",
                    rhai_float(v)
                ));
            } else {
                s.push_str(&format!(
                "sim.initial_velocity(body.nodes(box(#{{ min: [0.5, -1.0, -1.0], max: [2.0, 2.0, 2.0] }})), [{}, 0.0, 0.0]);\n",
                rhai_float(v)
            ));
            }
        }
        if layout == "continuous" && rng.chance(0.3) {
            s.push_str("let rb = sim.rebar(body, #{ points: [[0.1, 0.5, 0.5], [0.9, 0.5, 0.5]], diameter: 0.02, steel: stl, bond: bnd });\n");
            self.vars.push(("rb".into(), "Rebar"));
        }
        for (v, t) in [
            ("sim", "Simulation"),
            ("sim2", "Simulation"),
            ("mat", "Material"),
            ("shape", "Shape"),
            ("mesh", "Mesh"),
            ("body", "Body"),
            ("body2", "Body"),
            ("nodes", "Nodes"),
            ("nodes2", "Nodes"),
            ("elems", "Elements"),
            ("elems2", "Elements"),
            ("faces", "Faces"),
            ("faces2", "Faces"),
            ("tab", "Table"),
            ("jl", "JointLaw"),
            ("stl", "Steel"),
            ("bnd", "BondLaw"),
            ("rec", "GroundMotion"),
            ("mon", "Monitor"),
            ("asm", "Assembly"),
        ] {
            self.vars.push((v.into(), t));
        }
        s
    }

    /// `fn lawK(j, p) { … }`: a law for `joint_law("script", …)` and the other compiled laws,
    /// with a random body of arithmetic, math functions, `if`, `let` and inputs (some wrong).
    fn law_fn(&mut self, k: usize) -> String {
        let body = if self.rng.chance(0.5) {
            let mut outs = vec!["normal", "shear", "damage", "stress", "friction", "broken"];
            let n = 1 + self.rng.below(3);
            let fields: Vec<String> = (0..n)
                .map(|_| {
                    let o = outs.remove(self.rng.below(outs.len()));
                    format!("{o}: {}", self.expr(0))
                })
                .collect();
            format!("#{{ {} }}", fields.join(", "))
        } else {
            self.expr(0)
        };
        let lets = if self.rng.chance(0.3) {
            format!("let a = {};\n    ", self.expr(1))
        } else {
            String::new()
        };
        format!("fn law{k}(j, p) {{\n    {lets}{body}\n}}\n")
    }

    fn expr(&mut self, depth: usize) -> String {
        let leaf = depth >= 3 || self.rng.chance(0.3);
        if leaf {
            return match self.rng.below(4) {
                0 if self.rng.chance(0.7) => format!("j.{}", self.rng.word(&LAW_INPUTS[..6])),
                0 => format!("j.{}", self.rng.word(LAW_INPUTS)),
                1 => format!("p.{}", self.rng.word(&["a", "b", "k"])),
                2 => self
                    .rng
                    .word(&["0.0", "1.0", "-2.5", "1.0e300", "1.0e-300", "3", "0"])
                    .into(),
                _ => "j.opening".into(),
            };
        }
        let a = self.expr(depth + 1);
        match self.rng.below(6) {
            0 | 1 => {
                let op = self
                    .rng
                    .word(&["+", "-", "*", "/", "%", "**", "<", ">=", "=="]);
                format!("({a} {op} {})", self.expr(depth + 1))
            }
            2 => {
                let f = self.rng.word(&[
                    "exp", "ln", "sqrt", "abs", "sin", "cos", "tan", "atan", "floor", "ceil",
                ]);
                format!("{f}({a})")
            }
            3 => {
                let f = self.rng.word(&["min", "max"]);
                format!("{f}({a}, {})", self.expr(depth + 1))
            }
            4 => format!(
                "if {a} > {} {{ {} }} else {{ {} }}",
                self.expr(depth + 1),
                self.expr(depth + 1),
                self.expr(depth + 1)
            ),
            _ => format!("(-({a}))"),
        }
    }

    /// One random call in its own `try`, its result kept in a slot.
    fn statement(&mut self, depth: usize) -> String {
        let sig = self.sigs[self.rng.below(self.sigs.len())].clone();
        let call = self.call(&sig, depth);
        let k = self.rng.below(6);
        self.slots[k] = script_type(&sig.ret);
        if verbose() {
            // What the calls reach: a line for each that returned and each that failed.
            let name = sig.name.replace('$', "_");
            return format!(
                "try {{ v{k} = {call}; print(\"call ok {name}\"); }} catch (e) {{ print(\"call error {name}: \" + e); }}"
            );
        }
        format!("try {{ v{k} = {call}; }} catch (e) {{ }}")
    }

    fn call(&mut self, sig: &Sig, depth: usize) -> String {
        let name = sig.name.as_str();
        let mut args: Vec<String> = Vec::new();
        let mut law: Option<String> = None;
        for (i, p) in sig.params.iter().enumerate() {
            let ty = p.trim_start_matches("&mut ");
            let a = if self.rng.chance(0.06) {
                self.hostile()
            } else if self.rng.chance(0.04) {
                format!("v{}", self.rng.below(6))
            } else {
                match ty {
                    "map" => self.options(name, law.as_deref(), depth),
                    "string" => {
                        let w = self.string_for(name, i);
                        if i == 0 || (i == 1 && sig.params[0].starts_with("&mut")) {
                            law = Some(w.clone());
                        }
                        format!("{w:?}")
                    }
                    "array" => self.array_for(name),
                    "i64" => self.int(),
                    "types::dynamic::Dynamic" => self.number_for(name),
                    "Fn" => self.closure(name, depth),
                    t => self.var_of(t),
                }
            };
            args.push(a);
        }
        if name == "+" && args.len() == 2 {
            return format!("({} + {})", args[0], args[1]);
        }
        if let Some(prop) = name.strip_prefix("get$") {
            return format!("{}.{prop}", args[0]);
        }
        if sig.params.first().is_some_and(|p| p.starts_with("&mut ")) {
            let recv = args.remove(0);
            return format!("{recv}.{name}({})", args.join(", "));
        }
        format!("{name}({})", args.join(", "))
    }

    fn hostile(&mut self) -> String {
        if self.rng.chance(0.02) {
            return format!("\"{}\"", "x".repeat(1000 + self.rng.below(5000)));
        }
        self.rng.word(HOSTILE).into()
    }

    /// A variable of script type `t` (or a slot that last held one, or a hostile value).
    fn var_of(&mut self, t: &str) -> String {
        let mut names: Vec<String> = self
            .vars
            .iter()
            .filter(|(_, ty)| *ty == t)
            .map(|(n, _)| n.clone())
            .collect();
        for (k, s) in self.slots.iter().enumerate() {
            if *s == Some(t) {
                names.push(format!("v{k}"));
            }
        }
        if names.is_empty() {
            self.hostile()
        } else {
            self.rng.pick(&names).clone()
        }
    }

    fn int(&mut self) -> String {
        if self.rng.chance(0.15) {
            self.rng
                .word(&[
                    "(-1)",
                    "0",
                    "100000000",
                    "9223372036854775807",
                    "(-9223372036854775807 - 1)",
                ])
                .into()
        } else {
            self.rng.int(0, 4).to_string()
        }
    }

    fn vec3(&mut self) -> String {
        let mut c = || {
            if self.rng.chance(0.05) {
                self.rng
                    .word(&["nan", "inf", "1.0e300", "(-1.0e300)", "1.0e-300"])
                    .to_string()
            } else {
                rhai_float(self.rng.uniform(-1.0, 1.0))
            }
        };
        format!("[{}, {}, {}]", c(), c(), c())
    }

    fn array_for(&mut self, name: &str) -> String {
        match name {
            "table" => {
                let n = self.rng.below(4);
                let pts: Vec<String> = (0..n)
                    .map(|k| {
                        format!(
                            "[{}, {}]",
                            rhai_float(k as f64 * self.rng.uniform(0.0, 1.0)),
                            rhai_float(self.rng.uniform(-1.0, 1.0))
                        )
                    })
                    .collect();
                format!("[{}]", pts.join(", "))
            }
            "spectrum" => {
                let n = self.rng.below(3);
                let ps: Vec<String> = (0..n).map(|_| self.number_for("spectrum")).collect();
                format!("[{}]", ps.join(", "))
            }
            _ => self.vec3(),
        }
    }

    /// A number for a function taking a number: a time, a factor, a ratio …
    fn number_for(&mut self, name: &str) -> String {
        if self.rng.chance(0.1) {
            return self.hostile();
        }
        let x = match name {
            "spectrum" => *self.rng.pick(&[0.05, 0.2, 0.5, 1.0, 1.0e6, 1.0e-6]),
            "scale" => self.rng.uniform(0.5, 2.0),
            "fmt" | "expect_within" | "expect_near" => self.rng.uniform(-10.0, 10.0),
            _ => self.rng.uniform(0.0, 1.0),
        };
        rhai_float(x)
    }

    /// A string argument: a law name, a path, an axis, a name, from the function's docs.
    fn string_for(&mut self, name: &str, _index: usize) -> String {
        let files = self.files;
        let pool: Vec<String> = match name {
            "gmsh" => files.meshes.clone(),
            "ground_motion" => files.records.clone(),
            "read_table" => files.tables.clone(),
            _ => {
                let mut w: Vec<String> = Vec::new();
                for d in docs_of(name) {
                    w.extend(quoted_words(d.summary));
                    w.extend(quoted_words(d.signature));
                    w.extend(d.laws.iter().map(|l| l.name.to_string()));
                }
                w.extend(["x", "y", "z", "xyz", "b", "c", "bottom", "m"].map(String::from));
                w
            }
        };
        if self.rng.chance(0.05) {
            return ["", "..", "a/b", "é", "nope"][self.rng.below(5)].into();
        }
        self.rng.pick(&pool).clone()
    }

    /// An options map of function `name` (its documented keys, and the keys of `law`):
    /// required keys mostly, others half the time, now and then an unknown key.
    fn options(&mut self, name: &str, law: Option<&str>, depth: usize) -> String {
        let docs = docs_of(name);
        let mut keys: Vec<&'static Param> = Vec::new();
        for d in &docs {
            keys.extend(d.keys.iter());
            for l in d.laws {
                if law.is_none_or(|w| w == l.name) || self.rng.chance(0.05) {
                    keys.extend(l.params.iter());
                }
            }
        }
        let mut fields: Vec<String> = Vec::new();
        let mut seen: Vec<&str> = Vec::new();
        for p in keys {
            if seen.contains(&p.name) {
                continue;
            }
            seen.push(p.name);
            let required =
                matches!(p.default, DefaultValue::Required) || p.default_text() == "required";
            // Generators get a coarse `size` (or a hostile one): their default follows the
            // thinnest dimension, and a random thin wall would mesh millions of tets (slow,
            // not wrong; the defaults are tested in tests/generators.rs).
            let chance = if p.name == "size" && GENERATORS.contains(&name) {
                1.0
            } else if required {
                0.9
            } else {
                0.4
            };
            if !self.rng.chance(chance) {
                continue;
            }
            let v = self.key_value(name, p, depth);
            fields.push(format!("{}: {v}", p.name));
        }
        // Runs stay short: a few steps, whatever else the map says.
        match name {
            "run" => {
                fields.retain(|f| !f.starts_with("steps:"));
                fields.push(format!("steps: {}", 1 + self.rng.below(5)));
            }
            "bring_to_rest" => {
                fields.retain(|f| !f.starts_with("max_steps:"));
                fields.push(format!("max_steps: {}", 1 + self.rng.below(30)));
            }
            _ => {}
        }
        if self.rng.chance(0.05) {
            fields.push(format!("{}: 1", self.rng.word(&["nope", "size_", "stpes"])));
        }
        format!("#{{ {} }}", fields.join(", "))
    }

    fn key_value(&mut self, func: &str, p: &Param, depth: usize) -> String {
        if self.rng.chance(0.1) {
            return self.hostile();
        }
        let kind = p.kind;
        match (p.name, kind) {
            ("function", _) => {
                return format!(
                    "{:?}",
                    self.rng.word(&[
                        "law0",
                        "law1",
                        "law2",
                        "munjiza",
                        "linear_rate",
                        "slip_weakening",
                        "nope"
                    ])
                )
            }
            ("source", _) => {
                return format!(
                    "{:?}",
                    self.rng.word(&[
                        "stdlib/joint_laws",
                        "stdlib/friction_laws",
                        "stdlib/units",
                        "nope"
                    ])
                )
            }
            ("params", _) => {
                return format!(
                    "#{{ a: {}, b: {}, k: 1.0 }}",
                    rhai_float(self.rng.uniform(-2.0, 2.0)),
                    rhai_float(self.rng.uniform(0.0, 1e6))
                )
            }
            ("friction_law", _) => {
                return format!(
                    "#{{ function: {:?}, params: #{{ a: 0.5, b: 0.1, k: 1.0 }} }}",
                    self.rng.word(&["law0", "law1", "law2", "nope"])
                )
            }
            ("size", "float") => {
                return rhai_float(*self.rng.pick(&[0.1, 0.2, 0.3, 0.5]));
            }
            ("divisions" | "count", _) => {
                let mut d = || self.rng.int(1, 3).to_string();
                return format!("[{}, {}, {}]", d(), d(), d());
            }
            _ => {}
        }
        if kind.contains("table") && self.rng.chance(0.5) {
            return self.var_of("Table");
        }
        if kind.contains("vec3") && !kind.contains("array") {
            return self.vec3();
        }
        match kind {
            k if k.contains("float") => rhai_float(plausible(p, &mut self.rng)),
            "int" => self.rng.int(1, 4).to_string(),
            "bool" => self.rng.word(&["true", "false"]).into(),
            "string" => {
                let mut w = quoted_words(p.doc);
                w.extend(quoted_words(&p.default_text()));
                if w.is_empty() {
                    w.push("x".into());
                }
                format!("{:?}", self.rng.pick(&w))
            }
            "closure" => self.closure(func, depth),
            k if k.contains("shape") => self.var_of("Shape"),
            k if k.contains("body") => {
                if self.rng.chance(0.3) {
                    format!("[{}, {}]", self.var_of("Body"), self.var_of("Body"))
                } else {
                    self.var_of("Body")
                }
            }
            k if k.contains("material") => {
                format!("[{}, {}]", self.var_of("Material"), self.var_of("Material"))
            }
            "JointLaw" => self.var_of("JointLaw"),
            "Steel" => self.var_of("Steel"),
            "BondLaw" => self.var_of("BondLaw"),
            "GroundMotion" => self.var_of("GroundMotion"),
            "array of [x, y, z]" => format!("[{}, {}]", self.vec3(), self.vec3()),
            "[a, b]" => format!(
                "[{}, {}]",
                rhai_float(self.rng.uniform(0.0, 1.0)),
                rhai_float(self.rng.uniform(0.0, 1.0))
            ),
            "array of vec3" => format!(
                "[{}, {}, {}, {}]",
                self.vec3(),
                self.vec3(),
                self.vec3(),
                self.vec3()
            ),
            "array of [int; 4]" => format!("[[0, 1, 2, 3], [{}, 1, 2, 3]]", self.int()),
            _ => self.hostile(),
        }
    }

    /// A closure for a hook, monitor, `stop_when` or event: a few random calls (on `s`, the
    /// simulation it is called with, or on anything in scope) and a value.
    fn closure(&mut self, func: &str, depth: usize) -> String {
        let params = match func {
            "on_joint_broken" | "on_new_contact_pair" => "|s, e|",
            _ => "|s|",
        };
        let mut body = String::new();
        if depth < 2 {
            self.vars.push(("s".into(), "Simulation"));
            for _ in 0..self.rng.below(3) {
                body.push_str(&self.statement(depth + 1));
                body.push(' ');
            }
            self.vars.pop();
        }
        let value = self.rng.word(&[
            "s.time",
            "s.step",
            "s.kinetic_energy()",
            "s.step > 2",
            "nan",
            "()",
            "\"x\"",
            "1",
            "inf",
            "s.energy()",
        ]);
        format!("{params} {{ {body}{value} }}")
    }
}

/// Functions that mesh a solid of the sizes they are given.
const GENERATORS: &[&str] = &[
    "mesh",
    "disc",
    "hollow_cylinder",
    "notched_beam",
    "arch",
    "wall",
    "dome",
    "cloister_vault",
];

/// A plausible value of a numeric parameter: its default, or a typical number of its unit,
/// kept inside its range.
fn plausible(p: &Param, rng: &mut Rng) -> f64 {
    let base = match p.default {
        DefaultValue::Value(v) if v != 0.0 && v.is_finite() => v.abs(),
        _ => match p.unit {
            "Pa" => 1e7,
            "kg/m³" => 2500.0,
            "m" => 0.3,
            "m²" => 0.01,
            "s" => 1e-3,
            "1/s" => 10.0,
            "°" => 30.0,
            "J/m²" => 50.0,
            "m/s" => 1.0,
            "N" => 1e3,
            "Pa/m" => 1e9,
            _ => 0.3,
        },
    };
    let x = base * rng.uniform(0.3, 1.5);
    let r = p.range;
    if r.contains(x) || rng.chance(0.1) {
        return x;
    }
    match (r.lo.is_finite(), r.hi.is_finite()) {
        (true, true) => r.lo + (r.hi - r.lo) * rng.uniform(0.01, 0.99),
        (true, false) => r.lo.abs().max(1e-3) * rng.uniform(1.01, 3.0),
        (false, true) => r.hi - r.hi.abs().max(1.0) * rng.uniform(0.01, 1.0),
        _ => x,
    }
}

#[test]
fn fuzz_script_api() {
    let sigs = signatures();
    assert!(sigs.len() > 150, "{} signatures", sigs.len());
    let dir = work_dir("scripts");
    let files = script_files(&dir, &mut Rng::new(base_seed()));
    let options = fdem::script::RunOptions {
        out_dir: Some(dir.join("out")),
        overwrite: true,
        quiet: true,
        max_operations: Some(2_000_000),
        ..Default::default()
    };
    let path = dir.join("fuzz.rhai");
    campaign("scripts", 400, Duration::from_secs(60), |c| {
        let mut g = ScriptGen {
            rng: c.rng.clone(),
            sigs: &sigs,
            files: &files,
            vars: Vec::new(),
            slots: [None; 6],
        };
        let script = g.script();
        c.input(script.as_bytes());
        let r = fdem::script::run_source(&path, &script, options.clone());
        if verbose() {
            if let Err(e) = &r {
                eprintln!("script error: {e}");
            }
        }
        // The files it wrote read back (frames, series, histories), one case in five.
        if c.rng.chance(0.2) {
            check_outputs(&dir.join("out"));
        }
        r.into()
    });
}

/// `body.translate([0, 1e300, 0])` left no digits for the tets' size: the reference data
/// could not be inverted and an `expect` panicked. The move is refused with the body as it
/// was.
#[test]
fn regression_moving_a_body_to_1e300_is_refused() {
    let mut sim = common::box_sim(
        Vec3::zeros(),
        Vec3::new(1.0, 1.0, 1.0),
        [1, 1, 1],
        common::material(fdem::material::Formulation::Munjiza, 2500.0, 1e9, 0.2),
        fdem::Layout::Continuous,
    );
    let before = sim.nodes.x0.clone();
    let e = sim
        .translate_body(0, Vec3::new(0.0, 1e300, 0.0))
        .unwrap_err()
        .to_string();
    assert!(e.contains("degenerate") && e.contains("'box'"), "{e}");
    assert_eq!(sim.nodes.x0, before);
    let e = sim
        .rotate_body(0, Vec3::new(0.0, 0.0, 1.0), 1.0, Vec3::new(1e300, 0.0, 0.0))
        .unwrap_err()
        .to_string();
    assert!(e.contains("degenerate"), "{e}");
    sim.translate_body(0, Vec3::new(0.0, 1.0, 0.0)).unwrap();
    sim.prepare().unwrap();
    sim.step().unwrap();
}

/// Check every file a script left in `dir` as a reader would: each `.vtu` holds blocks of the
/// sizes its header gives (points, cells and fields), each `.pvd` names files that exist,
/// each CSV has as many fields in every row as in its header, and no `.tmp` is left.
fn check_outputs(dir: &Path) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            check_outputs(&p);
            continue;
        }
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        let ext = p.extension().map(|x| x.to_string_lossy().into_owned());
        match ext.as_deref() {
            Some("tmp") => panic!("a temporary file was left: {}", p.display()),
            Some("vtu") => check_vtu_structure(&std::fs::read(&p).unwrap(), &name),
            Some("pvd") => {
                let xml = std::fs::read_to_string(&p).unwrap();
                assert!(xml.chars().all(xml_char), "{name}: not XML");
                for l in xml.lines().filter(|l| l.contains("<DataSet")) {
                    let file = xml_unescape(attribute(l, "file").unwrap());
                    assert!(
                        dir.join(&file).exists(),
                        "{name} names {file}, which is not there"
                    );
                }
            }
            Some("csv") => {
                let text = std::fs::read_to_string(&p).unwrap();
                let mut lines = text.lines();
                let Some(header) = lines.next() else { continue };
                let n = csv_fields(header).len();
                for l in lines {
                    assert_eq!(csv_fields(l).len(), n, "{name}: '{l}' under '{header}'");
                    for f in csv_fields(l) {
                        assert!(f.parse::<f64>().is_ok(), "{name}: '{f}' is not a number");
                    }
                }
            }
            _ => {}
        }
    }
}

/// A `.vtu` file's structure, from its header alone: every block's byte count is that of
/// its array (points or cells × components × size), the offsets end where the connectivity
/// does, and the appended data ends where the header says.
fn check_vtu_structure(bytes: &[u8], name: &str) {
    let marker = b"   _";
    let at = bytes
        .windows(marker.len())
        .position(|w| w == marker)
        .unwrap_or_else(|| panic!("{name}: no appended data"))
        + marker.len();
    let xml = std::str::from_utf8(&bytes[..at]).expect("the XML part is UTF-8");
    assert!(
        xml.chars().all(xml_char),
        "{name}: a character XML does not allow"
    );
    let piece = xml.lines().find(|l| l.contains("<Piece")).unwrap();
    let count = |k: &str| -> usize { attribute(piece, k).unwrap().parse().unwrap() };
    let (points, cells) = (count("NumberOfPoints"), count("NumberOfCells"));
    let base64 = xml.contains("encoding=\"base64\"");
    let mut section = "";
    let mut end = 0;
    let mut connectivity = 0;
    for l in xml.lines() {
        for s in ["<PointData", "<CellData", "<Points", "<Cells"] {
            if l.contains(s) {
                section = s;
            }
        }
        if !l.contains("<DataArray") {
            continue;
        }
        let array = xml_unescape(attribute(l, "Name").unwrap());
        let size = match attribute(l, "type").unwrap() {
            "Float64" | "Int64" => 8,
            "Int32" => 4,
            "UInt8" => 1,
            t => panic!("{name}: type {t}"),
        };
        let comps: usize = attribute(l, "NumberOfComponents").map_or(1, |c| c.parse().unwrap());
        let off: usize = attribute(l, "offset").unwrap().parse().unwrap();
        let head = if base64 {
            base64_decode(&bytes[at + off..at + off + 12])[..8].to_vec()
        } else {
            bytes[at + off..at + off + 8].to_vec()
        };
        let nbytes = u64::from_le_bytes(head.try_into().unwrap()) as usize;
        let expected = match (section, array.as_str()) {
            ("<PointData", _) | ("<Points", _) => points * comps * size,
            ("<CellData", _) => cells * comps * size,
            ("<Cells", "offsets") | ("<Cells", "types") => cells * size,
            ("<Cells", "connectivity") => {
                connectivity = nbytes / 8;
                nbytes
            }
            _ => panic!("{name}: array {array} in {section}"),
        };
        assert_eq!(nbytes, expected, "{name}: block {array}");
        let len = if base64 {
            4 * (8 + nbytes).div_ceil(3)
        } else {
            8 + nbytes
        };
        end = end.max(off + len);
        if array == "offsets" && cells > 0 {
            let last = if base64 {
                let block = base64_decode(&bytes[at + off..at + off + len]);
                block[block.len() - 8..].to_vec()
            } else {
                bytes[at + off + len - 8..at + off + len].to_vec()
            };
            let last = i64::from_le_bytes(last.try_into().unwrap()) as usize;
            assert_eq!(
                last, connectivity,
                "{name}: offsets end where the connectivity does"
            );
        }
    }
    assert_eq!(
        &bytes[at + end..],
        b"\n  </AppendedData>\n</VTKFile>\n",
        "{name}: the data end where the header says"
    );
}

/// Found with overflow checks on (`CARGO_TARGET_DIR=target/overflow cargo test --test
/// fuzz`): a physical tag of −2⁶³ in `$Entities` (4.1) or an element's tags (2.2) has no
/// absolute value — a panic with overflow checks, and in a release build a group named
/// `physical_-9223372036854775808`. It is an error naming its line now.
#[test]
fn regression_physical_tag_without_an_absolute_value_is_an_error() {
    let m = msh_model([1, 1, 1]);
    let v41 = String::from_utf8(msh41_ascii(&m)).unwrap().replace(
        "1 0 0 0 1 0.5 0.25 1 1 1 1",
        "1 0 0 0 1 0.5 0.25 1 -9223372036854775808 1 1",
    );
    let v22 = String::from_utf8(msh22(&m)).unwrap().replacen(
        " 4 2 1 1 ",
        " 4 2 -9223372036854775808 1 ",
        1,
    );
    for text in [v41, v22] {
        let at = text.find("-9223372036854775808").unwrap();
        let line = 1 + text[..at].matches('\n').count();
        let e = parse_msh(text.as_bytes(), "t.msh").unwrap_err().to_string();
        assert!(
            e.contains("physical tag -9223372036854775808 is out of range")
                && e.contains(&format!("t.msh:{line}:")),
            "{e}"
        );
    }
    // Negative tags (an orientation) still name the group of their absolute value.
    let neg = String::from_utf8(msh22(&m))
        .unwrap()
        .replace(" 4 2 1 1 ", " 4 2 -1 1 ");
    let mesh = parse_msh(neg.as_bytes(), "n.msh").unwrap().mesh;
    assert_eq!(mesh.sets.elements["solid"].len(), m.tets.len());
}

/// Found with overflow checks on: a sphere or cylinder `size` so small that the cells per
/// quarter circle saturate doubled them with an overflow (a panic with overflow checks; a
/// count of exactly 2⁶³ wrapped to 0 cells in a release build). The count saturates and is
/// refused.
#[test]
fn regression_cells_of_a_tiny_size_saturate_and_are_refused() {
    use fdem::mesh::solids::{cylinder, sphere};
    let quarter = std::f64::consts::PI / 4.0;
    for ratio in [2f64.powi(63), 2f64.powi(64), 1e300] {
        let radius = ratio / quarter;
        for r in [
            sphere(radius, 1.0).map(|_| ()),
            cylinder(radius, 1.0, 1.0).map(|_| ()),
        ] {
            let e = r.unwrap_err();
            assert!(e.contains("too many") || e.contains("memory"), "{e}");
        }
    }
    let dir = work_dir("tiny-size");
    let e = fdem::script::run_source(
        &dir.join("d.rhai"),
        "disc(#{ radius: 0.325, thickness: 0.3, size: 1.0e-300 });",
        Default::default(),
    )
    .err()
    .unwrap()
    .to_string();
    assert!(e.contains("too many"), "{e}");
}
