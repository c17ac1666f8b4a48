//! Values that scripts hold: the simulation, bodies, selections, shapes, meshes, materials,
//! tables and monitors; [`register`] gives them their Rhai names and `to_string`.

use crate::io::VtkSeries;
use crate::loads::ground_motion::{GroundMotion, Kinematics};
use crate::loads::TimeFunction;
use crate::material::{Material, StressMeasure};
use crate::mesh::{BoundaryFace, Mesh, Region};
use crate::pipeline::Simulation;
use rhai::{Engine, FnPtr};
use std::cell::RefCell;
use std::collections::HashMap;
use std::path::PathBuf;
use std::rc::Rc;

/// Shared handle to a simulation and its script-side state.
#[derive(Clone)]
pub struct SimHandle(pub Rc<RefCell<SimState>>);

pub struct SimState {
    pub sim: Simulation,
    /// Identity of this simulation, carried by every selection made from it.
    pub owner: Owner,
    pub name: String,
    pub out_dir: PathBuf,
    pub stress_output: StressMeasure,
    pub vtk_encoding: crate::io::vtu::Encoding,
    /// Frames in pieces, one per rank (`vtk_pieces: "per_rank"`): a `.pvtu` per frame.
    pub vtk_pieces: bool,
    pub hooks: Vec<Hook>,
    pub monitors: Vec<MonitorHandle>,
    pub vtk: VtkSeries,
    /// The crack surface, one frame per `write_vtk` when the model has joints.
    pub cracks_vtk: VtkSeries,
    /// The bars of the rebars, one frame per `write_vtk` when the model has rebars.
    pub bars_vtk: VtkSeries,
    /// Material uid (from `material(..)`) → material id in this simulation.
    pub material_ids: HashMap<u64, u32>,
    /// Number of completed `run` calls.
    pub runs: usize,
    /// The last time-step line printed, without the element's place: printed again only when
    /// the rest changes (`runner::prepare_run`).
    pub printed_dt: Option<String>,
    /// Wall time spent inside runs [s].
    pub wall: f64,
    pub steps_in_runs: u64,
    /// `sim.on_joint_broken(|s, joint| …)`.
    pub on_joint_broken: Option<FnPtr>,
    /// Break events already handed to the callback.
    pub events_dispatched: usize,
    /// `sim.on_new_contact_pair(|s, pair| …)`.
    pub on_new_contact_pair: Option<FnPtr>,
    /// The balance-error warning was printed (once per simulation).
    pub balance_warned: bool,
    /// The contact-penetration warning was printed (once per simulation).
    pub penetration_warned: bool,
    /// `energy.csv`, streamed from the first run on.
    pub energy_csv: Option<crate::io::CsvStream>,
    /// Energy samples already in `energy.csv`.
    pub energy_rows: usize,
    /// `cracks.csv` (models with joints), streamed from the first run on.
    pub cracks_csv: Option<crate::io::CsvStream>,
    /// Break events already in `cracks.csv`.
    pub crack_rows: usize,
    /// `fdem check`: nothing is written.
    pub dry: bool,
    /// `--overwrite`: earlier output of this simulation may be replaced.
    pub overwrite: bool,
    /// `--restart` continues this simulation and its checkpoint is not restored yet: runs
    /// before the checkpoint's are skipped, and frames and histories are not written.
    pub restore_pending: bool,
    /// `sim.checkpoint()` was called inside a run: written at the end of the step.
    pub checkpoint_requested: bool,
    /// The run in progress started at this (time [s], step); None between runs.
    pub run_start: Option<(f64, u64)>,
    /// The run in progress is ended by a rule in Rust (`bring_to_rest`), whose own state a
    /// checkpoint cannot hold: checkpoints wait for its end.
    pub native_run: bool,
    /// What each completed `bring_to_rest` returned: a checkpoint keeps them, and a restart
    /// replaying the script returns them again from the calls it skips.
    pub rest_results: Vec<super::checkpoint::RestRecord>,
}

/// Error unless `name` can name a file: not empty, not `.` or `..`, no path separator,
/// no leading dot, no control character (nor U+FFFE, U+FFFF, which the `.pvd` file's XML
/// cannot hold), at most 100 characters.
pub fn check_file_name(func: &str, what: &str, name: &str) -> Result<(), Box<rhai::EvalAltResult>> {
    let bad = name.is_empty()
        || name.starts_with('.')
        || name.chars().count() > 100
        || name
            .chars()
            .any(|c| c == '/' || c == '\\' || c.is_control() || !crate::io::vtu::xml_char(c));
    if bad {
        return Err(format!(
            "{func}: {what} '{}' cannot name a file: use letters, digits, '_' or '-' (not empty, no leading '.', no '/' or '\\', at most 100 characters)",
            name.escape_debug()
        )
        .into());
    }
    Ok(())
}

