//! Limits that keep a typo from taking the machine down: memory estimates checked against the
//! memory the machine has before large allocations, and bounded reads of input files (a
//! script may name `/dev/zero`, or a 50 GB file by mistake).
//!
//! Bytes per tetrahedron, measured with `/usr/bin/time -f %M` on a 750 000-tet box
//! (`fdem run`, two steps, one thread): the mesh alone 32 B, a continuous body 300 B, a
//! jointed body 850 B, a jointed body with joints on every internal face 1 430 B. The
//! constants below round these up.

pub mod interrupt;

use std::io::Read;
use std::path::Path;

/// Memory of a mesh, per tetrahedron [B] (nodes and tets, and the sets).
pub const MESH_BYTES_PER_TET: f64 = 40.0;
/// Memory of a continuous or rigid body in a simulation, per tetrahedron [B].
pub const CONTINUOUS_BYTES_PER_TET: f64 = 320.0;
/// Memory of a jointed body in a simulation with its joints, per tetrahedron [B].
pub const JOINTED_BYTES_PER_TET: f64 = 1500.0;

/// The largest text input read whole (tables, ground-motion records) [B].
pub const MAX_TEXT_INPUT: u64 = 256 << 20;

/// Memory the machine can still give this process [B]: `MemAvailable` of `/proc/meminfo`
/// (None where there is no such file).
pub fn available_memory() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    kilobytes(&text, "MemAvailable:").or_else(|| kilobytes(&text, "MemTotal:"))
}

/// The most memory this process has held resident so far [B]: `VmHWM` of
/// `/proc/self/status` (None where there is no such file).
pub fn peak_resident_memory() -> Option<f64> {
    kilobytes(
        &std::fs::read_to_string("/proc/self/status").ok()?,
        "VmHWM:",
    )
}

/// The value [B] of the line `key  N kB` of a `/proc` file's `text`.
fn kilobytes(text: &str, key: &str) -> Option<f64> {
    let line = text.lines().find(|l| l.starts_with(key))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024.0)
}

/// Bytes for people: `1.5 GB`, `300 MB`.
pub fn format_bytes(b: f64) -> String {
    if !b.is_finite() {
        return "an unbounded amount".into();
    }
    let units = ["B", "kB", "MB", "GB", "TB", "PB", "EB"];
    let mut v = b;
    let mut u = 0;
    while v >= 1000.0 && u + 1 < units.len() {
        v /= 1000.0;
        u += 1;
    }
    if u + 1 == units.len() && v >= 1000.0 {
        return format!("{b:.1e} B");
    }
    if v >= 100.0 || u == 0 {
        format!("{v:.0} {}", units[u])
    } else {
        format!("{v:.1} {}", units[u])
    }
}

/// Error unless `bytes` (an estimate, computed in floating point so that no product
/// overflows) fits in the memory the machine has available; `what` says what would be built
/// ("a mesh of 3.0e8 tetrahedra").
pub fn check_memory(what: &str, bytes: f64) -> Result<(), String> {
    let available = available_memory();
    let fits = match available {
        Some(a) => bytes.is_finite() && bytes <= a,
        None => bytes.is_finite() && bytes <= 1.0e12,
    };
    if fits {
        return Ok(());
    }
    let have = available.map_or_else(
        || "this machine can give".to_string(),
        |a| format!("the {} available on this machine", format_bytes(a)),
    );
    Err(format!(
        "{what} would need about {} of memory, more than {have}",
        format_bytes(bytes)
    ))
}

/// Error unless a mesh of `tets` tetrahedra, simulated as continuous bodies, fits in memory.
pub fn check_tets(tets: f64) -> Result<(), String> {
    check_memory(
        &format!("a mesh of {tets:.3e} tetrahedra (simulated as a continuous body)"),
        tets * (MESH_BYTES_PER_TET + CONTINUOUS_BYTES_PER_TET),
    )
    .map_err(|e| format!("{e}; use a larger 'size' or fewer cells"))
}

/// The largest mesh file read [B] (a regular file; a device or pipe is read up to
/// [`MAX_TEXT_INPUT`]), and never more than the memory available.
pub const MAX_MESH_INPUT: u64 = 8 << 30;

/// Read a file of at most `limit` bytes (a larger file, or a device that never ends such as
/// `/dev/zero`, is an error naming the limit instead of eating the memory). Only regular
/// files may use the whole `limit`; anything else is cut at [`MAX_TEXT_INPUT`].
pub fn read_bounded(path: &Path, limit: u64) -> std::io::Result<Vec<u8>> {
    let file = std::fs::File::open(path)?;
    let meta = file.metadata()?;
    if meta.is_dir() {
        return Err(std::io::Error::other("is a directory"));
    }
    let limit = if meta.is_file() {
        limit
    } else {
        limit.min(MAX_TEXT_INPUT)
    };
    let too_big = || {
        std::io::Error::other(format!(
            "larger than {} (the limit for this input; a device or pipe that never ends?)",
            format_bytes(limit as f64)
        ))
    };
    if meta.is_file() {
        if meta.len() > limit {
            return Err(too_big());
        }
        check_memory("reading this file", 2.0 * meta.len() as f64)
            .map_err(std::io::Error::other)?;
    }
    let mut bytes = Vec::new();
    file.take(limit + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > limit {
        return Err(too_big());
    }
    Ok(bytes)
}

/// Read a text file of at most `limit` bytes ([`read_bounded`]).
pub fn read_text_bounded(path: &Path, limit: u64) -> std::io::Result<String> {
    let bytes = read_bounded(path, limit)?;
    String::from_utf8(bytes).map_err(|e| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("not UTF-8 text (byte {})", e.utf8_error().valid_up_to()),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bytes_read_like_people_write_them() {
        assert_eq!(format_bytes(78.0e9), "78.0 GB");
        assert_eq!(format_bytes(300.0e6), "300 MB");
        assert_eq!(format_bytes(12.0), "12 B");
        assert_eq!(format_bytes(f64::INFINITY), "an unbounded amount");
    }

    #[test]
    fn an_absurd_estimate_is_refused_with_the_estimate() {
        let e = check_memory("a thing", 1e30).unwrap_err();
        assert!(e.contains("a thing would need about 1.0e30 B"), "{e}");
        assert!(check_memory("a small thing", 1e3).is_ok());
    }

    #[test]
    fn endless_devices_are_read_up_to_the_limit() {
        let e = read_text_bounded(Path::new("/dev/zero"), 1 << 20).unwrap_err();
        assert!(e.to_string().contains("larger than 1.0 MB"), "{e}");
    }
}
