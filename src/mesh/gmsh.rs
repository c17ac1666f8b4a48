//! Gmsh import: `.msh` files in MSH 4.1 (ASCII and binary) and MSH 2.2 (ASCII), written from
//! the format description in the Gmsh reference manual ("MSH file format").
//!
//! 4-node tetrahedra (element type 4) become the mesh. Lower-dimensional elements only build
//! named sets from physical groups:
//! - 3D groups → element sets;
//! - 2D groups → face sets (each triangle must be a face of a tetrahedron) and node sets;
//! - 1D and 0D groups → node sets.
//!
//! Groups without a `$PhysicalNames` entry are named `physical_<tag>`. Nodes used by no
//! tetrahedron are dropped (with a warning) and the rest renumbered in file order. Left-handed
//! tetrahedra are reordered by [`Mesh::fix_orientation`] (with a warning). Any other 3D element
//! type is refused with its number and meaning.
//!
//! Every problem is a [`GmshError`] with the file, the line (ASCII) or byte offset (binary),
//! and what was expected; malformed input never panics.

use super::{Mesh, TET_FACES};
use crate::math::{Real, Vec3};
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::{Path, PathBuf};

/// Where in the file a problem is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Place {
    /// 1-based line (ASCII files).
    Line(usize),
    /// Byte offset from the start (binary files).
    Byte(usize),
    /// The file as a whole (e.g. a missing section).
    File,
}

/// A malformed or unsupported `.msh` file.
#[derive(Clone, Debug, PartialEq)]
pub struct GmshError {
    pub file: String,
    pub place: Place,
    pub message: String,
}

impl std::fmt::Display for GmshError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.place {
            Place::Line(l) => write!(f, "{}:{l}: {}", self.file, self.message),
            Place::Byte(b) => write!(f, "{}: byte {b}: {}", self.file, self.message),
            Place::File => write!(f, "{}: {}", self.file, self.message),
        }
    }
}

impl std::error::Error for GmshError {}

/// A mesh read from a `.msh` file.
#[derive(Clone, Debug)]
pub struct Imported {
    pub mesh: Mesh,
    /// Things the reader changed or ignored (dropped nodes, reordered tetrahedra, …).
    pub warnings: Vec<String>,
    /// "MSH 4.1 ASCII", "MSH 4.1 binary" or "MSH 2.2 ASCII".
    pub format: String,
}

/// Gmsh element types: (type, nodes, dimension, meaning).
const ELEMENT_TYPES: &[(u32, usize, u8, &str)] = &[
    (1, 2, 1, "2-node line"),
    (2, 3, 2, "3-node triangle"),
    (3, 4, 2, "4-node quadrangle"),
    (4, 4, 3, "4-node tetrahedron"),
    (5, 8, 3, "8-node hexahedron"),
    (6, 6, 3, "6-node prism"),
    (7, 5, 3, "5-node pyramid"),
    (8, 3, 1, "3-node second-order line"),
    (9, 6, 2, "6-node second-order triangle"),
    (10, 9, 2, "9-node second-order quadrangle"),
    (11, 10, 3, "10-node second-order tetrahedron"),
    (12, 27, 3, "27-node second-order hexahedron"),
    (13, 18, 3, "18-node second-order prism"),
    (14, 14, 3, "14-node second-order pyramid"),
    (15, 1, 0, "1-node point"),
    (16, 8, 2, "8-node second-order quadrangle"),
    (17, 20, 3, "20-node second-order hexahedron"),
    (18, 15, 3, "15-node second-order prism"),
    (19, 13, 3, "13-node second-order pyramid"),
    (20, 9, 2, "9-node third-order incomplete triangle"),
    (21, 10, 2, "10-node third-order triangle"),
    (22, 12, 2, "12-node fourth-order incomplete triangle"),
    (23, 15, 2, "15-node fourth-order triangle"),
    (24, 15, 2, "15-node fifth-order incomplete triangle"),
    (25, 21, 2, "21-node fifth-order triangle"),
    (26, 4, 1, "4-node third-order line"),
    (27, 5, 1, "5-node fourth-order line"),
    (28, 6, 1, "6-node fifth-order line"),
    (29, 20, 3, "20-node third-order tetrahedron"),
    (30, 35, 3, "35-node fourth-order tetrahedron"),
    (31, 56, 3, "56-node fifth-order tetrahedron"),
    (92, 64, 3, "64-node third-order hexahedron"),
    (93, 125, 3, "125-node fourth-order hexahedron"),
];

fn element_type(t: u32) -> Option<(usize, u8, &'static str)> {
    ELEMENT_TYPES
        .iter()
        .find(|e| e.0 == t)
        .map(|e| (e.1, e.2, e.3))
}

/// Read a `.msh` file.
pub fn read_msh(path: &Path) -> Result<Imported, GmshError> {
    let label = path.display().to_string();
    let bytes = crate::limits::read_bounded(path, crate::limits::MAX_MESH_INPUT).map_err(|e| {
        GmshError {
            file: label.clone(),
            place: Place::File,
            message: format!("cannot read the file: {e}"),
        }
    })?;
    parse_msh(&bytes, &label)
}

/// Parse the bytes of a `.msh` file; `label` names it in errors.
pub fn parse_msh(bytes: &[u8], label: &str) -> Result<Imported, GmshError> {
    let mut r = Reader {
        b: bytes,
        pos: 0,
        file: label,
        binary: false,
        big_endian: false,
        size_t: 8,
    };
    let raw = r.read_file()?;
    raw.build(&r)
}

/// Whether the `gmsh` executable can be run.
pub fn gmsh_installed() -> bool {
    std::process::Command::new("gmsh")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
}

/// The message given when a `.geo` file needs gmsh and it is missing.
pub const GMSH_MISSING: &str =
    "gmsh is not installed; install it (Debian: apt-get install gmsh) or give a .msh file";

