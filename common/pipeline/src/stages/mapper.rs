//! `mapper`: owns the global map; turns each keyframe request into a keyframe with local
//! mapping (landmarks, fusion, local BA, culling) and answers with the tracker's
//! neighbourhood of it (`MappingSession::update`), which a restarted tracker resumes
//! from; a relocalisation request (the tracker is lost) is answered with the
//! neighbourhood of the keyframe the whole map found the frame against, and the frame's
//! pose. Its own checkpoint is the whole map (`MappingSession::checkpoint`). With loop
//! closing on, the whole map of each keyframe also goes to the loop stage, and the
//! loop corrections it sends back are applied between keyframes; in lockstep the
//! mapper waits for the verdict on each keyframe before answering (up to the feature
//! deadline, so that a dead loop stage cannot hang the run), as the inline odometry
//! closes loops before answering. On a loaded map (`--load-map`) it starts from the
//! file unless it has a checkpoint; it writes `--save-map` when it stops, and any file
//! a [`SaveMapRequest`] names when one comes.

use super::context::{POLL, StageContext, StageError};
use crate::map_files::{SaveMapReply, SaveMapRequest, write_map};
use crate::state::{StateDir, StateError};
use gfs_ipc::{
    MAX_VARIABLE_MESSAGE_BYTES, Mode, MsgHeader, Service, Stage, TopicPublisher, TopicSubscriber,
    encode_message, topics,
};
use gfs_odometry::map::Map;
use gfs_odometry::map_file::MapCamera;
use gfs_odometry::session::{LoopVerdict, MapRequest, MapUpdate, MappingSession};
use std::time::{Duration, Instant};

/// The tracker's checkpoints: the last two maps sent to it (bincode [`MapUpdate`]s of
/// its neighbourhood), by the parity of the request they answer, so that a restarted
/// tracker finds the one it tracked against even when the mapper answered its last
/// request after it died.
pub const MAP_CHECKPOINTS: [&str; 2] = ["map.0.bin", "map.1.bin"];

/// The mapper's checkpoint: the whole map after the last request applied (bincode
/// [`MapUpdate`]).
pub const GLOBAL_MAP_CHECKPOINT: &str = "global_map.bin";

/// The tracker's maps in the checkpoints, newest first.
///
/// # Errors
/// [`StateError`] when a checkpoint exists but cannot be read.
pub fn saved_maps(state: &StateDir) -> Result<Vec<MapUpdate>, StateError> {
    let mut maps = Vec::new();
    for name in MAP_CHECKPOINTS {
        match state.read::<MapUpdate>(name)? {
            Some(map) if map.check().is_ok() => maps.push(map),
            Some(map) => tracing::warn!("{name}: {}", map.check().unwrap_err()),
            None => {}
        }
    }
    maps.sort_by_key(|m| std::cmp::Reverse(m.seq));
    Ok(maps)
}

/// The mapper's map as it last saved it (every keyframe and the retired ones, with
/// their loop corrections): what the final trajectory of a pipeline run is taken from.
///
/// # Errors
/// [`StateError`] when a checkpoint exists but cannot be read.
pub fn last_saved_map(state: &StateDir) -> Result<Option<Map>, StateError> {
    Ok(state
        .read::<MapUpdate>(GLOBAL_MAP_CHECKPOINT)?
        .map(|update| update.map))
}

/// A map message is sized for this many bytes at first (grows as needed).
const TYPICAL_MAP_BYTES: usize = 4 << 20;

