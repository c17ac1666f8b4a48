//! Checkpoint files: a simulation's whole state at the end of a step, written so that a run
//! restarted from it continues bit for bit as if it had never stopped.
//!
//! Layout (little-endian):
//!
//! | bytes | content |
//! |---|---|
//! | 8 | magic `FDEMCKPT` |
//! | 4 | format version ([`FORMAT_VERSION`]) |
//! | 8 | payload length n |
//! | 4 | CRC-32 of the payload |
//! | n | payload: the head (postcard), then the body (postcard) |
//!
//! The head ([`Head`]) is read first and alone: it names the simulation, the `run` call the
//! checkpoint was taken in, the model's [`Fingerprint`] and the script-side state. The body is
//! the [`Simulation`] itself, read only when the restarted script reaches that run: its compiled
//! laws are found by key among the laws the script compiled again
//! ([`crate::compiled::CompiledLaw`]). The payload is written to a temporary file and renamed, so a
//! checkpoint on disk is always whole.
//!
//! What a checkpoint guarantees: a restarted run's positions, velocities, joint, contact, bar and
//! rigid-body state, fracture events, energy account, monitors and output numbering equal those
//! of the uninterrupted run, bit for bit, for any thread count (`tests/checkpoint.rs`).

use crate::pipeline::Simulation;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Version of the layout and of the serialized state; a file of another version is refused.
pub const FORMAT_VERSION: u32 = 1;

/// Hash of this build's sources (build.rs). The state is serialized without field names, as
/// this build's types lay it out; a checkpoint of another build is refused, not misread.
pub const BUILD_ID: &str = env!("FDEM_BUILD_ID");

const MAGIC: &[u8; 8] = b"FDEMCKPT";
const HEADER_BYTES: usize = 8 + 4 + 8 + 4;

/// What identifies a model's structure: a checkpoint restores into the same structure only.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct Fingerprint {
    pub bodies: Vec<String>,
    pub nodes: usize,
    pub tets: usize,
    pub joints: usize,
    pub bars: usize,
    pub bond_points: usize,
    pub rigid_bodies: usize,
    /// FNV-1a of the reference positions and the tets' and joints' node ids.
    pub geometry_hash: u64,
}

impl Fingerprint {
    pub fn of(sim: &Simulation) -> Self {
        let mut h = Fnv::new();
        for p in &sim.nodes.x0 {
            for c in p.iter() {
                h.write(&c.to_bits().to_le_bytes());
            }
        }
        for t in &sim.tets.nodes {
            for n in t {
                h.write(&n.to_le_bytes());
            }
        }
        for f in &sim.joints.faces {
            for n in f.iter().flatten() {
                h.write(&n.to_le_bytes());
            }
        }
        for b in &sim.bars.nodes {
            for n in b {
                h.write(&n.to_le_bytes());
            }
        }
        Fingerprint {
            bodies: sim.bodies.iter().map(|b| b.name.clone()).collect(),
            nodes: sim.nodes.len(),
            tets: sim.tets.len(),
            joints: sim.joints.len(),
            bars: sim.bars.nodes.len(),
            bond_points: sim.bonds.node.len(),
            rigid_bodies: sim.rigid.bodies.len(),
            geometry_hash: h.0,
        }
    }

    /// None when equal; else what differs, for an error message.
    pub fn difference(&self, now: &Fingerprint) -> Option<String> {
        let mut d = Vec::new();
        if self.bodies != now.bodies {
            d.push(format!(
                "bodies [{}] in the checkpoint, [{}] now",
                self.bodies.join(", "),
                now.bodies.join(", ")
            ));
        }
        let counts = [
            ("nodes", self.nodes, now.nodes),
            ("tetrahedra", self.tets, now.tets),
            ("joints", self.joints, now.joints),
            ("bars", self.bars, now.bars),
            ("bond points", self.bond_points, now.bond_points),
            ("rigid bodies", self.rigid_bodies, now.rigid_bodies),
        ];
        for (what, a, b) in counts {
            if a != b {
                d.push(format!("{a} {what} in the checkpoint, {b} now"));
            }
        }
        if d.is_empty() && self.geometry_hash != now.geometry_hash {
            d.push("the same counts, but other node positions or connectivity".into());
        }
        (!d.is_empty()).then(|| d.join("; "))
    }
}

/// 64-bit FNV-1a.
struct Fnv(u64);

impl Fnv {
    fn new() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(0x0100_0000_01b3);
        }
    }
}

/// Where a checkpoint was taken within the script: in which `run` call, and (inside a run)
/// where that run started, so the restarted run ends where the original would have.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct RunPoint {
    /// Number of `run` calls of the simulation completed before the checkpoint.
    pub runs_completed: usize,
    /// Inside a run: its starting time [s] and step; None between runs.
    pub run_start: Option<(f64, u64)>,
}

