//! gfs-lines (in progress).
