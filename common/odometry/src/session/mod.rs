//! The odometry in two halves that talk by messages: [`TrackingSession`] tracks every
//! frame and asks for keyframes ([`KeyFrameRequest`]); [`MappingSession`] owns the map,
//! runs local mapping and answers with the map ([`MapUpdate`]). A lost tracker asks the
//! mapping half to find the frame in the whole map ([`RelocalisationRequest`]). The `tracker` and
//! `mapper` services each run one half; [`crate::Odometry`] runs both in one thread
//! with the same messages, so both paths give the same poses.

pub(crate) mod final_trajectory;
mod mapping;
mod messages;
pub(crate) mod messages_check;
pub(crate) mod odometry;
mod state;
#[cfg(test)]
mod tests;
mod tracking;

pub use mapping::MappingSession;
pub use messages::{
    KeyFrameRequest, LoopVerdict, MapRequest, MapUpdate, MapUpdateRef, RelocalisationRequest,
    Relocalised, TrackedAgainst,
};
pub use state::{MapReceipt, RequestLedger, TrackingState};
pub use tracking::{
    FramePose, LoadedMapUse, ResetError, TrackOutput, TrackingCheckpoint, TrackingSession,
};
