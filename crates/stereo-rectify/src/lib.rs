//! stereo-rectify
