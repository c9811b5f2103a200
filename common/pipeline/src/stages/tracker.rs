//! `tracker`: joins the points, lines and Manhattan axes of each frame (and its planes
//! and depth grid when `[tracking] use_planes` / `use_depth_alignment`), tracks it
//! (the tracking half of the odometry), asks the mapper for keyframes (and, when lost, to
//! relocalise the frame in the whole map) and publishes the pose. Lockstep: the pose of
//! a frame that asked is published after the mapper answered, as the in-process
//! odometry does, so both give the same trajectory; in realtime a relocalisation's
//! answer comes frames later and tracking goes on from the frame it found. On a loaded
//! map (`--load-map`) it starts on the map's neighbourhood as the inline odometry does,
//! unless its checkpoint says where it was. A reset on the `control` topic starts a new
//! map at the next frame that can be; a pose hint there, while localising, places the
//! next frame in the loaded map near it.

use super::context::{POLL, StageContext, StageError, mark_ready};
use super::imu::ImuInbox;
use super::join::{FrameJoin, Joined, Part};
use super::mapper::saved_maps;
use crate::control::{Control, ControlLedger, ControlMessage};
use crate::state::StateDir;
use crate::wire::{
    WireImuSample, WireKeyPoint, WireLine, WireManhattan, WirePose, WireTrackedFeature,
};
use gfs_ipc::{
    MAX_VARIABLE_MESSAGE_BYTES, Mode, MsgHeader, Service, Stage, TopicPublisher, TopicSubscriber,
    decode_message, encode_message, topics,
};
use gfs_odometry::session::{
    LoadedMapUse, MapRequest, MapUpdate, ResetError, TrackingCheckpoint, TrackingSession,
};
use gfs_odometry::{FrameSurfaces, TrackingStatus};
use nalgebra::Isometry3;
use std::time::Instant;

/// The checkpoint: motion model, reference keyframe, counters ([`TrackingCheckpoint`]).
const CHECKPOINT: &str = "tracker.bin";
/// The last control request applied ([`ControlLedger`]).
const CONTROL_LEDGER: &str = "tracker-control.bin";

/// The tracker's ports.
struct Ports<S: Service> {
    points: TopicSubscriber<S, WireKeyPoint>,
    lines: TopicSubscriber<S, WireLine>,
    manhattan: TopicSubscriber<S, WireManhattan>,
    /// The planes and depth grid, subscribed only when the tracker uses them.
    surfaces: Option<TopicSubscriber<S, u8>>,
    /// The IMU samples before each frame (nothing comes from an input without IMU).
    imu: TopicSubscriber<S, WireImuSample>,
    maps: TopicSubscriber<S, u8>,
    poses: TopicPublisher<S, WirePose>,
    /// The frame's matches for viewers, sent only while one subscribes.
    tracked: TopicPublisher<S, WireTrackedFeature>,
    keyframes: TopicPublisher<S, u8>,
    control: TopicSubscriber<S, u8>,
}

/// The map answering a keyframe request: the mapper's header (its stamps).
type MapAnswer = MsgHeader;

/// A keyframe request sent and not answered yet.
struct Outstanding {
    header: MsgHeader,
    bytes: Vec<u8>,
    sent: Instant,
}

