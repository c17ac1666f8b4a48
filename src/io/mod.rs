//! Output: ParaView frames (VTK XML `.vtu` + `.pvd` series) written on a background thread,
//! and CSV histories. Every file is written whole to a temporary name and renamed into place,
//! so no output is ever left half-written, even when a run stops with an error.

pub mod frame;
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
    let mut s = header.join(",");
    s.push('\n');
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

/// A CSV number: integers (step counts, exact zeros) as integers, everything else in
/// shortest round-trip exponent form (`1.25e-3`).
pub fn format_number(v: f64) -> String {
    if v == v.trunc() && v.abs() < 1e15 {
        format!("{}", v as i64)
    } else {
        format!("{v:e}")
    }
}

enum Job {
    /// Write the bytes to the path, then rewrite the pvd with these entries.
    Frame {
        path: PathBuf,
        bytes: Vec<u8>,
        pvd_path: PathBuf,
        pvd: Vec<u8>,
    },
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
                        Job::Frame {
                            path,
                            bytes,
                            pvd_path,
                            pvd,
                        } => {
                            let r = write_atomic(&path, &bytes)
                                .and_then(|_| write_atomic(&pvd_path, &pvd));
                            if let Err(e) = r {
                                *error.lock().unwrap() =
                                    Some(format!("writing {}: {e}", path.display()));
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
    pub fn push(&mut self, t: f64, bytes: Vec<u8>) -> std::io::Result<PathBuf> {
        std::fs::create_dir_all(&self.dir)?;
        let file = format!("{}_{:06}.vtu", self.name, self.entries.len());
        self.entries.push((t, file.clone()));
        let path = self.dir.join(&file);
        let pvd = vtu::encode_pvd(&self.entries);
        let pvd_path = self.dir.join(format!("{}.pvd", self.name));
        let job = Job::Frame {
            path: path.clone(),
            bytes,
            pvd_path,
            pvd,
        };
        self.sender()
            .send(job)
            .map_err(|_| std::io::Error::other("VTK writer thread stopped"))?;
        Ok(path)
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