/// A joint law from `joint_law(..)`; penalties default to 10 × the Young's modulus of the
/// body the joints are inserted in.
#[derive(Clone, Debug)]
pub struct JointLawValue {
    pub name: String,
    /// None for "tied" and script laws.
    pub cohesive: Option<crate::joints::law::Cohesive>,
    /// A compiled Rhai law.
    pub script: Option<std::sync::Arc<crate::compiled::CompiledLaw>>,
    /// (p_n, p_t) [Pa] when given.
    pub penalties: (Option<f64>, Option<f64>),
}

/// A periodic callback.
pub struct Hook {
    pub every_steps: Option<u64>,
    pub every_time: Option<f64>,
    pub next_time: f64,
    pub f: FnPtr,
}

#[derive(Clone)]
pub struct MonitorHandle(pub Rc<RefCell<MonitorData>>);

pub struct MonitorData {
    pub name: String,
    /// The `unit` key: written into the CSV header as `name [unit]`, put on plot axes.
    pub unit: Option<String>,
    pub every: u64,
    pub f: FnPtr,
    pub times: Vec<f64>,
    pub steps: Vec<u64>,
    pub values: Vec<f64>,
    pub path: PathBuf,
    /// The CSV file, created with the first sample (none under `fdem check`).
    pub csv: Option<crate::io::CsvStream>,
    /// `fdem check`: nothing is written.
    pub dry: bool,
}

#[derive(Clone)]
pub struct BodyHandle {
    pub sim: SimHandle,
    pub id: usize,
}

/// The simulation a selection was made from: selections hold ids into that simulation's
/// arrays, so using one with another simulation is an error naming both (never a panic, or
/// a silent selection of other nodes).
#[derive(Clone, Debug)]
pub struct Owner {
    /// Unique in the process (simulations of one script, and of every script a test runs).
    pub uid: u64,
    pub name: Rc<str>,
}

impl Owner {
    /// A new identity for a simulation named `name`.
    pub fn new(name: &str) -> Self {
        static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
        Owner {
            uid: NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
            name: name.into(),
        }
    }

    /// An error of `func` when a selection (`what`: "these nodes", "body 'b'") made in this
    /// simulation is used with simulation `user`.
    pub fn check(
        &self,
        user: &Owner,
        func: &str,
        what: &str,
    ) -> Result<(), Box<rhai::EvalAltResult>> {
        if self.uid == user.uid {
            return Ok(());
        }
        let (a, b) = if self.name == user.name {
            (
                format!("another simulation named '{}'", self.name),
                format!("'{}'", user.name),
            )
        } else {
            (
                format!("simulation '{}'", self.name),
                format!("'{}'", user.name),
            )
        };
        Err(format!(
            "{func}: {what} from {a} cannot be used with {b}: bodies and selections hold ids into the simulation that made them; select again from a body of {b}"
        )
        .into())
    }
}

#[derive(Clone, Debug)]
pub struct NodeSet(pub Rc<Vec<u32>>, pub Owner);

#[derive(Clone, Debug)]
pub struct ElementSet(pub Rc<Vec<u32>>, pub Owner);

#[derive(Clone, Debug)]
pub struct FaceSet {
    pub faces: Rc<Vec<BoundaryFace>>,
    /// Reference area [m²].
    pub area: f64,
    pub owner: Owner,
}

