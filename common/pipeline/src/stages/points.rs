//! `points`: ORB keypoints with depth and descriptors of every frame.

use super::context::{POLL, StageContext, StageError, mark_ready};
use crate::wire::WireKeyPoint;
use gfs_ipc::{Service, Stage, frame_view, topics};
use gfs_points::{OrbExtractor, OrbFeatures};

/// Runs the points stage until told to stop.
///
/// # Errors
/// [`StageError`] when the ORB config is invalid or a topic fails.
pub fn run<S: Service>(ctx: &StageContext<S>) -> Result<(), StageError> {
    let config = &ctx.config().points;
    let mut orb = OrbExtractor::new(config.clone()).map_err(|e| StageError::Setup {
        stage: "points",
        message: e.to_string(),
    })?;
    let mut features = OrbFeatures::default();
    let publisher = ctx.publish::<WireKeyPoint>(topics::POINTS, config.features)?;
    // Last: a frame subscriber tells the realtime source that this stage is ready.
    let frames = ctx.subscribe::<u8>(topics::FRAME)?;
    while !ctx.stopping() {
        let Some(sample) = ctx.next_frame(&frames, &publisher, POLL * 25)? else {
            continue;
        };
        let mut header = *sample.user_header();
        mark_ready(&mut header, Stage::Points, 0);
        header.mark_started(Stage::Points);
        features.clear();
        match frame_view(&sample) {
            Ok(frame) => {
                if let Err(e) = orb.extract(frame.gray(), Some(frame.depth()), &mut features) {
                    tracing::warn!(frame = header.frame_id, "points: {e}; no keypoints");
                    features.clear();
                }
            }
            Err(e) => tracing::warn!(frame = header.frame_id, "points: bad frame: {e}"),
        }
        drop(sample);
        header.mark_finished(Stage::Points);
        let mut out = publisher.loan(&header, features.len())?;
        let zipped = features.keypoints.iter().zip(&features.descriptors);
        for (slot, (kp, d)) in out.payload_mut().iter_mut().zip(zipped) {
            *slot = WireKeyPoint::new(kp, d);
        }
        publisher.send(out)?;
        ctx.made(header.frame_id);
    }
    Ok(())
}
