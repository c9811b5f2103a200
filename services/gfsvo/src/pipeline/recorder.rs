//! The recorder: collects the pose of every frame from the `pose` topic, with the stage
//! stamps its header carried, and the mapper's stamps from the `local-map` topic.

use gfs_core::ids::FrameId;
use gfs_core::scene::{FrameView, Scene};
use gfs_core::stamp::Stamp;
use gfs_ipc::profile::Profile;
use gfs_ipc::{
    IpcError, IpcRun, MAX_VARIABLE_MESSAGE_BYTES, Mode, Service, Stage, TopicSubscriber,
    decode_message, topics,
};
use gfs_odometry::map::Map;
use gfs_odometry::session::MapUpdate;
use gfs_odometry::{FrameAnchor, FramePose, TrackingStatus};
use gfs_pipeline::wire::{WirePose, WireTrackedFeature};
use iceoryx2::node::Node;
use nalgebra::Isometry3;
use std::collections::BTreeMap;
use std::time::Duration;

/// The covariance of each tracked pose (from its optimisation), by frame id.
pub type Covariances = BTreeMap<u64, nalgebra::Matrix6<f64>>;

/// Poses and profile of a run as they arrive.
pub struct Recorder<S: Service> {
    poses: TopicSubscriber<S, WirePose>,
    maps: TopicSubscriber<S, u8>,
    received: BTreeMap<u64, FramePose>,
    covariances: Covariances,
    corrections: Corrections,
    anchors: Anchors,
    keyframes: usize,
    /// The IMU samples the tracker took in, over the frames recorded.
    imu_samples: u64,
    profile: Profile,
    /// The tracker's map as a viewer draws it, after each keyframe, by the keyframe's
    /// frame id (`None`: not kept).
    scenes: Option<Scenes>,
    /// With the scenes: each frame's matched keypoints and lines, by frame id.
    tracked: Option<(TopicSubscriber<S, WireTrackedFeature>, FrameViews)>,
}

/// The tracker's map after each keyframe as a viewer draws it, by the keyframe's frame
/// id, in arrival order.
pub type Scenes = Vec<(u64, Scene)>;

/// Each tracked frame's matched keypoints and lines, by frame id.
pub type FrameViews = BTreeMap<u64, FrameView>;

/// Each frame's reference keyframe and its map pose when tracked, by frame id (frames
/// before the first keyframe have none).
pub type Anchors = BTreeMap<u64, FrameAnchor>;

/// The tracker's `map_from_odom` by frame id, for the frames published after a loop
/// closed (earlier frames: the identity).
pub type Corrections = BTreeMap<u64, nalgebra::Isometry3<f64>>;

impl<S: Service> Recorder<S> {
    /// Subscribes to the run's poses (before the stages start, so none is missed).
    ///
    /// # Errors
    /// [`IpcError`] when the topics cannot be opened.
    pub fn new(run: &IpcRun, node: &Node<S>, mode: Mode, label: &str) -> Result<Self, IpcError> {
        Ok(Self {
            poses: TopicSubscriber::create(run, node, topics::POSE.name, &topics::POSE.qos(mode))?,
            maps: TopicSubscriber::create(
                run,
                node,
                topics::LOCAL_MAP.name,
                &topics::LOCAL_MAP.qos(mode),
            )?,
            received: BTreeMap::new(),
            covariances: BTreeMap::new(),
            corrections: BTreeMap::new(),
            anchors: BTreeMap::new(),
            keyframes: 0,
            imu_samples: 0,
            profile: Profile::new(label),
            scenes: None,
            tracked: None,
        })
    }

    /// Also keeps the tracker's map after each keyframe as a [`Scene`] (decoded here, in
    /// the supervisor, off the stages' path) and each frame's matches.
    ///
    /// # Errors
    /// [`IpcError`] when the matches' topic cannot be opened.
    pub fn keeping_scenes(
        mut self,
        keep: bool,
        run: &IpcRun,
        node: &Node<S>,
        mode: Mode,
    ) -> Result<Self, IpcError> {
        self.scenes = keep.then(Vec::new);
        if keep {
            let qos = topics::TRACKED.qos(mode);
            let port = TopicSubscriber::create(run, node, topics::TRACKED.name, &qos)?;
            self.tracked = Some((port, BTreeMap::new()));
        }
        Ok(self)
    }