/// The first part of a checkpoint: everything but the simulation's state.
#[derive(Serialize, Deserialize, Clone, Debug)]
pub struct Head<S> {
    /// `CARGO_PKG_VERSION` of the fdem that wrote it.
    pub fdem_version: String,
    /// [`BUILD_ID`] of the fdem that wrote it.
    pub build: String,
    /// The simulation's name.
    pub simulation: String,
    /// File name of the script that ran it.
    pub script: String,
    /// The `--set` overrides of that run, in order.
    pub overrides: Vec<(String, String)>,
    pub point: RunPoint,
    pub time: f64,
    pub step: u64,
    pub fingerprint: Fingerprint,
    /// The script layer's state (monitors, hooks, output series).
    pub script_state: S,
}

/// Write `head` and `sim` to `path` (through a temporary file and a rename).
pub fn write<S: Serialize>(path: &Path, head: &Head<S>, sim: &Simulation) -> Result<(), String> {
    let fail = |e: &dyn std::fmt::Display| format!("writing checkpoint {}: {e}", path.display());
    let mut payload = postcard::to_stdvec(head).map_err(|e| fail(&e))?;
    payload = postcard::to_extend(sim, payload).map_err(|e| fail(&e))?;
    let mut bytes = Vec::with_capacity(HEADER_BYTES + payload.len());
    bytes.extend_from_slice(MAGIC);
    bytes.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    bytes.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    bytes.extend_from_slice(&crc32fast::hash(&payload).to_le_bytes());
    bytes.extend_from_slice(&payload);
    super::vtu::write_atomic(path, &bytes).map_err(|e| fail(&e))
}

/// A checkpoint read from disk: its head, and the simulation's bytes, decoded on demand.
pub struct Loaded<S> {
    pub head: Head<S>,
    /// The payload, and where the body starts in it.
    payload: Vec<u8>,
    body_start: usize,
}

/// The longest checkpoint read (a bigger file is refused before it is read).
pub const MAX_BYTES: u64 = 64 << 30;

/// Read and verify `path`: magic, format version, length and checksum, then the head.
pub fn read<S: for<'de> Deserialize<'de>>(path: &Path) -> Result<Loaded<S>, String> {
    let name = path.display();
    let bad = |why: String| format!("--restart {name}: {why}");
    let meta = std::fs::metadata(path).map_err(|e| bad(e.to_string()))?;
    if !meta.is_file() {
        return Err(bad("not a file".into()));
    }
    if meta.len() > MAX_BYTES {
        return Err(bad(format!(
            "{} bytes is more than a checkpoint may hold ({MAX_BYTES})",
            meta.len()
        )));
    }
    let bytes = std::fs::read(path).map_err(|e| bad(e.to_string()))?;
    if bytes.len() < HEADER_BYTES || &bytes[..8] != MAGIC {
        return Err(bad(
            "not an fdem checkpoint (it does not start with FDEMCKPT)".into(),
        ));
    }
    let word = |a: usize, n: usize| -> u64 {
        let mut b = [0u8; 8];
        b[..n].copy_from_slice(&bytes[a..a + n]);
        u64::from_le_bytes(b)
    };
    let version = word(8, 4) as u32;
    if version != FORMAT_VERSION {
        return Err(bad(format!(
            "checkpoint format version {version}; this fdem reads version {FORMAT_VERSION}"
        )));
    }
    let len = word(12, 8);
    let crc = word(20, 4) as u32;
    let payload = &bytes[HEADER_BYTES..];
    if payload.len() as u64 != len {
        return Err(bad(format!(
            "the file is truncated or damaged: {} payload bytes, the header says {len}",
            payload.len()
        )));
    }
    if crc32fast::hash(payload) != crc {
        return Err(bad(
            "the file is damaged: its checksum does not match its contents".into(),
        ));
    }
    let (head, rest): (Head<S>, &[u8]) =
        postcard::take_from_bytes(payload).map_err(|e| bad(format!("unreadable head: {e}")))?;
    if head.fdem_version != env!("CARGO_PKG_VERSION") {
        return Err(bad(format!(
            "written by fdem {}, this is fdem {}: a checkpoint restarts only with the version that wrote it",
            head.fdem_version,
            env!("CARGO_PKG_VERSION")
        )));
    }
    if head.build != BUILD_ID {
        return Err(bad(format!(
            "written by another build of fdem {} (sources {}, this build's {BUILD_ID}): a checkpoint restarts only with the build that wrote it",
            head.fdem_version, head.build
        )));
    }
    let body_start = payload.len() - rest.len();
    Ok(Loaded {
        head,
        payload: payload.to_vec(),
        body_start,
    })
}

impl<S> Loaded<S> {
    /// Decode the simulation (its compiled laws must have been compiled again by now).
    pub fn simulation(&self) -> Result<Simulation, String> {
        postcard::from_bytes(&self.payload[self.body_start..])
            .map_err(|e| {
                format!(
                    "the checkpoint's simulation state cannot be read ({e}): was it written by another build of fdem?"
                )
            })
    }
}
