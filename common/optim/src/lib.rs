//! gfs-optim (in progress).
#![warn(missing_docs)]

pub mod residuals;
