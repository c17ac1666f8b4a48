//! Output: ParaView frames (VTK XML `.vtu` + `.pvd` series) written on a background thread,
//! and CSV histories. Frames and whole files are written to a temporary name and renamed into
//! place, so none is ever left half-written, even when a run stops with an error; histories
//! are streamed ([`CsvStream`]: the header when the file is opened, each row appended and
//! flushed to the OS as it is sampled), so a killed run keeps every sample but the last.

pub mod checkpoint;
pub mod frame;
pub mod plot;
pub mod vtu;

use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::thread::JoinHandle;

pub use vtu::write_atomic;

/// Write a CSV file atomically: a header row and rows of numbers (full precision).
pub fn write_csv(
    path: &Path,
    header: &[&str],
    rows: impl Iterator<Item = Vec<f64>>,
) -> std::io::Result<()> {
    let mut s = csv_header(header);
    for row in rows {
        let cells: Vec<String> = row.iter().map(|&v| format_number(v)).collect();
        s.push_str(&cells.join(","));
        s.push('\n');
    }
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir)?;
    }
    write_atomic(path, s.as_bytes())
}

/// The header row of a CSV file, with its line end. A name holding a comma, a quote or a
/// line break (a monitor's name may) is quoted as RFC 4180 says (`"a,b"`; a quote doubled),
/// so that the header keeps one field per column.
pub fn csv_header(header: &[&str]) -> String {
    let mut s = String::new();
    for (i, name) in header.iter().enumerate() {
        if i > 0 {
            s.push(',');
        }
        if name.contains([',', '"', '\n', '\r']) {
            s.push('"');
            s.push_str(&name.replace('"', "\"\""));
            s.push('"');
        } else {
            s.push_str(name);
        }
    }
    s.push('\n');
    s
}

/// The header of a column of `name` in `unit`: `name [unit]`, or `name` without a unit
/// (read back by [`split_unit`]).
pub fn column_header(name: &str, unit: Option<&str>) -> String {
    match unit {
        Some(u) => format!("{name} [{u}]"),
        None => name.to_string(),
    }
}

/// A column header split into name and unit: `force [kN]` → (`force`, `kN`); a header
/// without a trailing `[unit]` (the CSVs of fdem before units, `step`, `time`) → (itself,
/// None). Inverse of [`column_header`] for every unit [`check_unit`] accepts.
pub fn split_unit(header: &str) -> (String, Option<String>) {
    if let Some((name, rest)) = header.rsplit_once(" [") {
        if let Some(u) = rest.strip_suffix(']') {
            if !name.is_empty() && check_unit(u).is_ok() {
                return (name.to_string(), Some(u.to_string()));
            }
        }
    }
    (header.to_string(), None)
}

/// Error unless `u` can be written as a column's unit and read back: not empty, no
/// surrounding spaces, no brackets, no control characters (`"N"`, `"MPa"`, `"m/s²"`, `"-"`
/// for a pure number).
pub fn check_unit(u: &str) -> Result<(), String> {
    if u.is_empty() || u.trim() != u || u.contains(['[', ']']) || u.chars().any(char::is_control) {
        return Err(format!(
            "unit \"{}\" cannot be written in a CSV header as `name [unit]`: give a symbol such as \"N\", \"MPa\" or \"m/s\" (\"-\" for a pure number), without brackets, control characters or surrounding spaces",
            u.escape_debug()
        ));
    }
    Ok(())
}

/// A CSV number: integers (step counts, exact zeros) as integers, everything else in
/// shortest round-trip exponent form (`1.25e-3`).
pub fn format_number(v: f64) -> String {
    let mut s = String::new();
    push_number(&mut s, v);
    s
}

/// [`format_number`] appended to `s` (no allocation once `s` has grown).
pub fn push_number(s: &mut String, v: f64) {
    use std::fmt::Write;
    if v == v.trunc() && v.abs() < 1e15 {
        let _ = write!(s, "{}", v as i64);
    } else {
        let _ = write!(s, "{v:e}");
    }
}

/// `create_dir_all` whose error names the directory.
pub fn create_dir(dir: &Path) -> Result<(), String> {
    if !crate::parallel::is_root() {
        return Ok(()); // rank 0 of a decomposed run writes the files
    }
    std::fs::create_dir_all(dir).map_err(|e| format!("creating directory {}: {e}", dir.display()))
}