/// Runs the tracker until told to stop.
///
/// # Errors
/// [`StageError`] when the config is invalid, a checkpoint unreadable or a topic fails.
pub fn run<S: Service>(ctx: &StageContext<S>) -> Result<(), StageError> {
    let camera = ctx.config().camera()?.pinhole;
    let (scale, levels) = ctx.pyramid()?;
    let config = ctx.config();
    let mut session =
        TrackingSession::new(config.odometry(), camera, scale, levels, &config.lines.grid);
    let state = ctx.state();
    let mut next_frame = resume(&state, &mut session)?;
    if next_frame == 0
        && let Some(saved) = ctx.settings.map_files.load(&ctx.config().map_camera()?)?
    {
        session.start_on_saved(saved, &ctx.settings.map_files.use_());
    }
    let surfaces_expected = config.tracking.use_planes || config.tracking.use_depth_alignment;
    let ports = Ports {
        points: ctx.subscribe(topics::POINTS)?,
        lines: ctx.subscribe(topics::LINES)?,
        manhattan: ctx.subscribe(topics::MANHATTAN)?,
        surfaces: if surfaces_expected {
            Some(ctx.subscribe(topics::SURFACES)?)
        } else {
            None
        },
        imu: ctx.subscribe(topics::IMU)?,
        maps: ctx.subscribe(topics::LOCAL_MAP)?,
        poses: ctx.publish(topics::POSE, 1)?,
        tracked: ctx.publish(topics::TRACKED, 2048)?,
        keyframes: ctx.publish(topics::KEYFRAME, 1 << 20)?,
        control: ctx.subscribe(topics::CONTROL)?,
    };
    let mut ledger = ControlLedger::open(&state, CONTROL_LEDGER)?;
    let mut reset: Option<ControlMessage> = None;
    let mut join = FrameJoin::new(surfaces_expected);
    let mut imu = ImuInbox::default();
    let mut outstanding: Option<Outstanding> = None;
    let mut scratch = Vec::new();
    let mut tracked = Vec::new();
    while !ctx.stopping() {
        if take_maps(&ports.maps, &mut session)?.is_some() {
            outstanding = None;
        }
        receive_features(&ports, &mut join, next_frame)?;
        // After the features: a frame's batch is sent before the frame, so every
        // feature received has its batch in by now.
        imu.receive(&ports.imu, next_frame)?;
        let joined = match ctx.mode() {
            Mode::Lockstep => join.next_in_order(ctx.feature_deadline()),
            Mode::Realtime => join.next_newest(ctx.feature_deadline()),
        };
        let Some(Joined {
            mut header,
            features,
            incomplete,
        }) = joined
        else {
            ports.poses.update_connections()?;
            ports.tracked.update_connections()?;
            ports.keyframes.update_connections()?;
            resend_if_stale(ctx, &ports.keyframes, &mut outstanding)?;
            match join.waiting_for() {
                Part::Points => ports.points.wait(POLL)?,
                Part::Lines => ports.lines.wait(POLL)?,
                Part::Manhattan => ports.manhattan.wait(POLL)?,
                Part::Surfaces => match &ports.surfaces {
                    Some(surfaces) => surfaces.wait(POLL)?,
                    None => ports.points.wait(POLL)?,
                },
            };
            continue;
        };
        take_controls(&ports.control, &ledger, &mut reset)?;
        if let Some(message) = reset
            && apply_control(ctx, &mut session, &message, header.frame_id)?
        {
            ledger.applied(&state, &message, &mut scratch)?;
            reset = None;
        }
        mark_ready(&mut header, Stage::Tracker, 0);
        header.mark_started(Stage::Tracker);
        let (id, timestamp) = (features.id, features.timestamp);
        let imu_samples = imu.push_through(id.0, &mut session);
        let (mut pose, request, covariance) = if features.is_blank() {
            (session.skip(id, timestamp), None, None)
        } else if let Err(e) = features.check() {
            tracing::warn!("tracker: inconsistent features: {e}; the pose is predicted");
            (session.skip(id, timestamp), None, None)
        } else {
            match session.process(features) {
                Ok(out) => {
                    let request = (out.keyframe.map(MapRequest::KeyFrame))
                        .or(out.relocalisation.map(MapRequest::Relocalise));
                    (out.pose, request, out.covariance)
                }
                Err(e) => {
                    tracing::warn!("tracker: {e}; the pose is predicted");
                    (session.skip(id, timestamp), None, None)
                }
            }
        };
        if incomplete && pose.status == TrackingStatus::Tracked {
            pose.status = TrackingStatus::Degraded;
        }
        let keyframe = matches!(request, Some(MapRequest::KeyFrame(_)));
        let new_map = matches!(&request, Some(MapRequest::KeyFrame(k)) if k.reset);
        if let Some(request) = request {
            let mut bytes = Vec::new();
            if let Err(e) = encode_message(&request, &mut bytes) {
                tracing::error!(frame = %id, "tracker: cannot encode the request: {e}");
            } else {
                ports.keyframes.publish_slice(&header, &bytes)?;
                ctx.requested(id.0);
                outstanding = Some(Outstanding {
                    header,
                    bytes,
                    sent: Instant::now(),
                });
            }
            if ctx.mode() == Mode::Lockstep || session.needs_map() {
                let Some(mapper) = await_map(ctx, &ports, &mut session, &mut outstanding)? else {
                    return Ok(());
                };
                header.merge_stamps(&mapper);
            }
        }
        // Lockstep: this frame, found in the whole map; realtime: an earlier one, whose
        // pose went out already.
        if let Some(found) = session.take_relocalised().filter(|p| p.id == id) {
            pose = found;
        }
        header.mark_finished(Stage::Tracker);
        let predicted = session.predicted_quaternion();
        let mut wire = WirePose::new(&pose, predicted.as_ref(), keyframe)
            .with_covariance(covariance.as_ref())
            .with_map_from_odom(session.map_from_odom())
            .with_anchor(session.anchor(&pose).as_ref())
            .with_imu_samples(imu_samples);
        if new_map {
            wire = wire.starting_new_map();
        }
        ports.poses.publish_slice(&header, &[wire])?;
        if ports.tracked.subscriber_count() > 0
            && let Some(matches) = session.last_matches()
        {
            WireTrackedFeature::fill(&matches, &mut tracked);
            ports.tracked.publish_slice(&header, &tracked)?;
        }
        ctx.made(id.0);
        state.write(CHECKPOINT, &session.checkpoint(), &mut scratch)?;
        next_frame = id.0 + 1;
        join.drop_before(next_frame);
    }
    Ok(())
}

