//! Developer tool beside stage 2 (not a stage): the joints' energy audit.
//!
//! With `FDEM_JOINT_AUDIT=1` in the environment, stage 2 records every joint's nodal forces,
//! stored energy and dissipation each step (energies are then sampled every step), and after
//! the stage the audit books, joint by joint, the work of its forces over the last step
//! (trapezoid ½(F_n + F_{n+1})·Δx, the central difference's rule) against the change of its
//! stored energy plus what it booked as dissipated. Every 1000 steps it prints to stderr the
//! running sums of work − (ΔΨ + D) by regime (intact, softening, broken and closed, broken
//! and open, parted, taken over by contact) and the joints with the largest sums;
//! `FDEM_AUDIT_JOINT=j` also prints joint j's points every step. A sum far from zero is
//! energy the joint law creates or loses that the energy account does not book: this is how
//! the drop-weight beam's balance error was traced to softening joints under compression
//! (docs/theory/joints.md, "Known limit"). Off, it costs one branch per step and per joint
//! on the general path; stage 2's fast path is not taken while auditing (the audit records every
//! point), so an audited run follows the general path's rounding and is not bit-identical to an
//! unaudited one.

use crate::math::{Real, SyncPtr, Vec3};
use std::sync::{Mutex, OnceLock};

/// Whether the audit runs (`FDEM_JOINT_AUDIT=1`, read once).
pub fn on() -> bool {
    static ON: OnceLock<bool> = OnceLock::new();
    *ON.get_or_init(|| std::env::var("FDEM_JOINT_AUDIT").is_ok_and(|v| v == "1"))
}

/// The joint whose points are printed every step (`FDEM_AUDIT_JOINT=j`).
pub fn traced() -> Option<usize> {
    static T: OnceLock<Option<usize>> = OnceLock::new();
    *T.get_or_init(|| {
        std::env::var("FDEM_AUDIT_JOINT")
            .ok()
            .and_then(|v| v.parse().ok())
    })
}

/// A joint's regime in one evaluation, for the sums.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[repr(u8)]
pub enum Regime {
    Intact = 0,
    Softening = 1,
    BrokenClosed = 2,
    BrokenOpen = 3,
    Parted = 4,
    /// Not evaluated (taken over by contact).
    Skipped = 5,
}
const NAMES: [&str; 6] = [
    "intact",
    "softening",
    "broken closed",
    "broken open",
    "parted",
    "taken over",
];

impl Regime {
    /// A point's regime from its damage after the evaluation and whether it pushes or rubs.
    pub fn of_point(damage: Real, closed: bool) -> Regime {
        match damage {
            d if d <= 0.0 => Regime::Intact,
            d if d < 1.0 => Regime::Softening,
            _ if closed => Regime::BrokenClosed,
            _ => Regime::BrokenOpen,
        }
    }
    /// A joint's regime from its points': softening if any point softens, else the lowest.
    fn merge(self, point: Regime) -> Regime {
        if self == Regime::Skipped {
            point
        } else if self == Regime::Softening || point == Regime::Softening {
            Regime::Softening
        } else if (point as u8) < (self as u8) {
            point
        } else {
            self
        }
    }
}

/// One evaluation of every joint.
#[derive(Default)]
struct Evaluation {
    /// Forces on face A's three nodes, then face B's [N].
    force: Vec<[Vec3; 6]>,
    energy: Vec<Real>,
    dissipated: Vec<Real>,
    regime: Vec<Regime>,
}

#[derive(Default)]
struct Audit {
    current: Evaluation,
    last: Evaluation,
    /// The joints' node positions at the last evaluation.
    last_x: Vec<[Vec3; 6]>,
    /// Work − (ΔΨ + D) per joint, summed over the steps [J].
    unbooked: Vec<Real>,
    by_regime: [Real; 6],
    by_regime_abs: [Real; 6],
    steps: u64,
}

static AUDIT: Mutex<Option<Audit>> = Mutex::new(None);

/// Stage 2's writer into the current evaluation: each joint is written by the one thread
/// that evaluates it (stage 2's blocks), so the records need no lock.
#[derive(Clone, Copy)]
pub struct Recorder {
    force: SyncPtr<[Vec3; 6]>,
    energy: SyncPtr<Real>,
    dissipated: SyncPtr<Real>,
    regime: SyncPtr<Regime>,
}

