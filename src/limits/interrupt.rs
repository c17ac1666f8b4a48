//! SIGINT and SIGTERM: the first asks the run to stop at the end of the current step (the
//! runner flushes every history, writes a final frame and returns an error, so the summary is
//! printed and `fdem` exits non-zero); a script that is not stepping (a runaway loop) is
//! stopped by the engine's progress check. A second signal exits at once: a watcher thread
//! (not the signal handler, which only counts) removes the temporary files of writes in
//! flight and exits with 128 + the signal number. Histories are appended and flushed as they
//! are sampled and every other file is renamed into place whole, so what is on disk is valid.
//!
//! Nothing is installed unless [`install`] is called (the `fdem` command does); tests that
//! run scripts in-process are not affected, except through [`request`].

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicI32, AtomicUsize, Ordering};
use std::sync::Mutex;

/// Signals received (SIGINT and SIGTERM).
static RECEIVED: AtomicUsize = AtomicUsize::new(0);
/// The last signal received.
static SIGNAL: AtomicI32 = AtomicI32::new(0);
/// Temporary files being written (removed by a hard exit).
static IN_FLIGHT: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

extern "C" fn on_signal(sig: libc::c_int) {
    // Only async-signal-safe work here: two atomic stores.
    SIGNAL.store(sig, Ordering::SeqCst);
    RECEIVED.fetch_add(1, Ordering::SeqCst);
}

/// Handle SIGINT and SIGTERM as described in the module doc (once per process).
pub fn install() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        for sig in [libc::SIGINT, libc::SIGTERM] {
            // SAFETY: `on_signal` only stores to atomics, which is async-signal-safe; the
            // sigaction struct is zeroed and then filled as sigaction(2) requires.
            unsafe {
                let mut act: libc::sigaction = std::mem::zeroed();
                act.sa_sigaction = on_signal as *const () as usize;
                act.sa_flags = libc::SA_RESTART;
                libc::sigemptyset(&mut act.sa_mask);
                libc::sigaction(sig, &act, std::ptr::null_mut());
            }
        }
        std::thread::spawn(|| loop {
            std::thread::sleep(std::time::Duration::from_millis(20));
            if RECEIVED.load(Ordering::SeqCst) >= 2 {
                hard_exit();
            }
        });
    });
}

/// The second signal: remove the temporary files of writes in flight and exit at once.
fn hard_exit() -> ! {
    let sig = SIGNAL.load(Ordering::SeqCst);
    // The lock is held until the process exits: a writer that has not yet created its
    // temporary file blocks in [`create_temp`] and never creates it (creating it after the
    // removal below is the race that left a `.tmp` behind).
    let guard = IN_FLIGHT.lock();
    if let Ok(list) = &guard {
        for p in list.iter() {
            let _ = std::fs::remove_file(p);
        }
    }
    eprintln!(
        "\nfdem: second {}: exiting now (files written so far are complete; histories end at their last sample)",
        signal_name(sig)
    );
    std::process::exit(128 + sig);
}

/// Name of a signal number.
pub fn signal_name(sig: i32) -> &'static str {
    match sig {
        libc::SIGINT => "SIGINT",
        libc::SIGTERM => "SIGTERM",
        _ => "signal",
    }
}

/// The signal that asked the run to stop, if one did.
pub fn requested() -> Option<i32> {
    (RECEIVED.load(Ordering::Relaxed) > 0).then(|| SIGNAL.load(Ordering::Relaxed))
}

/// Ask for a stop as a signal would (tests; `sig` is SIGINT or SIGTERM).
pub fn request(sig: i32) {
    on_signal(sig);
}

/// Forget a request (tests that run several scripts in one process).
pub fn clear() {
    RECEIVED.store(0, Ordering::SeqCst);
    SIGNAL.store(0, Ordering::SeqCst);
}

/// Create a temporary file and note it while it is written (a hard exit removes it).
/// Creation and noting happen under one lock, which a hard exit holds until the process
/// ends, so no temporary file can appear after the hard exit has cleaned up.
pub fn create_temp(path: &Path) -> std::io::Result<std::fs::File> {
    let mut list = IN_FLIGHT.lock().unwrap_or_else(|e| e.into_inner());
    let file = std::fs::File::create(path)?;
    list.push(path.to_path_buf());
    Ok(file)
}

/// The temporary file was renamed into place or removed.
pub fn end_temp(path: &Path) {
    if let Ok(mut l) = IN_FLIGHT.lock() {
        if let Some(i) = l.iter().position(|p| p == path) {
            l.swap_remove(i);
        }
    }
}
