//! `planes`: plane normals and the frame's Manhattan axes from its depth and its 3D
//! lines (from the `lines` stage), with the axes' identity kept by the tracker's
//! predicted rotation (from the last pose); and the frame's surfaces (BFS planes, depth
//! grid) for the tracker's plane and depth terms, with or without the axes.

use super::context::{POLL, StageContext, StageError, mark_ready};
use crate::wire::{WireLine, WireManhattan, WirePose};
use gfs_ipc::{Mode, Service, Stage, TopicSubscriber, encode_message, frame_view, topics};
use gfs_lines::Line3;
use gfs_odometry::{FrameSurfaces, StructureExtractor, SurfaceRequest};
use nalgebra::Rotation3;
use std::collections::BTreeMap;
use std::time::Instant;

/// The tracker's predicted rotation (`current_from_previous`) from the newest pose.
#[derive(Default)]
struct Prediction {
    frame: Option<u64>,
    rotation: Option<Rotation3<f64>>,
}

impl Prediction {
    /// Takes in the poses queued.
    fn take<S: Service>(&mut self, poses: &TopicSubscriber<S, WirePose>) -> Result<(), StageError> {
        while let Some(pose) = poses.receive()? {
            if let Some(p) = pose.payload().first() {
                self.frame = Some(p.frame_id);
                self.rotation = p.predicted_rotation();
            }
        }
        Ok(())
    }

    /// Lockstep: waits until the pose of frame `id - 1` is in, up to the feature
    /// deadline. It was published before frame `id`, but a restarted stage may see the
    /// frame before the pose topic's history.
    fn await_previous<S: Service>(
        &mut self,
        ctx: &StageContext<S>,
        poses: &TopicSubscriber<S, WirePose>,
        id: u64,
    ) -> Result<(), StageError> {
        if ctx.mode() != Mode::Lockstep || id == 0 {
            return Ok(());
        }
        let deadline = Instant::now() + ctx.feature_deadline();
        while self.frame.is_none_or(|f| f + 1 < id) && Instant::now() < deadline && !ctx.stopping()
        {
            poses.wait(POLL)?;
            self.take(poses)?;
        }
        if self.frame.is_none_or(|f| f + 1 < id) {
            // Said aloud: the axes then start from an older prediction, so the run is no
            // longer reproducible bit for bit.
            tracing::warn!(
                frame = id,
                "planes: the previous frame's pose missing at the deadline; \
                 predicting from an older one"
            );
        }
        Ok(())
    }
}

/// Frame `id`'s 3D lines and the time the `lines` stage published them, waited for up
/// to the feature deadline (none then: the axes come from the planes only). Later
/// frames' lines received meanwhile stay in `lines3d`.
fn take_lines<S: Service>(
    ctx: &StageContext<S>,
    lines: &TopicSubscriber<S, WireLine>,
    lines3d: &mut BTreeMap<u64, (u64, Vec<Line3>)>,
    id: u64,
) -> Result<(u64, Vec<Line3>), StageError> {
    let deadline = Instant::now() + ctx.feature_deadline();
    while !lines3d.contains_key(&id) && Instant::now() < deadline && !ctx.stopping() {
        while let Some(s) = lines.receive()? {
            let (frame, published) = (
                s.user_header().frame_id,
                s.user_header().stamp(Stage::Lines).finished_ns,
            );
            if frame >= id {
                let lines = s.payload().iter().map(WireLine::line3).collect();
                lines3d.insert(frame, (published, lines));
            }
        }
        if !lines3d.contains_key(&id) {
            lines.wait(POLL)?;
        }
    }
    let taken = lines3d.remove(&id).unwrap_or_else(|| {
        tracing::warn!(
            frame = id,
            "planes: no lines before the deadline; planes only"
        );
        (0, Vec::new())
    });
    lines3d.retain(|k, _| *k > id);
    Ok(taken)
}

/// Initial size of a surfaces message: the 80 x 60 depth grid of a VGA frame (115 kB)
/// and its planes; the publisher grows it for larger frames.
const SURFACES_INITIAL_BYTES: usize = 1 << 17;

/// The checkpoint: the last frame done and the axes the next one is labelled against.
const CHECKPOINT: &str = "planes.bin";