    /// Takes in what arrived; returns the number of new poses.
    ///
    /// # Errors
    /// [`IpcError`] when the transport fails.
    pub fn drain(&mut self) -> Result<usize, IpcError> {
        let mut new = 0;
        while let Some(sample) = self.poses.receive()? {
            let header = *sample.user_header();
            let Some(wire) = sample.payload().first() else {
                continue;
            };
            let Some(pose) = wire.pose() else {
                tracing::warn!(
                    frame = header.frame_id,
                    "recorder: dropping a malformed pose"
                );
                continue;
            };
            // The first pose of a frame wins: a restarted tracker may send one again.
            if let std::collections::btree_map::Entry::Vacant(slot) = self.received.entry(pose.id.0)
            {
                slot.insert(pose);
                if let Some(c) = wire.covariance() {
                    self.covariances.insert(pose.id.0, c);
                }
                let map_from_odom = wire.map_from_odom();
                let in_map = if map_from_odom == Isometry3::identity() {
                    pose.world_from_camera
                } else {
                    self.corrections.insert(pose.id.0, map_from_odom);
                    map_from_odom * pose.world_from_camera
                };
                if let Some(anchor) = wire.anchor(in_map) {
                    self.anchors.insert(pose.id.0, anchor);
                }
                self.keyframes += wire.keyframe as usize;
                self.imu_samples += u64::from(wire.imu_samples);
                self.profile.record(&header, pose.status.as_str());
                new += 1;
            }
        }
        if let Some((port, views)) = &mut self.tracked {
            while let Some(sample) = port.receive()? {
                let mut view = FrameView::default();
                WireTrackedFeature::view(sample.payload(), &mut view);
                views.insert(sample.user_header().frame_id, view);
            }
        }
        while let Some(sample) = self.maps.receive()? {
            self.profile
                .record_stage(sample.user_header(), Stage::Mapper);
            self.profile.record_stage(sample.user_header(), Stage::Loop);
            if let Some(scenes) = &mut self.scenes {
                let frame = sample.user_header().frame_id;
                match decode_message::<MapUpdate>(sample.payload(), MAX_VARIABLE_MESSAGE_BYTES) {
                    Ok(update) if update.keyframe.is_some() => {
                        scenes.push((frame, update.scene()));
                    }
                    Ok(_) => {}
                    Err(e) => tracing::warn!(frame, "recorder: cannot decode a local map: {e}"),
                }
            }
        }
        Ok(new)
    }

    /// The IMU samples the tracker took in before the frames recorded.
    pub fn imu_samples(&self) -> u64 {
        self.imu_samples
    }

    /// Sleeps until a pose is published or `timeout` passed (a signal cuts it short).
    ///
    /// # Errors
    /// [`IpcError`] when the wait fails.
    pub fn wait(&self, timeout: Duration) -> Result<(), IpcError> {
        self.poses.wait(timeout).map(|_| ())
    }

    /// True once frame `last` has a pose (the last input frame).
    pub fn has(&self, last: u64) -> bool {
        self.received.contains_key(&last)
    }

    /// True when frame `frame`'s matches came, or none are kept.
    pub fn has_view(&self, frame: u64) -> bool {
        self.tracked
            .as_ref()
            .is_none_or(|(_, views)| views.contains_key(&frame))
    }

    /// Number of frames with a pose.
    pub fn len(&self) -> usize {
        self.received.len()
    }

    /// Keyframes made over the run.
    pub fn keyframes(&self) -> usize {
        self.keyframes
    }

    /// The poses received so far, by frame id.
    pub fn poses(&self) -> &BTreeMap<u64, FramePose> {
        &self.received
    }

    /// The profile so far.
    pub fn profile(&self) -> &Profile {
        &self.profile
    }

    /// The profile, the poses received and their covariances.
    pub fn into_profile(self) -> (Profile, BTreeMap<u64, FramePose>, Covariances) {
        (self.profile, self.received, self.covariances)
    }

    /// The loop corrections received (taken out).
    pub fn take_corrections(&mut self) -> Corrections {
        std::mem::take(&mut self.corrections)
    }

