//! hand-eye