impl SimHandle {
    /// The simulation with every node's position, velocity and reaction current, for
    /// queries that read them. A decomposed model's ranks keep current only the nodes they
    /// compute: this shares the rest (a collective, at most once per step; every rank runs
    /// the same script, so all call it alike). Hooks and monitors no longer share every
    /// node before they run: a query that needs them does.
    pub fn current(&self) -> std::cell::Ref<'_, SimState> {
        self.0.borrow_mut().sim.synchronize_nodes();
        self.0.borrow()
    }

    /// [`SimHandle::current`] for queries of the nodes `which` alone: only they are made
    /// current (every rank passes the same list).
    pub fn current_nodes(&self, which: &[u32]) -> std::cell::Ref<'_, SimState> {
        self.0.borrow_mut().sim.synchronize_some_nodes(which);
        self.0.borrow()
    }

    /// [`SimHandle::current`] for queries of body `body` alone: its nodes are made current
    /// (nothing for a rigid body: every rank advances every rigid body's nodes).
    pub fn current_body(&self, body: usize) -> std::cell::Ref<'_, SimState> {
        let nodes: Vec<u32> = {
            let st = self.0.borrow();
            if st.sim.is_rigid(body) {
                Vec::new()
            } else {
                st.sim.bodies[body]
                    .nodes
                    .clone()
                    .map(|n| n as u32)
                    .collect()
            }
        };
        if nodes.is_empty() {
            return self.0.borrow();
        }
        self.current_nodes(&nodes)
    }

    /// [`SimHandle::current`] for queries of the tets `which`: their nodes are made current.
    pub fn current_tets(&self, which: &[u32]) -> std::cell::Ref<'_, SimState> {
        let nodes: Vec<u32> = {
            let st = self.0.borrow();
            which
                .iter()
                .flat_map(|&e| st.sim.tets.nodes[e as usize])
                .collect()
        };
        self.current_nodes(&nodes)
    }

    /// This simulation's identity.
    pub fn owner(&self) -> Owner {
        self.0.borrow().owner.clone()
    }

    /// The node ids of `n` when it was selected in this simulation; else an error of `func`.
    pub fn nodes_of<'a>(
        &self,
        n: &'a NodeSet,
        func: &str,
    ) -> Result<&'a [u32], Box<rhai::EvalAltResult>> {
        n.1.check(&self.0.borrow().owner, func, "these nodes")?;
        Ok(&n.0)
    }

    /// The element ids of `e` when it was selected in this simulation; else an error.
    pub fn elements_of<'a>(
        &self,
        e: &'a ElementSet,
        func: &str,
    ) -> Result<&'a [u32], Box<rhai::EvalAltResult>> {
        e.1.check(&self.0.borrow().owner, func, "these elements")?;
        Ok(&e.0)
    }

    /// The faces of `f` when they were selected in this simulation; else an error.
    pub fn faces_of<'a>(
        &self,
        f: &'a FaceSet,
        func: &str,
    ) -> Result<&'a [BoundaryFace], Box<rhai::EvalAltResult>> {
        f.owner.check(&self.0.borrow().owner, func, "these faces")?;
        Ok(&f.faces)
    }

    /// The id of body `b` when it belongs to this simulation; else an error of `func`.
    pub fn body_of(&self, b: &BodyHandle, func: &str) -> Result<usize, Box<rhai::EvalAltResult>> {
        if Rc::ptr_eq(&self.0, &b.sim.0) {
            return Ok(b.id);
        }
        let (theirs, name) = {
            let st = b.sim.0.borrow();
            (st.owner.clone(), st.sim.bodies[b.id].name.clone())
        };
        theirs.check(&self.0.borrow().owner, func, &format!("body '{name}'"))?;
        Ok(b.id)
    }
}

#[derive(Clone, Debug)]
pub struct Shape(pub Region);

#[derive(Clone, Debug)]
pub struct MeshValue(pub Rc<Mesh>);

#[derive(Clone, Debug)]
pub struct MaterialValue {
    pub uid: u64,
    pub material: Material,
}

#[derive(Clone, Debug)]
pub struct Table(pub TimeFunction);

/// A ground-motion record from `ground_motion(..)`, with its integrated velocity and
/// displacement (computed once).
#[derive(Clone, Debug)]
pub struct Record(pub Rc<(GroundMotion, Kinematics)>);

/// Union of two sorted id lists.
pub fn union(a: &[u32], b: &[u32]) -> Vec<u32> {
    let mut v: Vec<u32> = a.iter().chain(b).copied().collect();
    v.sort_unstable();
    v.dedup();
    v
}

/// Register the script value types under their Rhai names, with `to_string` (what `print`
/// shows).
pub fn register(engine: &mut Engine) {
    engine
        .register_type_with_name::<SimHandle>("Simulation")
        .register_type_with_name::<BodyHandle>("Body")
        .register_type_with_name::<NodeSet>("Nodes")
        .register_type_with_name::<ElementSet>("Elements")
        .register_type_with_name::<FaceSet>("Faces")
        .register_type_with_name::<Shape>("Shape")
        .register_type_with_name::<MeshValue>("Mesh")
        .register_type_with_name::<MaterialValue>("Material")
        .register_type_with_name::<Table>("Table")
        .register_type_with_name::<Record>("GroundMotion")
        .register_type_with_name::<MonitorHandle>("Monitor");
    engine.register_fn("to_string", |b: &mut BodyHandle| {
        format!("Body '{}'", b.sim.0.borrow().sim.bodies[b.id].name)
    });
    engine.register_fn("to_string", |n: &mut NodeSet| {
        format!("Nodes({})", n.0.len())
    });
    engine.register_fn("to_string", |n: &mut ElementSet| {
        format!("Elements({})", n.0.len())
    });
    engine.register_fn("to_string", |f: &mut FaceSet| {
        format!("Faces({}, area {:e} m²)", f.faces.len(), f.area)
    });
    engine.register_fn("to_string", |m: &mut MeshValue| {
        format!("Mesh({} nodes, {} tets)", m.0.nodes.len(), m.0.tets.len())
    });
    engine.register_fn("to_string", |m: &mut MaterialValue| {
        format!("Material({})", m.material.formulation.name())
    });
    engine.register_fn("to_string", |s: &mut Shape| {
        format!("Shape({})", s.0.kind())
    });
    engine.register_fn("to_string", |s: &mut SimHandle| {
        format!("Simulation '{}'", s.0.borrow().name)
    });
    engine.register_fn("to_string", |r: &mut Record| {
        let g = &r.0 .0;
        format!(
            "GroundMotion '{}' ({} samples at {} s)",
            g.name,
            g.acc.len(),
            g.dt
        )
    });
    engine.register_fn("to_string", |m: &mut MonitorHandle| {
        format!("Monitor '{}'", m.0.borrow().name)
    });
}
