//! Build script: `FDEM_BUILD_ID`, a hash of the sources (`src/**`, `Cargo.lock`), which
//! checkpoints carry: the state they hold is laid out as this build's types are, so a
//! checkpoint restarts only with the build that wrote it (`src/io/checkpoint.rs`).

use std::path::{Path, PathBuf};

fn files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            files(&p, out);
        } else {
            out.push(p);
        }
    }
}

fn main() {
    println!("cargo:rerun-if-changed=src");
    println!("cargo:rerun-if-changed=Cargo.lock");
    let mut list = Vec::new();
    files(Path::new("src"), &mut list);
    list.push(PathBuf::from("Cargo.lock"));
    list.sort();
    // 64-bit FNV-1a over each file's path and bytes.
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |bytes: &[u8]| {
        for &b in bytes {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    };
    for p in &list {
        eat(p.to_string_lossy().as_bytes());
        eat(&std::fs::read(p).unwrap_or_default());
    }
    println!("cargo:rustc-env=FDEM_BUILD_ID={h:016x}");
}
