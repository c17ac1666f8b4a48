//! Stage 5: contact interaction.

pub mod potential;