impl Recorder {
    /// Start an evaluation of `n` joints (all zero and [`Regime::Skipped`]).
    pub fn begin(n: usize) -> Recorder {
        let mut guard = AUDIT.lock().unwrap_or_else(|e| e.into_inner());
        let e = &mut guard.get_or_insert_with(Default::default).current;
        e.force.clear();
        e.force.resize(n, [Vec3::zeros(); 6]);
        e.energy.clear();
        e.energy.resize(n, 0.0);
        e.dissipated.clear();
        e.dissipated.resize(n, 0.0);
        e.regime.clear();
        e.regime.resize(n, Regime::Skipped);
        // The vectors live in the static and are not resized until `close_step`, which stage
        // 2 calls after its blocks have finished.
        Recorder {
            force: SyncPtr(e.force.as_mut_ptr()),
            energy: SyncPtr(e.energy.as_mut_ptr()),
            dissipated: SyncPtr(e.dissipated.as_mut_ptr()),
            regime: SyncPtr(e.regime.as_mut_ptr()),
        }
    }

    /// Add point `p` of joint `j`: the force on its face-B node (minus it on face A's), its
    /// stored energy and dissipation [J], and its regime.
    ///
    /// # Safety
    /// `j` < the `n` of [`Recorder::begin`], and joint `j` is recorded by one thread only.
    pub unsafe fn point(
        &self,
        j: usize,
        p: usize,
        on_b: Vec3,
        energy: Real,
        dissipated: Real,
        regime: Regime,
    ) {
        // SAFETY: by the caller's contract.
        unsafe {
            let f = &mut *self.force.get().add(j);
            f[p] -= on_b;
            f[3 + p] += on_b;
            *self.energy.get().add(j) += energy;
            *self.dissipated.get().add(j) += dissipated;
            let r = &mut *self.regime.get().add(j);
            *r = r.merge(regime);
        }
    }

    /// Add dissipation to joint `j` outside its points (rate factors, parting) [J], and mark
    /// it parted if `parted`.
    ///
    /// # Safety
    /// As for [`Recorder::point`].
    pub unsafe fn dissipated(&self, j: usize, dissipated: Real, parted: bool) {
        // SAFETY: by the caller's contract.
        unsafe {
            *self.dissipated.get().add(j) += dissipated;
            if parted {
                *self.regime.get().add(j) = Regime::Parted;
            }
        }
    }
}

/// After stage 2 at positions `x` (time `time`): book every joint's step since the last
/// evaluation, and print the sums every 1000 steps.
pub fn close_step(faces: &[[[u32; 3]; 2]], x: &[Vec3], time: Real) {
    let mut guard = AUDIT.lock().unwrap_or_else(|e| e.into_inner());
    let Some(a) = guard.as_mut() else { return };
    let n = faces.len();
    let have_last = a.last_x.len() == n && a.last.force.len() == n;
    a.unbooked.resize(n, 0.0);
    a.last_x.resize(n, [Vec3::zeros(); 6]);
    for (j, face) in faces.iter().enumerate() {
        let xs: [Vec3; 6] = std::array::from_fn(|i| x[face[i / 3][i % 3] as usize]);
        if have_last {
            let (c, l) = (&a.current, &a.last);
            let work: Real = (0..6)
                .map(|i| 0.5 * (l.force[j][i] + c.force[j][i]).dot(&(xs[i] - a.last_x[j][i])))
                .sum();
            let unbooked = work + (c.energy[j] - l.energy[j]) + c.dissipated[j];
            a.unbooked[j] += unbooked;
            let r = if c.regime[j] == Regime::Skipped {
                l.regime[j]
            } else {
                c.regime[j]
            } as usize;
            a.by_regime[r] += unbooked;
            a.by_regime_abs[r] += unbooked.abs();
            if Some(j) == traced() {
                eprintln!(
                    "audit t={time:.6e} joint {j}: work {work:.4e} ΔΨ {:.4e} D {:.4e} unbooked {unbooked:.4e} J",
                    c.energy[j] - l.energy[j],
                    c.dissipated[j]
                );
            }
        }
        a.last_x[j] = xs;
    }
    std::mem::swap(&mut a.last, &mut a.current);
    a.steps += 1;
    if a.steps.is_multiple_of(1000) {
        let sums: Vec<String> = (0..6)
            .map(|r| {
                format!(
                    "{} {:.4} (|·| {:.4})",
                    NAMES[r], a.by_regime[r], a.by_regime_abs[r]
                )
            })
            .collect();
        eprintln!(
            "joint audit t={time:.6e} s, work − (ΔΨ + D) [J]: {}",
            sums.join(", ")
        );
        let mut worst: Vec<usize> = (0..n).collect();
        worst.sort_by(|&p, &q| a.unbooked[q].abs().total_cmp(&a.unbooked[p].abs()));
        for &j in worst.iter().take(5) {
            eprintln!(
                "  joint {j}: {:.4} J, now {}",
                a.unbooked[j], NAMES[a.last.regime[j] as usize]
            );
        }
    }
}
