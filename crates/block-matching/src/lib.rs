//! block-matching
