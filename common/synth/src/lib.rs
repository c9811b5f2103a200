//! gfs-synth (in progress).
