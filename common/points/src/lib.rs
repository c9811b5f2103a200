//! gfs-points (in progress).