/// Keeps the newest control request not applied yet in `reset`.
fn take_controls<S: Service>(
    control: &TopicSubscriber<S, u8>,
    ledger: &ControlLedger,
    reset: &mut Option<ControlMessage>,
) -> Result<(), StageError> {
    while let Some((_, message)) =
        control.receive_decoded::<ControlMessage>(MAX_VARIABLE_MESSAGE_BYTES)?
    {
        if ledger.is_new(&message) && reset.is_none_or(|r| r.seq < message.seq) {
            *reset = Some(message);
        }
    }
    Ok(())
}

/// Does what `message` asks before frame `frame`; false when it must wait for the
/// answer to a map request.
///
/// # Errors
/// [`StageError`] when the map camera cannot be made from the config.
fn apply_control<S: Service>(
    ctx: &StageContext<S>,
    session: &mut TrackingSession,
    message: &ControlMessage,
    frame: u64,
) -> Result<bool, StageError> {
    let pose = match message.control {
        Control::Reset => None,
        Control::ResetToPose(pose) => Some(pose),
        Control::RelocaliseNear(pose) => return relocalise_near(ctx, session, &pose, frame),
    };
    Ok(match session.start_new_map(pose) {
        Ok(()) => {
            tracing::info!(frame, ?message.control, "tracker: reset: a new map starts");
            true
        }
        Err(ResetError::RequestPending) => false,
        Err(e) => {
            tracing::warn!(frame, "tracker: reset refused: {e}");
            true
        }
    })
}

/// Localising (`--load-map --localize`): places the tracker in the loaded map near
/// `world_from_camera` as `--initial-pose` does at the start (the map is fixed, so the
/// file is the map the mapper holds); false while a map request is pending, whose
/// answer would replace the map placed here. Not localising, the hint is refused with
/// a warning: there is no other map to be placed in.
///
/// # Errors
/// [`StageError`] when the map camera cannot be made from the config.
fn relocalise_near<S: Service>(
    ctx: &StageContext<S>,
    session: &mut TrackingSession,
    world_from_camera: &Isometry3<f64>,
    frame: u64,
) -> Result<bool, StageError> {
    let files = &ctx.settings.map_files;
    if !files.localize {
        tracing::warn!(frame, "tracker: a pose hint while not localising; ignored");
        return Ok(true);
    }
    if session.pending_request().is_some() {
        return Ok(false);
    }
    match files.load(&ctx.config().map_camera()?) {
        Ok(Some(saved)) => {
            let use_ = LoadedMapUse {
                localise: true,
                initial_pose: Some(*world_from_camera),
            };
            session.start_on_saved(saved, &use_);
            tracing::info!(frame, "tracker: relocalising near the pose hint");
        }
        Ok(None) => tracing::warn!(frame, "tracker: a pose hint without a map; ignored"),
        Err(e) => tracing::warn!(frame, "tracker: pose hint ignored: {e}"),
    }
    Ok(true)
}