/// Runs the mapper until told to stop.
///
/// # Errors
/// [`StageError`] when the config is invalid, the checkpoint unreadable or a topic
/// fails.
pub fn run<S: Service>(ctx: &StageContext<S>) -> Result<(), StageError> {
    let camera = ctx.config().camera()?.pinhole;
    let (scale, levels) = ctx.pyramid()?;
    let config = ctx.config().odometry();
    let loop_stage = config.loop_closing.enabled;
    let mut session = if loop_stage {
        MappingSession::with_loop_stage(&config, camera, scale, levels)
    } else {
        MappingSession::new(&config, camera, scale, levels)
    };
    let state = ctx.state();
    let files = &ctx.settings.map_files;
    let map_camera = ctx.config().map_camera()?;
    match state.read::<MapUpdate>(GLOBAL_MAP_CHECKPOINT)? {
        Some(update) if update.check().is_ok() => {
            tracing::info!(request = update.seq, "mapper: resuming from the global map");
            session.restore(update);
            if files.localize {
                session.hold_fixed();
            }
        }
        checkpoint => {
            if let Some(update) = checkpoint {
                tracing::warn!(
                    "{GLOBAL_MAP_CHECKPOINT}: {}; starting afresh",
                    update.check().unwrap_err()
                );
            }
            if let Some(saved) = files.load(&map_camera)? {
                session.start_from(saved, files.localize);
            }
        }
    }
    let loops = if loop_stage {
        Some(LoopPorts {
            maps: ctx.publish(topics::KEYFRAME_MAP, TYPICAL_MAP_BYTES)?,
            verdicts: ctx.subscribe(topics::LOOP_VERDICT)?,
        })
    } else {
        None
    };
    let requests = ctx.subscribe::<u8>(topics::KEYFRAME)?;
    let publisher = ctx.publish::<u8>(topics::LOCAL_MAP, TYPICAL_MAP_BYTES)?;
    let saves = SavePorts {
        requests: ctx.subscribe(topics::SAVE_MAP)?,
        replies: ctx.publish(topics::MAP_SAVED, 256)?,
    };
    // The tracker's map and the whole map, encoded.
    let (mut bytes, mut global) = (Vec::new(), Vec::new());
    let budget = (ctx.mode() == Mode::Realtime)
        .then(|| Duration::from_millis(ctx.config().pipeline.realtime_ba_budget_ms));
    // Realtime: yield to the next keyframe (ORB-SLAM2's abort flag) or to the budget.
    let next_keyframe_waits = || requests.port().has_samples().unwrap_or(false);
    while !ctx.stopping() {
        if let Some(loops) = &loops {
            loops.take(&mut session, None)?;
        }
        saves.answer(&session, &map_camera)?;
        let Some((mut header, request)) =
            requests.receive_decoded::<MapRequest>(MAX_VARIABLE_MESSAGE_BYTES)?
        else {
            publisher.update_connections()?;
            saves.replies.update_connections()?;
            if let Some(loops) = &loops {
                loops.maps.update_connections()?;
            }
            requests.wait(POLL * 25)?;
            continue;
        };
        if let Err(e) = request.check() {
            tracing::warn!("mapper: dropping an inconsistent request: {e}");
            continue;
        }
        header.mark_received(Stage::Mapper);
        header.mark_started(Stage::Mapper);
        let started = Instant::now();
        let applied_before = session.last_applied();
        let is_keyframe = matches!(request, MapRequest::KeyFrame(_));
        let update = match (request, budget) {
            (MapRequest::Relocalise(request), _) => session.relocalise(&request),
            (MapRequest::KeyFrame(request), Some(budget)) => session.insert_until(request, &|| {
                started.elapsed() >= budget || next_keyframe_waits()
            }),
            (MapRequest::KeyFrame(request), None) => session.insert(request),
        };
        if let Err(e) = encode_message(&update, &mut bytes) {
            tracing::error!(
                frame = header.frame_id,
                "mapper: cannot encode the tracker's map: {e}"
            );
            continue;
        }
        let mut whole = encode_whole(&session, &mut global, header.frame_id);
        header.mark_finished(Stage::Mapper);
        if let Some(loops) = &loops
            && is_keyframe
            && whole
            && session.last_applied() > applied_before
        {
            loops.maps.publish_slice(&header, &global)?;
            if ctx.mode() == Mode::Lockstep
                && loops.await_verdict(ctx, &mut session, &mut header)?
            {
                if let Err(e) = encode_message(&session.update(), &mut bytes) {
                    tracing::error!(
                        frame = header.frame_id,
                        "mapper: cannot encode the corrected map: {e}"
                    );
                    continue;
                }
                whole = encode_whole(&session, &mut global, header.frame_id);
            }
        }
        publisher.publish_slice(&header, &bytes)?;
        ctx.made(header.frame_id);
        if whole {
            state.write_bytes(GLOBAL_MAP_CHECKPOINT, &global)?;
        }
        let name = MAP_CHECKPOINTS[(session.last_applied() % 2) as usize];
        state.write_bytes(name, &bytes)?;
    }
    if let Some(path) = &files.save_map
        && let Err(e) = write_map(path, &map_camera, session.map(), session.manhattan())
    {
        tracing::error!("mapper: {e}");
    }
    Ok(())
}