    /// The scenes kept (taken out; empty unless [`Self::keeping_scenes`]).
    pub fn take_scenes(&mut self) -> Scenes {
        self.scenes.take().unwrap_or_default()
    }

    /// The frames' matches kept (taken out; empty unless [`Self::keeping_scenes`]).
    pub fn take_views(&mut self) -> FrameViews {
        self.tracked
            .as_mut()
            .map(|(_, views)| std::mem::take(views))
            .unwrap_or_default()
    }

    /// The frames' anchors received (taken out).
    pub fn take_anchors(&mut self) -> Anchors {
        std::mem::take(&mut self.anchors)
    }
}

/// The final best estimate of the frames received: a frame tied to a keyframe gets the
/// loop corrections that keyframe received after it, as far as `map` (the mapper's last
/// saved map) knows them; any other frame its map pose as published
/// (`map_from_odom * pose`).
pub fn final_poses(
    received: &BTreeMap<u64, FramePose>,
    corrections: &Corrections,
    anchors: &Anchors,
    map: Option<&Map>,
) -> BTreeMap<u64, FramePose> {
    received
        .iter()
        .map(|(&id, pose)| {
            let world_from_camera = match (anchors.get(&id), map) {
                (Some(anchor), Some(map)) => anchor.final_pose(map),
                _ => match corrections.get(&id) {
                    Some(map_from_odom) => map_from_odom * pose.world_from_camera,
                    None => pose.world_from_camera,
                },
            };
            (
                id,
                FramePose {
                    world_from_camera,
                    ..*pose
                },
            )
        })
        .collect()
}

/// One pose per input frame: a frame without a pose from the tracker (dropped in
/// realtime, or lost to an interruption) gets the pose interpolated at its timestamp
/// between the neighbouring frames that have one (held beyond the first or last),
/// flagged predicted.
pub fn complete_trajectory(
    received: &BTreeMap<u64, FramePose>,
    timestamps: &[Stamp],
) -> Vec<FramePose> {
    let mut out = Vec::with_capacity(timestamps.len());
    for (i, &timestamp) in timestamps.iter().enumerate() {
        let id = i as u64;
        if let Some(pose) = received.get(&id) {
            out.push(*pose);
            continue;
        }
        let before = received.range(..id).next_back().map(|(_, p)| p);
        let after = received.range(id..).next().map(|(_, p)| p);
        let world_from_camera = match (before, after) {
            (Some(a), Some(b)) if b.timestamp > a.timestamp => {
                let t = (timestamp.secs_since(a.timestamp) / b.timestamp.secs_since(a.timestamp))
                    .clamp(0.0, 1.0);
                a.world_from_camera.lerp_slerp(&b.world_from_camera, t)
            }
            (Some(p), _) | (None, Some(p)) => p.world_from_camera,
            (None, None) => Isometry3::identity(),
        };
        out.push(FramePose {
            id: FrameId(id),
            timestamp,
            world_from_camera,
            status: TrackingStatus::Predicted,
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn missing_frames_are_interpolated_and_flagged_predicted() {
        let pose = |id: u64, x: f64| FramePose {
            id: FrameId(id),
            timestamp: Stamp::from_nanos(id as i64 * 1_000_000_000),
            world_from_camera: Isometry3::translation(x, 0.0, 0.0),
            status: TrackingStatus::Tracked,
        };
        let received: BTreeMap<u64, FramePose> =
            [(1, pose(1, 1.0)), (3, pose(3, 3.0))].into_iter().collect();
        let stamps: Vec<Stamp> = (0..5)
            .map(|k| Stamp::from_nanos(k * 1_000_000_000))
            .collect();
        let t = complete_trajectory(&received, &stamps);
        let xs: Vec<f64> = t
            .iter()
            .map(|p| p.world_from_camera.translation.x)
            .collect();
        assert_eq!(xs, [1.0, 1.0, 2.0, 3.0, 3.0]);
        let predicted: Vec<bool> = t
            .iter()
            .map(|p| p.status == TrackingStatus::Predicted)
            .collect();
        assert_eq!(predicted, [true, false, true, false, true]);
        assert_eq!(t[2].timestamp, stamps[2]);
    }
}