/// Restores a killed tracker's state; returns the next frame to track.
fn resume(state: &StateDir, session: &mut TrackingSession) -> Result<u64, StageError> {
    let Some(checkpoint) = state.read::<TrackingCheckpoint>(CHECKPOINT)? else {
        return Ok(0);
    };
    if let Some(Err(e)) = checkpoint.last.as_ref().map(|l| l.check()) {
        tracing::warn!("tracker: {CHECKPOINT} is inconsistent ({e}); starting afresh");
        return Ok(0);
    }
    let mut maps = saved_maps(state).unwrap_or_else(|e| {
        tracing::warn!("tracker: {e}; starting a new map");
        Vec::new()
    });
    // The map it tracked against, else the newest.
    let map = maps
        .iter()
        .position(|m| m.seq == checkpoint.requests.map_seq())
        .or((!maps.is_empty()).then_some(0))
        .map(|i| maps.swap_remove(i));
    let next = checkpoint.last.as_ref().map_or(0, |l| l.features.id.0 + 1);
    tracing::info!(frame = next, "tracker: resuming from its checkpoint");
    session.restore(checkpoint, map);
    Ok(next)
}

fn receive_features<S: Service>(
    ports: &Ports<S>,
    join: &mut FrameJoin,
    next_frame: u64,
) -> Result<(), StageError> {
    while let Some(s) = ports.points.receive()? {
        if s.user_header().frame_id >= next_frame {
            join.add_points(s.user_header(), s.payload());
        }
    }
    while let Some(s) = ports.lines.receive()? {
        if s.user_header().frame_id >= next_frame {
            join.add_lines(s.user_header(), s.payload());
        }
    }
    while let Some(s) = ports.manhattan.receive()? {
        if s.user_header().frame_id >= next_frame {
            join.add_manhattan(s.user_header(), s.payload());
        }
    }
    if let Some(surfaces) = &ports.surfaces {
        while let Some(s) = surfaces.receive()? {
            let id = s.user_header().frame_id;
            if id >= next_frame {
                let decoded =
                    decode_message::<FrameSurfaces>(s.payload(), MAX_VARIABLE_MESSAGE_BYTES)
                        .unwrap_or_else(|e| {
                            if !s.payload().is_empty() {
                                tracing::warn!(frame = id, "tracker: bad surfaces message: {e}");
                            }
                            FrameSurfaces::default()
                        });
                join.add_surfaces(s.user_header(), decoded);
            }
        }
    }
    Ok(())
}

/// Applies every map received; returns the header of the one that answered the pending
/// request, if it came.
fn take_maps<S: Service>(
    maps: &TopicSubscriber<S, u8>,
    session: &mut TrackingSession,
) -> Result<Option<MapAnswer>, StageError> {
    let mut answer = None;
    while let Some((header, update)) =
        maps.receive_decoded::<MapUpdate>(MAX_VARIABLE_MESSAGE_BYTES)?
    {
        if let Err(e) = update.check() {
            tracing::warn!("tracker: dropping an inconsistent map: {e}");
            continue;
        }
        if session.apply(update) {
            answer = Some(header);
        }
    }
    Ok(answer)
}

/// Waits for the map answering the pending request, sending the request again when the
/// mapper seems to have lost it. `None` when told to stop.
fn await_map<S: Service>(
    ctx: &StageContext<S>,
    ports: &Ports<S>,
    session: &mut TrackingSession,
    outstanding: &mut Option<Outstanding>,
) -> Result<Option<MapAnswer>, StageError> {
    loop {
        if let Some(answer) = take_maps(&ports.maps, session)? {
            *outstanding = None;
            return Ok(Some(answer));
        }
        if session.pending_request().is_none() || ctx.stopping() {
            return Ok(None);
        }
        ports.keyframes.update_connections()?;
        resend_if_stale(ctx, &ports.keyframes, outstanding)?;
        ports.maps.wait(POLL)?;
    }
}

fn resend_if_stale<S: Service>(
    ctx: &StageContext<S>,
    keyframes: &TopicPublisher<S, u8>,
    outstanding: &mut Option<Outstanding>,
) -> Result<(), StageError> {
    if let Some(o) = outstanding
        .as_mut()
        .filter(|o| o.sent.elapsed() > ctx.resend_after())
    {
        tracing::warn!(
            frame = o.header.frame_id,
            "tracker: no map yet; sending the keyframe again"
        );
        keyframes.publish_slice(&o.header, &o.bytes)?;
        o.sent = Instant::now();
    }
    Ok(())
}
