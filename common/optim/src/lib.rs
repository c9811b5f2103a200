//! gfs-optim (in progress).