/// 64-bit FNV-1a: a hash that is the same on every machine and Rust version (cache names).
pub fn fnv1a(chunks: &[&[u8]]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for c in chunks {
        for &b in *c {
            h ^= b as u64;
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
        // Separate the chunks, so ("ab", "c") and ("a", "bc") differ.
        h ^= 0xff;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

/// The gmsh version line (part of the cache key: another gmsh may mesh differently).
fn gmsh_version() -> String {
    std::process::Command::new("gmsh")
        .arg("--version")
        .output()
        .map(|o| {
            format!(
                "{}{}",
                String::from_utf8_lossy(&o.stdout),
                String::from_utf8_lossy(&o.stderr)
            )
            .trim()
            .to_string()
        })
        .unwrap_or_default()
}

/// A `.geo` file meshed through the cache: the mesh, the `.msh` file it was read from, and
/// whether that file was already there.
pub struct CachedMesh {
    pub imported: Imported,
    pub msh: std::path::PathBuf,
    pub reused: bool,
}

/// Mesh a `.geo` file once per content: the `.msh` is kept as
/// `<dir>/.fdem-cache/<stem>-<hash>.msh` (or in the temporary directory if the `.geo` file's
/// directory is not writable), the hash covering the `.geo` text, `size` and the gmsh version.
/// gmsh's 3-D meshers are not all deterministic (HXT is parallel), so `fdem check` and
/// `fdem run` would otherwise see different meshes. Files the `.geo` merges are not in the key:
/// delete the cache entry after changing them. The [`GeoPolicy`] is applied before the cache
/// is looked at; gmsh meshes into a private temporary directory and the result is moved into
/// the cache under a temporary name and renamed, so a cache never holds half a file.
pub fn mesh_geo_cached(
    geo: &Path,
    size: Option<Real>,
    policy: &GeoPolicy,
) -> Result<CachedMesh, String> {
    let text = std::fs::read(geo).map_err(|e| format!("{}: cannot read: {e}", geo.display()))?;
    // The sandbox first: a cached mesh of a .geo that runs commands is not reused either.
    check_commands(geo, policy)?;
    if !gmsh_installed() {
        return Err(format!("{}: {GMSH_MISSING}", geo.display()));
    }
    let size_key = size.map(|h| format!("clmax={h:e}")).unwrap_or_default();
    let version = gmsh_version();
    let key = fnv1a(&[
        &text,
        size_key.as_bytes(),
        version.as_bytes(),
        b"-3 -format msh41 -bin",
    ]);
    let stem = geo
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "mesh".into());
    let name = format!("{stem}-{key:016x}.msh");
    let dir = geo
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
        .join(".fdem-cache");
    let beside = dir.join(&name);
    let fallback = std::env::temp_dir().join("fdem-mesh-cache").join(&name);
    for cached in [&beside, &fallback] {
        if cached.is_file() {
            if let Ok(mut m) = read_msh(cached) {
                m.format = format!("cached gmsh mesh, {}", m.format);
                return Ok(CachedMesh {
                    imported: m,
                    msh: cached.clone(),
                    reused: true,
                });
            }
        }
    }
    let target = if std::fs::create_dir_all(&dir).is_ok() {
        beside
    } else {
        std::fs::create_dir_all(fallback.parent().unwrap_or(Path::new(".")))
            .map_err(|e| format!("{}: cannot create a mesh cache: {e}", geo.display()))?;
        fallback
    };
    let imported = mesh_geo_impl(geo, size, policy, Some(&target))?;
    Ok(CachedMesh {
        imported,
        msh: target,
        reused: false,
    })
}

/// How `.geo` files are run through gmsh.
#[derive(Clone, Debug)]
pub struct GeoPolicy {
    /// Allow `.geo` files (or the files they `Include`) that run commands: `SystemCall`,
    /// `NonBlockingSystemCall`, `Shell`, `OnelabRun`. Off by default: a model downloaded with
    /// a script must not run programs on the user's machine (`fdem run --allow-geo-commands`).
    pub allow_commands: bool,
    /// gmsh is stopped after this long (a `.geo` that loops would hang fdem).
    pub timeout: std::time::Duration,
}

/// gmsh's default time limit [s] (`--gmsh-timeout` changes it).
pub const GMSH_TIMEOUT_SECONDS: u64 = 600;

impl Default for GeoPolicy {
    fn default() -> Self {
        GeoPolicy {
            allow_commands: false,
            timeout: std::time::Duration::from_secs(GMSH_TIMEOUT_SECONDS),
        }
    }
}

/// The gmsh commands that run programs.
const COMMANDS: [&str; 3] = ["SystemCall", "Shell", "OnelabRun"];

/// The first command of [`COMMANDS`] in `geo` or in a file it includes: (file, line, command).
/// Comments are skipped; `Include "f";` is followed (relative to the including file, up to
/// 32 levels, each file once).
pub fn find_commands(geo: &Path) -> Result<Option<(PathBuf, usize, &'static str)>, String> {
    let mut todo = vec![(geo.to_path_buf(), 0usize)];
    let mut seen: Vec<PathBuf> = Vec::new();
    while let Some((file, depth)) = todo.pop() {
        if seen.contains(&file) || depth > 32 {
            continue;
        }
        seen.push(file.clone());
        let text = crate::limits::read_text_bounded(&file, crate::limits::MAX_TEXT_INPUT)
            .map_err(|e| format!("{}: cannot read: {e}", file.display()))?;
        let code = strip_comments(&text);
        for (k, line) in code.lines().enumerate() {
            for word in line.split(|c: char| !(c.is_ascii_alphanumeric() || c == '_')) {
                let hit = COMMANDS
                    .iter()
                    .find(|&&c| word == c || word == "NonBlockingSystemCall" && c == "SystemCall");
                if let Some(c) = hit {
                    return Ok(Some((file, k + 1, c)));
                }
            }
            if let Some(rest) = line.trim_start().strip_prefix("Include") {
                if let Some(name) = rest.split('"').nth(1) {
                    let dir = file.parent().unwrap_or(Path::new(""));
                    todo.push((dir.join(name), depth + 1));
                }
            }
        }
    }
    Ok(None)
}

/// `text` with `//` and `/* */` comments blanked (newlines kept, so lines still count).
fn strip_comments(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut chars = text.chars().peekable();
    let (mut line_comment, mut block_comment, mut in_string) = (false, false, false);
    while let Some(c) = chars.next() {
        if line_comment {
            if c == '\n' {
                line_comment = false;
                out.push(c);
            }
        } else if block_comment {
            if c == '*' && chars.peek() == Some(&'/') {
                chars.next();
                block_comment = false;
            } else if c == '\n' {
                out.push(c);
            }
        } else if !in_string && c == '/' && chars.peek() == Some(&'/') {
            line_comment = true;
        } else if !in_string && c == '/' && chars.peek() == Some(&'*') {
            chars.next();
            block_comment = true;
        } else {
            if c == '"' {
                in_string = !in_string;
            }
            out.push(c);
        }
    }
    out
}

/// Mesh a `.geo` file with the `gmsh` executable (`gmsh -3 -format msh41 -bin`, run in the
/// file's directory so that files it merges are found) and import the result. `size` is the
/// largest element size (`-clmax`). The default [`GeoPolicy`]: commands refused, 600 s.
pub fn mesh_geo(geo: &Path, size: Option<Real>) -> Result<Imported, String> {
    mesh_geo_with(geo, size, &GeoPolicy::default())
}

/// [`mesh_geo`] under `policy`: a `.geo` that runs commands is refused unless allowed; gmsh
/// writes into a private temporary directory (unpredictable name, removed afterwards) and is
/// killed when it runs past the time limit.
pub fn mesh_geo_with(
    geo: &Path,
    size: Option<Real>,
    policy: &GeoPolicy,
) -> Result<Imported, String> {
    mesh_geo_impl(geo, size, policy, None)
}

/// The [`GeoPolicy`] sandbox: an error naming the file, line and command if `geo` (or a file
/// it includes) runs commands and they are not allowed.
fn check_commands(geo: &Path, policy: &GeoPolicy) -> Result<(), String> {
    if !policy.allow_commands {
        if let Some((file, line, c)) = find_commands(geo)? {
            return Err(format!(
                "{}:{line}: the .geo file calls {c}, which runs programs on this machine; fdem refuses it unless you allow it with --allow-geo-commands (only for files you trust)",
                file.display()
            ));
        }
    }
    Ok(())
}

/// [`mesh_geo_with`], also keeping the `.msh` as `keep` if given (copied beside it under a
/// temporary name and renamed, so a cache never holds half a file).
fn mesh_geo_impl(
    geo: &Path,
    size: Option<Real>,
    policy: &GeoPolicy,
    keep: Option<&Path>,
) -> Result<Imported, String> {
    if !geo.is_file() {
        return Err(format!("{}: no such file", geo.display()));
    }
    check_commands(geo, policy)?;
    if !gmsh_installed() {
        return Err(format!("{}: {GMSH_MISSING}", geo.display()));
    }
    let tmp_dir = tempfile::Builder::new()
        .prefix("fdem-gmsh-")
        .tempdir()
        .map_err(|e| {
            format!(
                "{}: cannot create a temporary directory: {e}",
                geo.display()
            )
        })?;
    // Absolute: gmsh runs in the .geo file's directory, and a relative output path would be
    // taken from there (a script's `gmsh("meshes/x.geo")` failed with "Unable to open file";
    // the temporary directory is relative when TMPDIR is).
    let tmp = std::path::absolute(tmp_dir.path().join("mesh.msh"))
        .map_err(|e| format!("{}: {e}", geo.display()))?;
    let log = tmp_dir.path().join("gmsh.log");
    let dir = geo.parent().filter(|d| !d.as_os_str().is_empty());
    let name = geo.file_name().map(Path::new).unwrap_or(geo);
    let mut cmd = std::process::Command::new("gmsh");
    cmd.args(["-3", "-format", "msh41", "-bin", "-o"])
        .arg(&tmp)
        .arg(if dir.is_some() { name } else { geo });
    if let Some(d) = dir {
        cmd.current_dir(d);
    }
    if let Some(h) = size {
        cmd.arg("-clmax").arg(format!("{h:e}"));
    }
    let log_file = std::fs::File::create(&log)
        .map_err(|e| format!("{}: cannot create {}: {e}", geo.display(), log.display()))?;
    let log_err = log_file
        .try_clone()
        .map_err(|e| format!("{}: {e}", geo.display()))?;
    cmd.stdin(std::process::Stdio::null())
        .stdout(log_file)
        .stderr(log_err);
    let status = run_with_timeout(&mut cmd, policy.timeout)
        .map_err(|e| format!("{}: {e}", geo.display()))?;
    let text = std::fs::read_to_string(&log).unwrap_or_default();
    let errors: Vec<&str> = text.lines().filter(|l| l.contains("Error")).collect();
    if !status.success() || !errors.is_empty() || !tmp.is_file() {
        let shown = if errors.is_empty() {
            text.lines()
                .rev()
                .take(5)
                .collect::<Vec<_>>()
                .into_iter()
                .rev()
                .collect::<Vec<_>>()
                .join("\n")
        } else {
            errors.join("\n")
        };
        return Err(format!(
            "{}: gmsh failed to mesh the file ({status}):\n{shown}",
            geo.display()
        ));
    }
    let r = read_msh(&tmp)
        .map(|mut m| {
            m.format = format!("meshed by gmsh, {}", m.format);
            m
        })
        .map_err(|e| format!("{}: meshed by gmsh, but: {e}", geo.display()));
    if let (Ok(_), Some(dest)) = (&r, keep) {
        // The private directory may be on another file system: copy beside `dest`, then
        // rename (atomic), so a cache never holds half a file. A failure only loses the cache.
        let part = dest.with_extension(format!("part{}.msh", std::process::id()));
        if std::fs::copy(&tmp, &part).is_err() || std::fs::rename(&part, dest).is_err() {
            let _ = std::fs::remove_file(&part);
        }
    }
    r
}

/// Run `cmd`, killing it after `timeout`; its exit status.
fn run_with_timeout(
    cmd: &mut std::process::Command,
    timeout: std::time::Duration,
) -> Result<std::process::ExitStatus, String> {
    let mut child = cmd.spawn().map_err(|e| format!("cannot run gmsh: {e}"))?;
    let start = std::time::Instant::now();
    loop {
        match child.try_wait() {
            Ok(Some(status)) => return Ok(status),
            Ok(None) => {}
            Err(e) => return Err(format!("waiting for gmsh: {e}")),
        }
        let interrupted = crate::limits::interrupt::requested().is_some();
        if start.elapsed() >= timeout || interrupted {
            let _ = child.kill();
            let _ = child.wait();
            return Err(if interrupted {
                "gmsh stopped: interrupted".to_string()
            } else {
                format!(
                    "gmsh ran longer than {} s and was stopped (a .geo that loops?); raise the limit with --gmsh-timeout SECONDS",
                    timeout.as_secs_f64()
                )
            });
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
}

// ─── Low-level reading ──────────────────────────────────────────────────────────

struct Reader<'a> {
    b: &'a [u8],
    pos: usize,
    file: &'a str,
    binary: bool,
    big_endian: bool,
    /// Bytes of a `size_t` field in binary files.
    size_t: usize,
}

type R<T> = Result<T, GmshError>;

impl<'a> Reader<'a> {
    fn place(&self, pos: usize) -> Place {
        if self.binary {
            Place::Byte(pos)
        } else {
            let end = pos.min(self.b.len());
            Place::Line(1 + self.b[..end].iter().filter(|&&c| c == b'\n').count())
        }
    }

    fn err_at(&self, pos: usize, msg: impl Into<String>) -> GmshError {
        GmshError {
            file: self.file.to_string(),
            place: self.place(pos),
            message: msg.into(),
        }
    }

    fn eof(&self, what: &str) -> GmshError {
        self.err_at(
            self.b.len(),
            format!("the file ends early (truncated?): expected {what}"),
        )
    }

    fn skip_ws(&mut self) {
        while self.pos < self.b.len() && self.b[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
    }

    /// The next whitespace-separated token and where it starts.
    fn token(&mut self, what: &str) -> R<(&'a str, usize)> {
        self.skip_ws();
        let start = self.pos;
        while self.pos < self.b.len() && !self.b[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        if start == self.pos {
            return Err(self.eof(what));
        }
        let t = std::str::from_utf8(&self.b[start..self.pos])
            .map_err(|_| self.err_at(start, format!("expected {what}, found non-text bytes")))?;
        Ok((t, start))
    }

    fn ascii_int(&mut self, what: &str) -> R<(i64, usize)> {
        let (t, at) = self.token(what)?;
        t.parse::<i64>()
            .map(|v| (v, at))
            .map_err(|_| self.err_at(at, format!("expected {what} (an integer), found '{t}'")))
    }

    fn ascii_float(&mut self, what: &str) -> R<Real> {
        let (t, at) = self.token(what)?;
        match t.parse::<Real>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(self.err_at(
                at,
                format!("expected {what} (a finite number), found '{t}'"),
            )),
        }
    }

    fn bytes(&mut self, n: usize, what: &str) -> R<&'a [u8]> {
        if self.b.len() - self.pos < n {
            return Err(self.eof(what));
        }
        let s = &self.b[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    fn uint_bytes(&self, s: &[u8]) -> u64 {
        let mut v: u64 = 0;
        if self.big_endian {
            for &c in s {
                v = (v << 8) | c as u64;
            }
        } else {
            for &c in s.iter().rev() {
                v = (v << 8) | c as u64;
            }
        }
        v
    }

    /// An `int` field (4 bytes in binary files). Returns the value and where it starts.
    fn int(&mut self, what: &str) -> R<(i64, usize)> {
        if self.binary {
            let at = self.pos;
            let s = self.bytes(4, what)?;
            Ok((self.uint_bytes(s) as u32 as i32 as i64, at))
        } else {
            self.ascii_int(what)
        }
    }

    /// A `size_t` field (non-negative).
    fn size(&mut self, what: &str) -> R<(u64, usize)> {
        if self.binary {
            let at = self.pos;
            let s = self.bytes(self.size_t, what)?;
            Ok((self.uint_bytes(s), at))
        } else {
            let (v, at) = self.ascii_int(what)?;
            if v < 0 {
                return Err(self.err_at(at, format!("expected {what} (≥ 0), found {v}")));
            }
            Ok((v as u64, at))
        }
    }

    fn double(&mut self, what: &str) -> R<Real> {
        if self.binary {
            let at = self.pos;
            let s = self.bytes(8, what)?;
            let v = f64::from_bits(self.uint_bytes(s));
            if !v.is_finite() {
                return Err(self.err_at(at, format!("{what} is not a finite number ({v})")));
            }
            Ok(v)
        } else {
            self.ascii_float(what)
        }
    }

    /// A count that must fit in the rest of the file (`min_bytes` per item at least), so that
    /// a corrupt count is an error rather than a huge allocation.
    fn count(&self, n: u64, at: usize, min_bytes: usize, what: &str) -> R<usize> {
        let rest = (self.b.len() - self.pos) as u64;
        if n.saturating_mul(min_bytes as u64) > rest {
            return Err(self.err_at(
                at,
                format!("bad count: {n} {what} cannot fit in the rest of the file ({rest} bytes; truncated file or wrong count?)"),
            ));
        }
        Ok(n as usize)
    }

    fn expect(&mut self, word: &str) -> R<()> {
        let (t, at) = self.token(word)?;
        if t != word {
            return Err(self.err_at(at, format!("expected {word}, found '{t}'")));
        }
        Ok(())
    }

    /// After binary data, the end marker follows a newline.
    fn expect_end(&mut self, section: &str) -> R<()> {
        self.expect(&format!("$End{section}"))
    }

    /// Skip an unknown section up to its `$End…` line.
    fn skip_section(&mut self, name: &str, at: usize) -> R<()> {
        let end = format!("$End{name}");
        let hay = &self.b[self.pos..];
        match hay.windows(end.len()).position(|w| w == end.as_bytes()) {
            Some(i) => {
                self.pos += i + end.len();
                Ok(())
            }
            None => Err(self.err_at(
                at,
                format!("section ${name} has no {end} (truncated file?)"),
            )),
        }
    }
}

// ─── The file's content before it becomes a Mesh ────────────────────────────────

#[derive(Default)]
struct RawElement {
    tag: u64,
    kind: u32,
    /// Indices into `Raw::x`.
    nodes: Vec<u32>,
    /// Physical groups (dimension, tag) the element belongs to.
    groups: Vec<(u8, i64)>,
    /// Where the element is in the file.
    at: usize,
}

#[derive(Default)]
struct Raw {
    version: String,
    names: BTreeMap<(u8, i64), String>,
    x: Vec<Vec3>,
    node_tags: Vec<u64>,
    elements: Vec<RawElement>,
    warnings: Vec<String>,
}

/// The sections met so far while reading a file.
#[derive(Default)]
struct Seen {
    /// `$Entities` (MSH 4.1): physical groups of each (dimension, entity tag).
    entities: Option<HashMap<(u8, i64), Vec<i64>>>,
    /// `$Nodes`: index into `Raw::x` of each node tag.
    node_index: Option<HashMap<u64, u32>>,
    /// Whether `$Elements` was read.
    have_elements: bool,
}

impl<'a> Reader<'a> {
    /// Read the whole file: the `$MeshFormat` header, then every section up to the end.
    fn read_file(&mut self) -> R<Raw> {
        let mut raw = Raw::default();
        let (version, v4) = self.mesh_format()?;
        raw.version = version;
        let mut seen = Seen::default();
        loop {
            self.skip_ws();
            if self.pos >= self.b.len() {
                break;
            }
            self.section(&mut raw, &mut seen, v4)?;
        }
        if seen.node_index.is_none() {
            return Err(self.err_at_file("missing section $Nodes"));
        }
        if !seen.have_elements {
            return Err(self.err_at_file("missing section $Elements"));
        }
        Ok(raw)
    }

    /// Read the `$MeshFormat` section: the version ("4.1", "2.2", …) and whether it is 4.1.
    fn mesh_format(&mut self) -> R<(String, bool)> {
        self.skip_ws();
        if !self.b[self.pos..].starts_with(b"$MeshFormat") {
            return Err(self.err_at(
                self.pos,
                "not a Gmsh mesh: the file must start with $MeshFormat",
            ));
        }
        self.expect("$MeshFormat")?;
        let (version, vat) = self.token("the format version (4.1 or 2.2)")?;
        let (file_type, fat) = self.ascii_int("the file type (0 = ASCII, 1 = binary)")?;
        let (data_size, dat) = self.ascii_int("the data size (size of size_t)")?;
        let v4 = self.is_v4(version, vat)?;
        match file_type {
            0 => {}
            1 if v4 => self.binary_header(data_size, dat)?,
            1 => return Err(self.err_at(
                fat,
                "binary MSH 2.2 is not supported; save as MSH 4.1 (binary or ASCII) or 2.2 ASCII",
            )),
            t => {
                return Err(
                    self.err_at(fat, format!("file type {t} is not 0 (ASCII) or 1 (binary)"))
                )
            }
        }
        self.expect_end("MeshFormat")?;
        Ok((version.to_string(), v4))
    }

    /// Whether `version` (read at `at`) is 4.1 (true) or 2.x (false); others are refused.
    fn is_v4(&self, version: &str, at: usize) -> R<bool> {
        match version {
            "4.1" => Ok(true),
            v if v.starts_with("2.") => Ok(false),
            "4" | "4.0" => Err(self.err_at(
                at,
                "MSH 4.0 is not supported; save the mesh as MSH 4.1 (gmsh -format msh41) or 2.2 (-format msh22)",
            )),
            v => Err(self.err_at(
                at,
                format!("unsupported MSH version '{v}'; fdem reads 4.1 (ASCII or binary) and 2.2 (ASCII)"),
            )),
        }
    }

    /// Switch to binary: `size_t` of `data_size` bytes, byte order from the integer 1 after.
    fn binary_header(&mut self, data_size: i64, at: usize) -> R<()> {
        if data_size != 4 && data_size != 8 {
            return Err(self.err_at(
                at,
                format!("data size {data_size} is not supported (4 or 8 bytes)"),
            ));
        }
        self.size_t = data_size as usize;
        // The integer 1 in binary after the header line tells the byte order.
        self.skip_line_end();
        let at = self.pos;
        let one = self.bytes(4, "the binary integer 1 (byte-order mark)")?;
        self.binary = true;
        self.big_endian = match one {
            [1, 0, 0, 0] => false,
            [0, 0, 0, 1] => true,
            _ => return Err(self.err_at(at, "bad byte-order mark: expected the binary integer 1")),
        };
        Ok(())
    }

    /// Step over one line end (`\n` or `\r\n`) if the reader is at one.
    fn skip_line_end(&mut self) {
        if self.b.get(self.pos) == Some(&b'\r') {
            self.pos += 1;
        }
        if self.b.get(self.pos) == Some(&b'\n') {
            self.pos += 1;
        }
    }

    /// Read one section, from its `$Name` header to its `$EndName`, into `raw` and `seen`.
    fn section(&mut self, raw: &mut Raw, seen: &mut Seen, v4: bool) -> R<()> {
        let (t, at) = self.token("a section")?;
        let Some(name) = t.strip_prefix('$') else {
            return Err(self.err_at(
                at,
                format!("expected a section header such as $Nodes, found '{t}'"),
            ));
        };
        let name = name.to_string();
        if self.binary {
            // Binary data starts right after the header line's newline.
            self.skip_line_end();
        }
        match name.as_str() {
            "PhysicalNames" => {
                self.once(!raw.names.is_empty(), &name, at)?;
                self.physical_names(raw)
            }
            "Entities" if v4 => {
                self.once(seen.entities.is_some(), &name, at)?;
                seen.entities = Some(self.entities()?);
                Ok(())
            }
            "PartitionedEntities" => Err(self.err_at(
                at,
                "partitioned meshes are not supported; save the mesh unpartitioned",
            )),
            "Nodes" => {
                self.once(seen.node_index.is_some(), &name, at)?;
                seen.node_index = Some(if v4 {
                    self.nodes_v4(raw)?
                } else {
                    self.nodes_v2(raw)?
                });
                Ok(())
            }
            "Elements" => {
                self.once(seen.have_elements, &name, at)?;
                self.elements(raw, seen, v4, at)
            }
            n if n.starts_with("End") => {
                Err(self.err_at(at, format!("${n} without its section start")))
            }
            _ => self.skip_section(&name, at),
        }
    }

    /// Refuse section `$name` (header at `at`) if it was `seen` before.
    fn once(&self, seen: bool, name: &str, at: usize) -> R<()> {
        if seen {
            Err(self.err_at(at, format!("section ${name} appears twice")))
        } else {
            Ok(())
        }
    }

    /// Read the `$Elements` section (header at `at`), which needs `$Nodes` read before.
    fn elements(&mut self, raw: &mut Raw, seen: &mut Seen, v4: bool, at: usize) -> R<()> {
        let Some(index) = seen.node_index.as_ref() else {
            return Err(self.err_at(at, "$Elements comes before $Nodes"));
        };
        if v4 {
            let empty = HashMap::new();
            let ent = seen.entities.as_ref().unwrap_or(&empty);
            self.elements_v4(raw, index, ent)?;
        } else {
            self.elements_v2(raw, index)?;
        }
        seen.have_elements = true;
        Ok(())
    }

    fn err_at_file(&self, msg: &str) -> GmshError {
        GmshError {
            file: self.file.to_string(),
            place: Place::File,
            message: msg.to_string(),
        }
    }

    fn physical_names(&mut self, raw: &mut Raw) -> R<()> {
        let (n, at) = self.ascii_int("the number of physical names")?;
        if n < 0 {
            return Err(self.err_at(at, format!("bad count: {n} physical names")));
        }
        let n = self.count(n as u64, at, 6, "physical names")?;
        for _ in 0..n {
            let (dim, dat) = self.ascii_int("the dimension of a physical group (0–3)")?;
            if !(0..=3).contains(&dim) {
                return Err(self.err_at(
                    dat,
                    format!("physical group dimension {dim} is not 0, 1, 2 or 3"),
                ));
            }
            let (tag, _) = self.ascii_int("a physical group tag")?;
            self.skip_ws();
            let q = self.pos;
            if self.b.get(q) != Some(&b'"') {
                return Err(self.err_at(q, "expected a quoted physical group name"));
            }
            let rest = &self.b[q + 1..];
            let end = rest
                .iter()
                .position(|&c| c == b'"' || c == b'\n')
                .filter(|&i| rest[i] == b'"')
                .ok_or_else(|| {
                    self.err_at(q, "unterminated physical group name (missing closing \")")
                })?;
            let name = String::from_utf8_lossy(&rest[..end]).into_owned();
            self.pos = q + 1 + end + 1;
            raw.names.insert((dim as u8, tag), name);
        }
        self.expect_end("PhysicalNames")
    }

    fn entities(&mut self) -> R<HashMap<(u8, i64), Vec<i64>>> {
        let mut counts = [0usize; 4];
        for (d, c) in counts.iter_mut().enumerate() {
            let what = ["points", "curves", "surfaces", "volumes"][d];
            let (n, at) = self.size(&format!("the number of {what} in $Entities"))?;
            *c = n as usize;
            // Validated item by item below; a first bound keeps allocations sane.
            self.count(n, at, 4, what)?;
        }
        let mut out = HashMap::new();
        for (dim, &n) in counts.iter().enumerate() {
            for _ in 0..n {
                let (tag, _) = self.int("an entity tag")?;
                let coords = if dim == 0 { 3 } else { 6 };
                for _ in 0..coords {
                    self.double("an entity coordinate")?;
                }
                let (np, at) = self.size("the number of physical tags of an entity")?;
                let np = self.count(np, at, 1, "physical tags")?;
                let mut tags = Vec::with_capacity(np);
                for _ in 0..np {
                    let (t, at) = self.int("a physical tag")?;
                    tags.push(self.physical_tag(t, at)?);
                }
                if dim > 0 {
                    let (nb, at) = self.size("the number of bounding entities")?;
                    let nb = self.count(nb, at, 1, "bounding entities")?;
                    for _ in 0..nb {
                        self.int("a bounding entity tag")?;
                    }
                }
                out.insert((dim as u8, tag), tags);
            }
        }
        self.expect_end("Entities")?;
        Ok(out)
    }

    fn add_node(&self, raw: &mut Raw, index: &mut HashMap<u64, u32>, tag: u64, at: usize) -> R<()> {
        if tag == 0 {
            return Err(self.err_at(at, "bad node tag 0: node tags start at 1"));
        }
        let i = raw.node_tags.len() as u32;
        if index.insert(tag, i).is_some() {
            return Err(self.err_at(at, format!("node tag {tag} appears twice in $Nodes")));
        }
        raw.node_tags.push(tag);
        Ok(())
    }

    fn nodes_v4(&mut self, raw: &mut Raw) -> R<HashMap<u64, u32>> {
        let (blocks, bat) = self.size("the number of entity blocks in $Nodes")?;
        let (total, tat) = self.size("the number of nodes")?;
        self.size("the smallest node tag")?;
        self.size("the largest node tag")?;
        let blocks = self.count(blocks, bat, 4, "node blocks")?;
        let total_n = self.count(total, tat, 4, "nodes")?;
        let mut index = HashMap::with_capacity(total_n);
        raw.x.reserve(total_n);
        for _ in 0..blocks {
            let (dim, dat) = self.int("the entity dimension of a node block")?;
            if !(0..=3).contains(&dim) {
                return Err(self.err_at(dat, format!("node block dimension {dim} is not 0–3")));
            }
            self.int("the entity tag of a node block")?;
            let (parametric, _) = self.int("the parametric flag of a node block")?;
            let (n, nat) = self.size("the number of nodes in the block")?;
            let n = self.count(n, nat, 4, "nodes")?;
            if raw.node_tags.len() + n > total_n {
                return Err(self.err_at(
                    nat,
                    format!("bad count: the blocks hold more nodes than the {total} given in the $Nodes header"),
                ));
            }
            for _ in 0..n {
                let (tag, at) = self.size("a node tag")?;
                self.add_node(raw, &mut index, tag, at)?;
            }
            let extra = if parametric != 0 { dim as usize } else { 0 };
            for _ in 0..n {
                let x = self.double("a node x coordinate")?;
                let y = self.double("a node y coordinate")?;
                let z = self.double("a node z coordinate")?;
                for _ in 0..extra {
                    self.double("a parametric node coordinate")?;
                }
                raw.x.push(Vec3::new(x, y, z));
            }
        }
        if raw.node_tags.len() != total_n {
            return Err(self.err_at(
                tat,
                format!(
                    "bad count: the $Nodes header says {total} nodes, its blocks hold {}",
                    raw.node_tags.len()
                ),
            ));
        }
        self.expect_end("Nodes")?;
        Ok(index)
    }

    fn nodes_v2(&mut self, raw: &mut Raw) -> R<HashMap<u64, u32>> {
        let (n, at) = self.size("the number of nodes")?;
        let n = self.count(n, at, 8, "nodes")?;
        let mut index = HashMap::with_capacity(n);
        for _ in 0..n {
            let (tag, at) = self.size("a node tag")?;
            self.add_node(raw, &mut index, tag, at)?;
            let x = self.double("a node x coordinate")?;
            let y = self.double("a node y coordinate")?;
            let z = self.double("a node z coordinate")?;
            raw.x.push(Vec3::new(x, y, z));
        }
        self.expect_end("Nodes")?;
        Ok(index)
    }

    /// Check an element type: known, and a 4-node tetrahedron if 3D.
    fn check_type(&self, kind: i64, at: usize) -> R<(usize, u8)> {
        let Some((nn, dim, meaning)) = u32::try_from(kind).ok().and_then(element_type) else {
            return Err(self.err_at(
                at,
                format!("unknown element type {kind} (not a Gmsh element type fdem knows)"),
            ));
        };
        if dim == 3 && kind != 4 {
            let hint = if meaning.contains("tetrahedron") {
                "mesh with first-order elements (Mesh.ElementOrder = 1)"
            } else {
                "mesh the volume with tetrahedra only (no Recombine, no extrusion layers with Recombine)"
            };
            return Err(self.err_at(
                at,
                format!("element type {kind} ({meaning}) is not supported: fdem needs 4-node tetrahedra (type 4); {hint}"),
            ));
        }
        Ok((nn, dim))
    }

    /// A physical group tag `t` (read at `at`) without its sign (MSH 4.1 entities give the
    /// orientation by it); an error for −2⁶³, which has no positive counterpart.
    fn physical_tag(&self, t: i64, at: usize) -> R<i64> {
        t.checked_abs()
            .ok_or_else(|| self.err_at(at, format!("physical tag {t} is out of range")))
    }

    fn node_ref(&self, index: &HashMap<u64, u32>, tag: u64, elem: u64, at: usize) -> R<u32> {
        index.get(&tag).copied().ok_or_else(|| {
            self.err_at(
                at,
                format!("element {elem} refers to node {tag}, which is not in $Nodes"),
            )
        })
    }

    fn elements_v4(
        &mut self,
        raw: &mut Raw,
        index: &HashMap<u64, u32>,
        entities: &HashMap<(u8, i64), Vec<i64>>,
    ) -> R<()> {
        let (blocks, bat) = self.size("the number of entity blocks in $Elements")?;
        let (total, tat) = self.size("the number of elements")?;
        self.size("the smallest element tag")?;
        self.size("the largest element tag")?;
        let blocks = self.count(blocks, bat, 4, "element blocks")?;
        let total_n = self.count(total, tat, 4, "elements")?;
        let mut seen = 0usize;
        // Element tags are unique in MSH 4.1 (MSH 2.2 repeats an element only with the same
        // nodes, once per physical group; here each element comes once).
        let mut tags: std::collections::HashSet<u64> =
            std::collections::HashSet::with_capacity(total_n);
        for _ in 0..blocks {
            let (edim, dat) = self.int("the entity dimension of an element block")?;
            let (etag, _) = self.int("the entity tag of an element block")?;
            let (kind, kat) = self.int("the element type of a block")?;
            let (n, nat) = self.size("the number of elements in the block")?;
            let (nn, dim) = self.check_type(kind, kat)?;
            if edim != dim as i64 {
                return Err(self.err_at(
                    dat,
                    format!("element block of entity dimension {edim} holds element type {kind} of dimension {dim}"),
                ));
            }
            let n = self.count(n, nat, 2 * (nn + 1), "elements")?;
            seen += n;
            if seen > total_n {
                return Err(self.err_at(
                    nat,
                    format!("bad count: the blocks hold more elements than the {total} given in the $Elements header"),
                ));
            }
            let groups: Vec<(u8, i64)> = entities
                .get(&(dim, etag))
                .map(|t| t.iter().map(|&p| (dim, p)).collect())
                .unwrap_or_default();
            for _ in 0..n {
                let (tag, at) = self.size("an element tag")?;
                if !tags.insert(tag) {
                    return Err(
                        self.err_at(at, format!("element tag {tag} appears twice in $Elements"))
                    );
                }
                let mut nodes = Vec::with_capacity(nn);
                for _ in 0..nn {
                    let (nt, nat) = self.size("a node tag of an element")?;
                    nodes.push(self.node_ref(index, nt, tag, nat)?);
                }
                raw.elements.push(RawElement {
                    tag,
                    kind: kind as u32,
                    nodes,
                    groups: groups.clone(),
                    at,
                });
            }
        }
        if seen != total_n {
            return Err(self.err_at(
                tat,
                format!(
                    "bad count: the $Elements header says {total} elements, its blocks hold {seen}"
                ),
            ));
        }
        self.expect_end("Elements")
    }

    fn elements_v2(&mut self, raw: &mut Raw, index: &HashMap<u64, u32>) -> R<()> {
        let (n, at) = self.size("the number of elements")?;
        let n = self.count(n, at, 8, "elements")?;
        // MSH 2.2 repeats an element once per physical group it belongs to.
        let mut by_tag: HashMap<u64, usize> = HashMap::with_capacity(n);
        for _ in 0..n {
            let (tag, at) = self.size("an element tag")?;
            let (kind, kat) = self.ascii_int("an element type")?;
            let (nn, dim) = self.check_type(kind, kat)?;
            let (ntags, ntat) = self.ascii_int("the number of element tags")?;
            if !(0..=64).contains(&ntags) {
                return Err(self.err_at(ntat, format!("bad count: {ntags} element tags")));
            }
            let mut tags = Vec::with_capacity(ntags as usize);
            for k in 0..ntags {
                let (t, at) = self.ascii_int("an element tag value")?;
                // The first tag is the physical group.
                tags.push(if k == 0 { self.physical_tag(t, at)? } else { t });
            }
            let mut nodes = Vec::with_capacity(nn);
            for _ in 0..nn {
                let (nt, nat) = self.size("a node tag of an element")?;
                nodes.push(self.node_ref(index, nt, tag, nat)?);
            }
            let groups: Vec<(u8, i64)> = match tags.first() {
                Some(&p) if p != 0 => vec![(dim, p)],
                _ => Vec::new(),
            };
            if let Some(&i) = by_tag.get(&tag) {
                let first: &mut RawElement = &mut raw.elements[i];
                if first.kind == kind as u32 && first.nodes == nodes {
                    first.groups.extend(groups);
                    continue;
                }
                return Err(self.err_at(
                    at,
                    format!("element tag {tag} is used twice for different elements"),
                ));
            }
            by_tag.insert(tag, raw.elements.len());
            raw.elements.push(RawElement {
                tag,
                kind: kind as u32,
                nodes,
                groups,
                at,
            });
        }
        self.expect_end("Elements")
    }
}

// ─── From the file's content to a Mesh with sets ────────────────────────────────

impl Raw {
    /// Turn the file's content into the mesh, its named sets and the reader's warnings.
    fn build(mut self, r: &Reader) -> R<Imported> {
        let format = format!(
            "MSH {} {}",
            self.version,
            if r.binary { "binary" } else { "ASCII" }
        );
        let mut warnings = std::mem::take(&mut self.warnings);
        // Tetrahedra, with their element tags for messages.
        let tets_raw: Vec<&RawElement> = self.elements.iter().filter(|e| e.kind == 4).collect();
        if tets_raw.is_empty() {
            return Err(r.err_at_file("the file has no 4-node tetrahedra (element type 4): mesh the volume in 3D (gmsh -3) and, if physical groups are defined, include the volume in one"));
        }
        let (nodes, new_id) = self.used_nodes(&tets_raw, &mut warnings);
        let tets: Vec<[u32; 4]> = tets_raw
            .iter()
            .map(|e| [0, 1, 2, 3].map(|k| new_id[e.nodes[k] as usize]))
            .collect();
        let mut mesh = Mesh::new(nodes, tets);
        let fixed = mesh.fix_orientation();
        if fixed > 0 {
            warnings.push(format!(
                "{fixed} of {} tetrahedra had left-handed node order (negative volume) and were reordered (two nodes swapped)",
                mesh.tets.len()
            ));
        }
        self.fill_sets(r, &mut mesh, &tets_raw, &new_id)?;
        // Named groups that hold no element of the file.
        for ((dim, tag), name) in &self.names {
            if !mesh.sets.names().iter().any(|n| n == name) {
                warnings.push(format!(
                    "physical group '{name}' (dimension {dim}, tag {tag}) has no elements in the file"
                ));
            }
        }
        Ok(Imported {
            mesh,
            warnings,
            format,
        })
    }

    /// Nodes used by tetrahedra and each file node's new index (`u32::MAX`: dropped, warned).
    fn used_nodes(
        &self,
        tets_raw: &[&RawElement],
        warnings: &mut Vec<String>,
    ) -> (Vec<Vec3>, Vec<u32>) {
        let mut used = vec![false; self.x.len()];
        for e in tets_raw {
            for &n in &e.nodes {
                used[n as usize] = true;
            }
        }
        let mut new_id = vec![u32::MAX; self.x.len()];
        let mut nodes = Vec::new();
        for (i, &u) in used.iter().enumerate() {
            if u {
                new_id[i] = nodes.len() as u32;
                nodes.push(self.x[i]);
            }
        }
        let dropped = self.x.len() - nodes.len();
        if dropped > 0 {
            let first: Vec<String> = (0..self.x.len())
                .filter(|&i| !used[i])
                .take(5)
                .map(|i| self.node_tags[i].to_string())
                .collect();
            warnings.push(format!(
                "dropped {dropped} node(s) used by no tetrahedron (node tags {}{}); the others are renumbered",
                first.join(", "),
                if dropped > 5 { ", …" } else { "" }
            ));
        }
        (nodes, new_id)
    }

    /// The name of physical group `g`: its `$PhysicalNames` entry or `physical_<tag>`.
    fn group_name(&self, g: &(u8, i64)) -> String {
        self.names
            .get(g)
            .cloned()
            .unwrap_or_else(|| format!("physical_{}", g.1))
    }

    /// Physical groups → the element, face and node sets of `mesh`.
    fn fill_sets(
        &self,
        r: &Reader,
        mesh: &mut Mesh,
        tets_raw: &[&RawElement],
        new_id: &[u32],
    ) -> R<()> {
        let mut elements: BTreeMap<String, BTreeSet<u32>> = BTreeMap::new();
        let mut node_sets: BTreeMap<String, BTreeSet<u32>> = BTreeMap::new();
        let mut faces: BTreeMap<String, BTreeSet<(u32, u8)>> = BTreeMap::new();
        for (t, e) in tets_raw.iter().enumerate() {
            for g in &e.groups {
                elements
                    .entry(self.group_name(g))
                    .or_default()
                    .insert(t as u32);
            }
        }
        // Tet faces by sorted node triple (sorted, searched by bisection).
        let needs_faces = self
            .elements
            .iter()
            .any(|e| e.kind != 4 && e.groups.iter().any(|g| g.0 == 2));
        let all_faces = if needs_faces {
            super::checks::sorted_faces(mesh, &[])
        } else {
            Vec::new()
        };
        for e in self
            .elements
            .iter()
            .filter(|e| e.kind != 4 && !e.groups.is_empty())
        {
            let (_, dim, _) = element_type(e.kind).expect("checked when read");
            let names: Vec<String> = e.groups.iter().map(|g| self.group_name(g)).collect();
            let ids = self.mesh_nodes(r, e, &names[0], new_id)?;
            if dim == 2 {
                let chosen = self.face_of(r, e, &names[0], &ids, mesh, &all_faces)?;
                for name in &names {
                    faces.entry(name.clone()).or_default().insert(chosen);
                }
            }
            for name in &names {
                node_sets
                    .entry(name.clone())
                    .or_default()
                    .extend(ids.iter().copied());
            }
        }
        mesh.sets.elements = sorted_lists(elements);
        mesh.sets.nodes = sorted_lists(node_sets);
        mesh.sets.faces = sorted_lists(faces);
        Ok(())
    }

    /// The mesh node indices of element `e` of `group`; an error if one is in no tetrahedron.
    fn mesh_nodes(&self, r: &Reader, e: &RawElement, group: &str, new_id: &[u32]) -> R<Vec<u32>> {
        let (_, _, meaning) = element_type(e.kind).expect("checked when read");
        let mut ids = Vec::with_capacity(e.nodes.len());
        for &n in &e.nodes {
            let id = new_id[n as usize];
            if id == u32::MAX {
                return Err(r.err_at(
                    e.at,
                    format!(
                        "element {} ({meaning}) of physical group '{group}' uses node {}, which belongs to no tetrahedron",
                        e.tag, self.node_tags[n as usize]
                    ),
                ));
            }
            ids.push(id);
        }
        Ok(ids)
    }

    /// The (tetrahedron, local face) that element `e` (mesh nodes `ids`) of surface `group` is.
    fn face_of(
        &self,
        r: &Reader,
        e: &RawElement,
        group: &str,
        ids: &[u32],
        mesh: &Mesh,
        all_faces: &[([u32; 3], u32, u8)],
    ) -> R<(u32, u8)> {
        if e.kind != 2 {
            let (_, _, meaning) = element_type(e.kind).expect("checked when read");
            return Err(r.err_at(
                e.at,
                format!("element {} ({meaning}) of surface group '{group}' cannot be a face of a 4-node tetrahedron; only 3-node triangles (type 2) are accepted in surface groups", e.tag),
            ));
        }
        let mut k = [ids[0], ids[1], ids[2]];
        k.sort_unstable();
        let lo = all_faces.partition_point(|f| f.0 < k);
        let owners: Vec<(u32, u8)> = all_faces[lo..]
            .iter()
            .take_while(|f| f.0 == k)
            .map(|f| (f.1, f.2))
            .collect();
        if owners.is_empty() {
            let c = (mesh.nodes[ids[0] as usize]
                + mesh.nodes[ids[1] as usize]
                + mesh.nodes[ids[2] as usize])
                / 3.0;
            return Err(r.err_at(
                e.at,
                format!(
                    "triangle element {} (nodes {}, {}, {}) of surface group '{group}' at ({:.6}, {:.6}, {:.6}) is not a face of any tetrahedron",
                    e.tag, self.node_tags[e.nodes[0] as usize], self.node_tags[e.nodes[1] as usize], self.node_tags[e.nodes[2] as usize],
                    c.x, c.y, c.z
                ),
            ));
        }
        Ok(facing_owner(mesh, ids, &owners))
    }
}

/// Of the (tetrahedron, local face) `owners` of triangle `ids`, the one it belongs to.
fn facing_owner(mesh: &Mesh, ids: &[u32], owners: &[(u32, u8)]) -> (u32, u8) {
    // On the boundary the face has one tetrahedron. On an internal surface, take the
    // tetrahedron whose outward normal agrees with the triangle's orientation.
    if owners.len() == 1 {
        return owners[0];
    }
    let p = ids
        .iter()
        .map(|&i| mesh.nodes[i as usize])
        .collect::<Vec<_>>();
    let n_tri = (p[1] - p[0]).cross(&(p[2] - p[0]));
    *owners
        .iter()
        .find(|&&(t, l)| {
            let f = TET_FACES[l as usize];
            let q = f.map(|c| mesh.nodes[mesh.tets[t as usize][c] as usize]);
            (q[1] - q[0]).cross(&(q[2] - q[0])).dot(&n_tri) > 0.0
        })
        .unwrap_or(&owners[0])
}

/// Named sets as sorted lists.
fn sorted_lists<T>(sets: BTreeMap<String, BTreeSet<T>>) -> BTreeMap<String, Vec<T>> {
    sets.into_iter()
        .map(|(k, v)| (k, v.into_iter().collect()))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit cube split into 5 tetrahedra (4 corner tets + the central one), MSH 4.1 ASCII,
    /// with a volume group and a face group on z = 0 (two triangles) and a point group.
    pub(crate) const CUBE41: &str = "$MeshFormat
4.1 0 8
$EndMeshFormat
$PhysicalNames
3
0 5 \"corner\"
2 2 \"bottom\"
3 1 \"solid\"
$EndPhysicalNames
$Entities
1 0 1 1
1 0 0 0 1 5
1 0 0 0 1 1 0 1 2 0
1 0 0 0 1 1 1 1 1 0
$EndEntities
$Nodes
2 8 1 8
0 1 0 1
1
0 0 0
3 1 0 7
2
3
4
5
6
7
8
1 0 0
0 1 0
1 1 0
0 0 1
1 0 1
0 1 1
1 1 1
$EndNodes
$Elements
3 8 1 8
0 1 15 1
1 1
2 1 2 2
2 1 2 3
3 2 4 3
3 1 4 5
4 1 2 3 5
5 4 3 2 8
6 6 2 5 8
7 7 5 3 8
8 2 3 5 8
$EndElements
";

    #[test]
    fn reads_a_small_cube_with_groups() {
        let m = parse_msh(CUBE41.as_bytes(), "cube.msh").unwrap();
        assert_eq!(m.format, "MSH 4.1 ASCII");
        assert_eq!(m.mesh.nodes.len(), 8);
        assert_eq!(m.mesh.tets.len(), 5);
        assert!((m.mesh.volume() - 1.0).abs() < 1e-14);
        assert!(m
            .mesh
            .tets
            .iter()
            .enumerate()
            .all(|(e, _)| m.mesh.tet_volume(e) > 0.0));
        assert_eq!(m.mesh.sets.elements["solid"].len(), 5);
        assert_eq!(m.mesh.sets.faces["bottom"].len(), 2);
        assert_eq!(m.mesh.sets.nodes["bottom"], vec![0, 1, 2, 3]);
        assert_eq!(m.mesh.sets.nodes["corner"], vec![0]);
    }
}