/// The mapper's ports for requests to save the map now.
struct SavePorts<S: Service> {
    requests: TopicSubscriber<S, u8>,
    replies: TopicPublisher<S, u8>,
}

impl<S: Service> SavePorts<S> {
    /// Writes the global map for every request received and answers each.
    fn answer(&self, session: &MappingSession, camera: &MapCamera) -> Result<(), StageError> {
        let mut bytes = Vec::new();
        while let Some((header, request)) = self
            .requests
            .receive_decoded::<SaveMapRequest>(MAX_VARIABLE_MESSAGE_BYTES)?
        {
            let result = write_map(&request.path, camera, session.map(), session.manhattan())
                .map_err(|e| {
                    tracing::error!("mapper: {e}");
                    e.to_string()
                });
            let reply = SaveMapReply {
                id: request.id,
                path: request.path,
                result,
                keyframes: session.map().keyframe_count(),
            };
            match encode_message(&reply, &mut bytes) {
                Ok(_) => {
                    self.replies.publish_slice(&header, &bytes)?;
                }
                Err(e) => tracing::error!("mapper: cannot encode the save reply: {e}"),
            }
        }
        Ok(())
    }
}

/// Encodes the whole map (the checkpoint, the loop stage's message) into `bytes`;
/// false, logged, when it cannot (larger than a message may be: `[keyframes]
/// max_keyframes` keeps it below).
fn encode_whole(session: &MappingSession, bytes: &mut Vec<u8>, frame: u64) -> bool {
    match encode_message(&session.checkpoint(), bytes) {
        Ok(_) => true,
        Err(e) => {
            tracing::error!(frame, "mapper: cannot encode the whole map: {e}");
            false
        }
    }
}

/// The mapper's ports to the loop stage.
struct LoopPorts<S: Service> {
    maps: TopicPublisher<S, u8>,
    verdicts: TopicSubscriber<S, u8>,
}

impl<S: Service> LoopPorts<S> {
    /// Applies the corrections of the verdicts received. Returns the header of the
    /// verdict on request `wanted` when it came, and whether a correction was applied.
    fn take(
        &self,
        session: &mut MappingSession,
        wanted: Option<u64>,
    ) -> Result<(Option<MsgHeader>, bool), StageError> {
        let (mut answer, mut corrected) = (None, false);
        while let Some((header, verdict)) = self
            .verdicts
            .receive_decoded::<LoopVerdict>(MAX_VARIABLE_MESSAGE_BYTES)?
        {
            if let Some(correction) = &verdict.correction {
                corrected |= session.apply(correction);
            }
            if Some(verdict.seq) == wanted {
                answer = Some(header);
            }
        }
        Ok((answer, corrected))
    }

    /// Lockstep: waits for the loop stage's verdict on the request just applied, up to
    /// the feature deadline, and takes the loop stage's stamps into `header`. Returns
    /// true when a correction was applied (the map must be encoded again).
    fn await_verdict(
        &self,
        ctx: &StageContext<S>,
        session: &mut MappingSession,
        header: &mut MsgHeader,
    ) -> Result<bool, StageError> {
        let wanted = session.last_applied();
        let deadline = Instant::now() + ctx.feature_deadline();
        let mut corrected = false;
        loop {
            let (answer, applied) = self.take(session, Some(wanted))?;
            corrected |= applied;
            if let Some(answer) = answer {
                *header.stamp_mut(Stage::Loop) = answer.stamp(Stage::Loop);
                return Ok(corrected);
            }
            if ctx.stopping() {
                return Ok(corrected);
            }
            if Instant::now() >= deadline {
                tracing::warn!(
                    request = wanted,
                    "mapper: no loop verdict in time; going on without it"
                );
                return Ok(corrected);
            }
            // A restarted loop stage connects here and gets this map from the history.
            self.maps.update_connections()?;
            self.verdicts.wait(POLL)?;
        }
    }
}