/// A CSV history written as it is sampled: the header when the file is created, then each
/// row appended with one `write` and no buffering in the process (a killed run loses at most
/// the row being written). Errors name the file and the OS error.
pub struct CsvStream {
    path: PathBuf,
    /// None on the ranks of a decomposed run other than 0 (which writes the files).
    file: Option<std::fs::File>,
    line: String,
}

impl CsvStream {
    /// Create (or truncate) `path` and write the header row.
    pub fn create(path: &Path, header: &[&str]) -> Result<Self, String> {
        if let Some(dir) = path.parent() {
            create_dir(dir)?;
        }
        let file = if crate::parallel::is_root() {
            Some(
                std::fs::File::create(path)
                    .map_err(|e| format!("writing {}: {e}", path.display()))?,
            )
        } else {
            None
        };
        let mut s = CsvStream {
            path: path.to_path_buf(),
            file,
            line: String::with_capacity(64 * header.len()),
        };
        s.line.push_str(&csv_header(header));
        s.write_line()?;
        Ok(s)
    }

    /// Append one row of numbers.
    pub fn row(&mut self, values: &[f64]) -> Result<(), String> {
        self.line.clear();
        for (i, &v) in values.iter().enumerate() {
            if i > 0 {
                self.line.push(',');
            }
            push_number(&mut self.line, v);
        }
        self.line.push('\n');
        self.write_line()
    }

    fn write_line(&mut self) -> Result<(), String> {
        use std::io::Write;
        let Some(file) = &mut self.file else {
            return Ok(());
        };
        file.write_all(self.line.as_bytes())
            .map_err(|e| format!("writing {}: {e}", self.path.display()))
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Bytes written so far (every row is written through; nothing is held back).
    pub fn bytes(&self) -> Result<u64, String> {
        let Some(file) = &self.file else {
            return Ok(0);
        };
        file.metadata()
            .map(|m| m.len())
            .map_err(|e| format!("reading the length of {}: {e}", self.path.display()))
    }

    /// Continue the history at `path` after its first `bytes` bytes (a restart: rows the
    /// interrupted run wrote after its checkpoint are cut off, to be written again).
    pub fn resume(path: &Path, bytes: u64) -> Result<Self, String> {
        use std::io::{Seek, SeekFrom};
        let fail = |e: std::io::Error| format!("resuming {}: {e}", path.display());
        if !crate::parallel::is_root() {
            return Ok(CsvStream {
                path: path.to_path_buf(),
                file: None,
                line: String::new(),
            });
        }
        let mut file = std::fs::OpenOptions::new()
            .write(true)
            .open(path)
            .map_err(fail)?;
        let len = file.metadata().map_err(fail)?.len();
        if len < bytes {
            return Err(format!(
                "resuming {}: it holds {len} bytes, fewer than the {bytes} it had at the checkpoint (was it changed?)",
                path.display()
            ));
        }
        file.set_len(bytes).map_err(fail)?;
        file.seek(SeekFrom::Start(bytes)).map_err(fail)?;
        Ok(CsvStream {
            path: path.to_path_buf(),
            file: Some(file),
            line: String::new(),
        })
    }
}

enum Job {
    /// Write the files in order (a frame or a piece, then the `.pvtu` and the `.pvd`, each
    /// atomically), stopping at the first error. A file marked `true` is this rank's own (its
    /// piece); the others are written by rank 0 only.
    Frame(Vec<(PathBuf, Vec<u8>, bool)>),
    Flush(mpsc::Sender<std::io::Result<()>>),
}

/// A series of ParaView frames for one simulation, written by a background thread so that
/// output does not stall the time step longer than building the frame's bytes.
pub struct VtkSeries {
    pub dir: PathBuf,
    pub name: String,
    pub entries: Vec<(f64, String)>,
    tx: Option<mpsc::Sender<Job>>,
    worker: Option<JoinHandle<()>>,
    error: std::sync::Arc<std::sync::Mutex<Option<String>>>,
}

impl VtkSeries {
    pub fn new(dir: PathBuf, name: String) -> Self {
        VtkSeries {
            dir,
            name,
            entries: Vec::new(),
            tx: None,
            worker: None,
            error: Default::default(),
        }
    }