/// Runs the planes stage until told to stop. With the Manhattan axes switched off
/// (ablation) it publishes "no axes" for every frame, and still extracts the surfaces
/// when the planes or the depth alignment are on.
///
/// # Errors
/// [`StageError`] when the config is invalid or a topic fails.
pub fn run<S: Service>(ctx: &StageContext<S>) -> Result<(), StageError> {
    let camera = ctx.config().camera()?.pinhole;
    let tracking = &ctx.config().tracking;
    let use_manhattan = tracking.use_manhattan;
    // The planes and the depth grid go to the tracker only for the terms that use them.
    let (send_planes, send_depth) = (tracking.use_planes, tracking.use_depth_alignment);
    let mut structure =
        StructureExtractor::new(&ctx.config().planes).map_err(|e| StageError::Setup {
            stage: "planes",
            message: e.to_string(),
        })?;
    let lines = ctx.subscribe::<WireLine>(topics::LINES)?;
    let poses = ctx.subscribe::<WirePose>(topics::POSE)?;
    let publisher = ctx.publish::<WireManhattan>(topics::MANHATTAN, 1)?;
    let surfaces_publisher = if send_planes || send_depth {
        Some(ctx.publish::<u8>(topics::SURFACES, SURFACES_INITIAL_BYTES)?)
    } else {
        None
    };
    let mut surfaces = FrameSurfaces::default();
    let mut surface_bytes = Vec::new();
    // Last: a frame subscriber tells the realtime source that this stage is ready.
    let frames = ctx.subscribe::<u8>(topics::FRAME)?;
    let state = ctx.state();
    let mut scratch = Vec::new();
    // The last frame done and the axes history: a restarted stage labels the axes of
    // the next frame as the killed one would have, and skips frames it already did
    // (a restarted source publishes its last frame again).
    let mut done = None;
    if let Some((frame, previous)) = state.read::<(u64, Option<Rotation3<f64>>)>(CHECKPOINT)? {
        structure.restore_previous_axes(previous);
        done = Some(frame);
    }
    let mut predicted = Prediction::default();
    let mut lines3d: BTreeMap<u64, (u64, Vec<Line3>)> = BTreeMap::new();
    while !ctx.stopping() {
        predicted.take(&poses)?;
        let Some(sample) = ctx.next_frame(&frames, &publisher, POLL * 5)? else {
            // A tracker that subscribed after the last surfaces went out (started late
            // under load, or restarted) gets them now, not at the next frame: in
            // lockstep that frame waits for its pose, so it would wait for the
            // deadline and track without them.
            if let Some(surfaces) = &surfaces_publisher {
                surfaces.update_connections()?;
            }
            continue;
        };
        let mut header = *sample.user_header();
        let id = header.frame_id;
        if done.is_some_and(|d| id <= d) {
            continue;
        }
        structure.surfaces(false, false, &mut surfaces);
        // Only the axes need the lines and, in lockstep, the last pose.
        let (published, frame_lines) = if use_manhattan {
            predicted.await_previous(ctx, &poses, id)?;
            take_lines(ctx, &lines, &mut lines3d, id)?
        } else {
            (0, Vec::new())
        };
        mark_ready(&mut header, Stage::Planes, published);
        header.mark_started(Stage::Planes);
        let mut axes = None;
        if use_manhattan || surfaces_publisher.is_some() {
            let request = SurfaceRequest {
                axes_from: use_manhattan.then_some((&frame_lines, predicted.rotation.as_ref())),
                planes: send_planes,
                depth: send_depth,
            };
            match frame_view(&sample)
                .map_err(|e| format!("bad frame: {e}"))
                .and_then(|frame| {
                    structure
                        .extract(
                            &frame.gray(),
                            &frame.depth(),
                            &camera,
                            &request,
                            &mut surfaces,
                        )
                        .map_err(|e| e.to_string())
                }) {
                Ok(extracted) => axes = extracted,
                Err(e) => tracing::warn!(frame = id, "planes: {e}"),
            }
        }
        drop(sample);
        header.mark_finished(Stage::Planes);
        match &axes {
            Some(a) => publisher.publish_slice(&header, &[WireManhattan::new(a)])?,
            None => publisher.publish_slice(&header, &[])?,
        };
        if let Some(surfaces_publisher) = &surfaces_publisher {
            // A frame whose extraction failed sends empty surfaces: the tracker's join
            // waits for this part of every frame.
            match encode_message(&surfaces, &mut surface_bytes) {
                Ok(_) => surfaces_publisher.publish_slice(&header, &surface_bytes)?,
                Err(e) => {
                    tracing::warn!(frame = id, "planes: cannot encode the surfaces: {e}");
                    surfaces_publisher.publish_slice(&header, &[])?
                }
            };
        }
        ctx.made(id);
        let history = structure.previous_axes().copied();
        state.write(CHECKPOINT, &(id, history), &mut scratch)?;
        done = Some(id);
    }
    Ok(())
}
