//! # fdem — the combined finite–discrete element method, driven by Rhai model scripts
//!
//! Bodies are deformable discrete elements meshed into constant-strain tetrahedra. Time runs
//! explicitly with the central difference method. One time step is Munjiza's seven stages, and
//! the module list reads as the step ([`pipeline::Simulation::step`]):
//!
//! 1. [`elements`] — stress in every element from its deformation; nodal internal forces
//!    (one module per element family: [`elements::tet4`]).
//! 2. [`joints`] — joint forces between tetrahedra; built-in and compiled joint laws.
//! 3. [`fracture`] — joints that break; user criteria; fragments.
//! 4. [`contact_detection`] — surface elements and candidate pairs by NBS; the pair remap.
//! 5. [`contact_interaction`] — potential contact forces with Coulomb friction; pair history.
//! 6. [`loads`] — gravity, nodal forces, tractions, prescribed velocities.
//! 7. [`integration`] — central difference, reactions, energy sums.
//!
//! Below them: [`math`], [`params`] (how laws declare parameters), [`mesh`] (tet4 meshes,
//! generators, regions, Gmsh), [`material`] (elastic laws), [`state`] (nodes, tets, bodies)
//! and [`compiled`] (Rhai laws compiled to native code). Above them: [`pipeline`] (the
//! [`Simulation`], the step, timers, energy), [`io`] (ParaView and CSV output), [`script`]
//! (the Rhai layer) and [`cli`]. Imports go one way only, in this order (tests/layering.rs).

pub mod cli;
pub mod compiled;
pub mod contact_detection;
pub mod contact_interaction;
pub mod elements;
pub mod fracture;
pub mod integration;
pub mod io;
pub mod joints;
pub mod limits;
pub mod loads;
pub mod material;
pub mod math;
pub mod mesh;
pub mod parallel;
pub mod params;
pub mod pipeline;
pub mod script;
pub mod state;

pub use pipeline::{Simulation, Stage};
pub use state::Layout;