    fn sender(&mut self) -> &mpsc::Sender<Job> {
        if self.tx.is_none() {
            let (tx, rx) = mpsc::channel::<Job>();
            let error = self.error.clone();
            self.worker = Some(std::thread::spawn(move || {
                for job in rx {
                    match job {
                        Job::Frame(files) => {
                            for (path, bytes, own) in &files {
                                let written = if *own {
                                    vtu::write_atomic_on_this_rank(path, bytes)
                                } else {
                                    write_atomic(path, bytes)
                                };
                                if let Err(e) = written {
                                    *error.lock().unwrap() =
                                        Some(format!("writing {}: {e}", path.display()));
                                    break;
                                }
                            }
                        }
                        Job::Flush(ack) => {
                            let _ = ack.send(Ok(()));
                        }
                    }
                }
            }));
            self.tx = Some(tx);
        }
        self.tx.as_ref().unwrap()
    }

    /// Queue a frame (its complete `.vtu` bytes) at simulated time `t`. Returns the file path.
    /// A write error of an earlier frame is returned here, naming its file.
    pub fn push(&mut self, t: f64, bytes: Vec<u8>) -> Result<PathBuf, String> {
        self.check()?;
        create_dir(&self.dir)?;
        let file = format!("{}_{:06}.vtu", self.name, self.entries.len());
        self.entries.push((t, file.clone()));
        let path = self.dir.join(&file);
        let files = vec![(path.clone(), bytes, false), self.pvd()];
        self.send(files, &path)?;
        Ok(path)
    }

    /// The piece file names of the next frame written in pieces ([`Self::push_piece`]),
    /// one per rank, relative to the output directory.
    pub fn piece_names(&self, ranks: usize) -> Vec<String> {
        (0..ranks).map(|r| self.piece_name(r)).collect()
    }

    /// Rank `rank`'s piece of the next frame written in pieces.
    fn piece_name(&self, rank: usize) -> String {
        format!("{}_{:06}_p{rank}.vtu", self.name, self.entries.len())
    }

    /// Queue this rank's piece of a frame written in pieces at simulated time `t`: every
    /// rank writes its piece `NAME_NNNNNN_pR.vtu`; rank 0 (`pvtu` given) also writes
    /// `NAME_NNNNNN.pvtu`, which names the pieces, and the `.pvd`, which names the `.pvtu`.
    /// Returns the path of the `.pvtu`.
    pub fn push_piece(
        &mut self,
        t: f64,
        rank: usize,
        piece: Vec<u8>,
        pvtu: Option<Vec<u8>>,
    ) -> Result<PathBuf, String> {
        self.check()?;
        create_dir(&self.dir)?;
        let piece_path = self.dir.join(self.piece_name(rank));
        let file = format!("{}_{:06}.pvtu", self.name, self.entries.len());
        self.entries.push((t, file.clone()));
        let path = self.dir.join(&file);
        let mut files = vec![(piece_path.clone(), piece, true)];
        if let Some(p) = pvtu {
            files.push((path.clone(), p, false));
            files.push(self.pvd());
        }
        self.send(files, &piece_path)?;
        Ok(path)
    }

    /// The `.pvd` of the entries so far: its path and bytes.
    fn pvd(&self) -> (PathBuf, Vec<u8>, bool) {
        (
            self.dir.join(format!("{}.pvd", self.name)),
            vtu::encode_pvd(&self.entries),
            false,
        )
    }

    fn send(&mut self, files: Vec<(PathBuf, Vec<u8>, bool)>, path: &Path) -> Result<(), String> {
        self.sender()
            .send(Job::Frame(files))
            .map_err(|_| format!("writing {}: the VTK writer thread stopped", path.display()))
    }

    /// The first write error of the background writer so far, without waiting for it.
    pub fn check(&mut self) -> Result<(), String> {
        match self.error.lock().map(|mut e| e.take()) {
            Ok(Some(e)) => Err(e),
            _ => Ok(()),
        }
    }

    /// Wait until every queued frame is on disk; report the first write error, if any.
    pub fn flush(&mut self) -> Result<(), String> {
        if let Some(tx) = &self.tx {
            let (ack_tx, ack_rx) = mpsc::channel();
            if tx.send(Job::Flush(ack_tx)).is_ok() {
                let _ = ack_rx.recv();
            }
        }
        match self.error.lock().unwrap().take() {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }
}

impl Drop for VtkSeries {
    fn drop(&mut self) {
        self.tx = None;
        if let Some(w) = self.worker.take() {
            let _ = w.join();
        }
    }
}
