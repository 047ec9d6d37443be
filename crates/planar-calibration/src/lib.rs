//! planar-calibration
