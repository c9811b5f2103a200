//! gfs-planes (in progress).
