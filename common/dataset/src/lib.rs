//! gfs-dataset (in progress).

mod depth;

pub use depth::DepthConfig;
