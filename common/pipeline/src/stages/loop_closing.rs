//! `loop`: loop closing apart from the mapper. It searches the map of every keyframe
//! the mapper sends for a loop (place recognition, verification, pose graph) and answers
//! each with a verdict, the loop's correction or none; the mapper applies corrections
//! between keyframes. Its place index is rebuilt from the maps it receives, so a
//! restarted loop stage needs only the last request searched and the keyframe of the
//! last loop (its checkpoint). Each map is searched once: searching one twice (sent
//! again by a restarted mapper, or from the topic's history) would count its candidates
//! twice towards consistency; a map sent again gets the verdict it had.

use super::context::{POLL, StageContext, StageError};
use gfs_core::ids::KeyFrameId;
use gfs_ipc::{
    MAX_VARIABLE_MESSAGE_BYTES, Mode, MsgHeader, Service, Stage, TopicSubscriber, encode_message,
    topics,
};
use gfs_odometry::loop_closing::LoopCloser;
use gfs_odometry::session::{LoopVerdict, MapUpdate};
use gfs_odometry::tracking::matching::ScalePyramid;
use serde::{Deserialize, Serialize};

/// The checkpoint ([`Searched`]).
const CHECKPOINT: &str = "loop.bin";

/// How far the loop stage got.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize)]
struct Searched {
    /// The last request whose map was searched.
    seq: u64,
    /// The keyframe of the last loop found.
    last_loop: Option<KeyFrameId>,
}

/// Runs the loop stage until told to stop. With loop closing off it idles (the mapper
/// then sends it nothing).
///
/// # Errors
/// [`StageError`] when the config is invalid, the checkpoint unreadable or a topic
/// fails.
pub fn run<S: Service>(ctx: &StageContext<S>) -> Result<(), StageError> {
    let camera = ctx.config().camera()?.pinhole;
    let (scale, levels) = ctx.pyramid()?;
    let config = ctx.config().odometry();
    let state = ctx.state();
    let mut closer = LoopCloser::new(&config, camera, ScalePyramid::new(scale, levels));
    let mut searched = state.read::<Searched>(CHECKPOINT)?.unwrap_or_default();
    closer.resume(searched.last_loop);
    // The last verdict sent, sent again when its map comes again.
    let mut last_verdict: Option<(u64, Vec<u8>)> = None;
    let verdicts = ctx.publish::<u8>(topics::LOOP_VERDICT, 1 << 16)?;
    let maps = ctx.subscribe::<u8>(topics::KEYFRAME_MAP)?;
    let (mut bytes, mut scratch) = (Vec::new(), Vec::new());
    while !ctx.stopping() {
        let Some((mut header, update)) = next_map(ctx, &maps)? else {
            verdicts.update_connections()?;
            maps.wait(POLL * 25)?;
            continue;
        };
        if let Err(e) = update.check() {
            tracing::warn!("loop: dropping an inconsistent map: {e}");
            continue;
        }
        if update.seq <= searched.seq {
            if let Some((seq, verdict)) = &last_verdict
                && *seq == update.seq
            {
                verdicts.publish_slice(&header, verdict)?;
            }
            continue;
        }
        header.mark_received(Stage::Loop);
        header.mark_started(Stage::Loop);
        let mut map = update.map;
        // The layout the mapper searched inline, so that both find the same loops.
        map.canonicalise();
        let correction = update
            .keyframe
            .and_then(|kf| closer.after_keyframe(&map, kf));
        let verdict = LoopVerdict {
            seq: update.seq,
            correction,
        };
        if let Err(e) = encode_message(&verdict, &mut bytes) {
            tracing::error!(
                frame = header.frame_id,
                "loop: cannot encode the verdict: {e}"
            );
            continue;
        }
        header.mark_finished(Stage::Loop);
        verdicts.publish_slice(&header, &bytes)?;
        ctx.made(header.frame_id);
        searched = Searched {
            seq: update.seq,
            last_loop: closer.last_loop(),
        };
        state.write(CHECKPOINT, &searched, &mut scratch)?;
        last_verdict = Some((update.seq, bytes.clone()));
    }
    Ok(())
}

/// The next map to search: the oldest in lockstep (every keyframe, as inline), the
/// newest in realtime (a loop stage behind skips keyframes rather than lag).
fn next_map<S: Service>(
    ctx: &StageContext<S>,
    maps: &TopicSubscriber<S, u8>,
) -> Result<Option<(MsgHeader, MapUpdate)>, StageError> {
    let mut next = maps.receive_decoded::<MapUpdate>(MAX_VARIABLE_MESSAGE_BYTES)?;
    if ctx.mode() == Mode::Realtime {
        while let Some(newer) = maps.receive_decoded::<MapUpdate>(MAX_VARIABLE_MESSAGE_BYTES)? {
            next = Some(newer);
        }
    }
    Ok(next)
}
