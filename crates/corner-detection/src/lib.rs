//! corner-detection
