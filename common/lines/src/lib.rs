//! Line features of GFS-VO (being written): EDLines detection, ELSED-style joining, LBD
//! descriptors and matching, the grid index, the paper's homogenisation schemes and 3D
//! lines from depth.
#![warn(missing_docs)]

pub mod detect;
pub mod extractor;
pub mod grid;
pub mod homogenise;
pub mod join;
pub mod lbd;
pub mod lines3d;
pub mod matching;
mod segment;

pub use segment::{DetectedLine, Segment};

pub use extractor::{LineConfig, LineExtractor, LineFeatures};
pub use lbd::LbdDescriptor;
pub use lines3d::Line3;

#[cfg(test)]
mod fixtures;
pub use {
    detect::{DetectConfig, DetectConfigError, LineDetector},
    join::JoinConfig,
};
