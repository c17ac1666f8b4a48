//! # fdem — the combined finite–discrete element method, driven by Rhai model scripts
//!
//! Bodies are deformable discrete elements meshed into constant-strain tetrahedra. Time runs
//! explicitly with the central difference method. One time step is Munjiza's seven stages, and
//! the module list reads as the step ([`pipeline::Simulation::step`]):
//!
//! 1. [`elements`] — stress in every tetrahedron from its deformation; nodal internal forces.
//! 2. joints — joint forces between tetrahedra.
//! 3. fracture — joints that break; fragments.
//! 4. contact detection — NBS search.
//! 5. contact interaction — potential contact forces with Coulomb friction.
//! 6. [`loads`] — gravity, nodal forces, tractions, prescribed velocities.
//! 7. [`integration`] — central difference, lumped mass, stable time step.
//!
//! Around them: [`mesh`] (tet4 meshes, generators, regions), [`material`] (elastic laws),
//! [`pipeline`] (the state, the step, timers, energy), [`script`] (the Rhai layer),
//! [`io`] (ParaView and CSV output) and [`cli`].

pub mod cli;
pub mod compiled;
pub mod contact_detection;
pub mod contact_interaction;
pub mod elements;
pub mod fracture;
pub mod integration;
pub mod io;
pub mod joints;
pub mod loads;
pub mod material;
pub mod math;
pub mod mesh;
pub mod params;
pub mod pipeline;
pub mod script;
pub mod state;

pub use pipeline::{Simulation, Stage};
pub use state::Layout;
