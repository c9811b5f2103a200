//! GFS-VO inter-process plumbing over iceoryx2 (work in progress).
#![warn(missing_docs)]
