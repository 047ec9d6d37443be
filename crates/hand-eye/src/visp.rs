//! ViSP formats.
