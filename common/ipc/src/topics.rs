//! The pipeline's topics (DESIGN.md "Data flow"): one name and kind each, shared by every
//! stage so that publishers and subscribers meet with the same queue sizes.

use crate::qos::{Mode, TopicKind, TopicQos};

/// A topic of the pipeline: its name (the last part of `gfsvo/<run-id>/<name>`) and the
/// kind that sizes its queues.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TopicSpec {
    /// Topic name.
    pub name: &'static str,
    /// What it carries.
    pub kind: TopicKind,
}

impl TopicSpec {
    /// Queue sizes of this topic in `mode`.
    pub fn qos(&self, mode: Mode) -> TopicQos {
        TopicQos::new(mode, self.kind)
    }
}

/// `source` -> everyone: gray, depth (metres) and colour of frame k ([`crate::frame`]).
pub const FRAME: TopicSpec = TopicSpec {
    name: "frame",
    kind: TopicKind::Frame,
};
/// `points` -> `tracker`: ORB keypoints with depth of frame k.
pub const POINTS: TopicSpec = TopicSpec {
    name: "points",
    kind: TopicKind::Features,
};
/// `lines` -> `planes`, `tracker`: 2D + 3D line segments with LBD descriptors.
pub const LINES: TopicSpec = TopicSpec {
    name: "lines",
    kind: TopicKind::Features,
};
/// `planes` -> `tracker`: plane normals, Manhattan axes, line <-> axis association.
pub const MANHATTAN: TopicSpec = TopicSpec {
    name: "manhattan",
    kind: TopicKind::Features,
};
/// `planes` -> `tracker`: the frame's BFS planes and depth grid (bincode), published only
/// with `[tracking] use_planes` or `use_depth_alignment`.
pub const SURFACES: TopicSpec = TopicSpec {
    name: "surfaces",
    kind: TopicKind::Features,
};
/// `source` -> `tracker`: the IMU samples before frame k (up to its stamp and the first
/// past it), published just before the frame and only when the input has an IMU.
pub const IMU: TopicSpec = TopicSpec {
    name: "imu",
    kind: TopicKind::Features,
};
/// `tracker` -> recorder, `source` (lockstep pacing): the pose and status of frame k.
pub const POSE: TopicSpec = TopicSpec {
    name: "pose",
    kind: TopicKind::Poses,
};
/// `tracker` -> recorder, `gfsvo-ros2`: the matched keypoints and lines of frame k, for
/// viewers (published only while someone subscribes).
pub const TRACKED: TopicSpec = TopicSpec {
    name: "tracked",
    kind: TopicKind::Features,
};
/// `tracker` -> `mapper`: a new keyframe (bincode).
pub const KEYFRAME: TopicSpec = TopicSpec {
    name: "keyframe",
    kind: TopicKind::Variable,
};
/// `mapper` -> `tracker`: the bounded local-map snapshot (bincode).
pub const LOCAL_MAP: TopicSpec = TopicSpec {
    name: "local-map",
    kind: TopicKind::Variable,
};

/// `mapper` -> `loop`: the map after local mapping of each keyframe (bincode), sent
/// only with loop closing on.
pub const KEYFRAME_MAP: TopicSpec = TopicSpec {
    name: "keyframe-map",
    kind: TopicKind::Variable,
};
/// `loop` -> `mapper`: the verdict on each keyframe's map, a loop correction or none
/// (bincode).
pub const LOOP_VERDICT: TopicSpec = TopicSpec {
    name: "loop-verdict",
    kind: TopicKind::Variable,
};
/// `gfsvo-ros2` -> `tracker` (and any stage a request is for): requests from outside
/// the run, such as a reset (bincode `gfs_pipeline::control::ControlMessage`).
pub const CONTROL: TopicSpec = TopicSpec {
    name: "control",
    kind: TopicKind::Variable,
};

/// anyone (`gfsvo ros2`'s `/gfsvo/save_map`) -> `mapper`: write the global map to a file
/// now (bincode `gfs_pipeline::map_files::SaveMapRequest`).
pub const SAVE_MAP: TopicSpec = TopicSpec {
    name: "save-map",
    kind: TopicKind::Variable,
};
/// `mapper` -> whoever asked: the file written or the error (bincode
/// `gfs_pipeline::map_files::SaveMapReply`).
pub const MAP_SAVED: TopicSpec = TopicSpec {
    name: "map-saved",
    kind: TopicKind::Variable,
};

/// Every topic of the pipeline.
pub const ALL: [TopicSpec; 15] = [
    FRAME,
    IMU,
    POINTS,
    LINES,
    MANHATTAN,
    SURFACES,
    POSE,
    TRACKED,
    KEYFRAME,
    LOCAL_MAP,
    KEYFRAME_MAP,
    LOOP_VERDICT,
    SAVE_MAP,
    MAP_SAVED,
    CONTROL,
];

#[cfg(test)]
mod tests {
    use super::*;
    use crate::run::{IpcRun, RunId};

    #[test]
    fn names_are_unique_valid_service_names() {
        let run = IpcRun::new(RunId::new("t").unwrap()).unwrap();
        for (i, a) in ALL.iter().enumerate() {
            assert!(run.service_name(a.name).is_ok(), "{}", a.name);
            assert!(ALL[i + 1..].iter().all(|b| b.name != a.name), "{}", a.name);
        }
        assert_eq!(FRAME.qos(Mode::Realtime).subscriber_buffer, 1);
        assert_eq!(LOCAL_MAP.qos(Mode::Lockstep).history, 2);
    }
}
