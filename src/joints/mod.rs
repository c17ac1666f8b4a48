//! Stage 2 — joints: cohesive elements between the faces of neighbouring tetrahedra.
//!
//! (Work in progress for issue #3: the constitutive laws are here; insertion and the stage
//! kernel follow.)

pub mod law;
