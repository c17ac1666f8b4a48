//! Stage 4: contact detection.
