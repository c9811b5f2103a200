//! `lines`: homogenised line segments with LBD descriptors and 3D lines of every frame.

use super::context::{POLL, StageContext, StageError, mark_ready};
use crate::wire::WireLine;
use gfs_ipc::{Service, Stage, frame_view, topics};
use gfs_lines::{LineExtractor, LineFeatures};

/// Lines a frame message is sized for at first (homogenisation keeps 30 to 150).
const TYPICAL_LINES: usize = 256;

/// Runs the lines stage until told to stop. With lines switched off (ablation) it
/// publishes empty line sets, so the stages after it run unchanged.
///
/// # Errors
/// [`StageError`] when the camera config is invalid or a topic fails.
pub fn run<S: Service>(ctx: &StageContext<S>) -> Result<(), StageError> {
    let camera = ctx.config().camera()?.pinhole;
    let use_lines = ctx.config().tracking.use_lines;
    let mut extractor = LineExtractor::new(ctx.config().lines.clone());
    let mut features = LineFeatures::default();
    let publisher = ctx.publish::<WireLine>(topics::LINES, TYPICAL_LINES)?;
    // Last: a frame subscriber tells the realtime source that this stage is ready.
    let frames = ctx.subscribe::<u8>(topics::FRAME)?;
    while !ctx.stopping() {
        let Some(sample) = ctx.next_frame(&frames, &publisher, POLL * 25)? else {
            continue;
        };
        let mut header = *sample.user_header();
        mark_ready(&mut header, Stage::Lines, 0);
        header.mark_started(Stage::Lines);
        features.clear();
        match frame_view(&sample) {
            Ok(frame) if use_lines => {
                extractor.extract(&frame.gray(), &frame.depth(), &camera, &mut features);
            }
            Ok(_) => {}
            Err(e) => tracing::warn!(frame = header.frame_id, "lines: bad frame: {e}"),
        }
        drop(sample);
        header.mark_finished(Stage::Lines);
        let mut out = publisher.loan(&header, features.len())?;
        let parts = features
            .lines
            .iter()
            .zip(&features.descriptors)
            .zip(&features.lines3d);
        for (slot, ((line, d), l3)) in out.payload_mut().iter_mut().zip(parts) {
            *slot = WireLine::new(line, d, l3);
        }
        publisher.send(out)?;
        ctx.made(header.frame_id);
    }
    Ok(())
}
