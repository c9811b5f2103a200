//! The matches of a tracked frame for viewers (`tracked` topic).

use gfs_core::scene::{FrameLine, FramePoint, FrameView};
use gfs_ipc::ZeroCopySend;
use gfs_odometry::FrameMatches;

/// A matched keypoint or line of a tracked frame (`tracked` topic: a slice per frame,
/// the inliers first), for viewers; a point has `end == start`.
#[derive(Clone, Copy, Debug, Default, PartialEq, ZeroCopySend)]
#[type_name("gfsvo::WireTrackedFeature")]
#[repr(C)]
pub struct WireTrackedFeature {
    /// Keypoint, or line start: undistorted pixel (u, v).
    pub start: [f32; 2],
    /// Line end (the keypoint again for a point).
    pub end: [f32; 2],
    /// Keypoint depth, metres (0 = none or a line).
    pub depth: f32,
    /// [`WireTrackedFeature::POINT_INLIER`] and friends.
    pub kind: u32,
}

impl WireTrackedFeature {
    /// A keypoint, inlier of the frame's pose.
    pub const POINT_INLIER: u32 = 0;
    /// A keypoint the pose optimisation rejected.
    pub const POINT_OUTLIER: u32 = 1;
    /// A line, inlier of the frame's pose.
    pub const LINE_INLIER: u32 = 2;
    /// A line the pose optimisation rejected.
    pub const LINE_OUTLIER: u32 = 3;

    /// The matched keypoints and lines of `matches`, inliers first, into `out`.
    pub fn fill(matches: &FrameMatches<'_>, out: &mut Vec<Self>) {
        out.clear();
        let features = &matches.frame.features;
        for (i, inlier) in matches.points() {
            if let Some(kp) = features.keypoints.get(i) {
                out.push(Self {
                    start: [kp.u, kp.v],
                    end: [kp.u, kp.v],
                    depth: kp.depth,
                    kind: if inlier {
                        Self::POINT_INLIER
                    } else {
                        Self::POINT_OUTLIER
                    },
                });
            }
        }
        for (j, inlier) in matches.lines() {
            if let Some(line) = features.lines.get(j) {
                out.push(Self {
                    start: line.segment.start,
                    end: line.segment.end,
                    depth: 0.0,
                    kind: if inlier {
                        Self::LINE_INLIER
                    } else {
                        Self::LINE_OUTLIER
                    },
                });
            }
        }
    }

    /// The frame view of a `tracked` slice; features with a non-finite coordinate or an
    /// unknown kind (a corrupt message) are left out.
    pub fn view(wire: &[Self], out: &mut FrameView) {
        out.points.clear();
        out.lines.clear();
        for f in wire {
            if !f.start.iter().chain(&f.end).all(|v| v.is_finite()) {
                continue;
            }
            match f.kind {
                Self::POINT_INLIER | Self::POINT_OUTLIER => out.points.push(FramePoint {
                    uv: f.start,
                    depth: if f.depth.is_finite() { f.depth } else { 0.0 },
                    inlier: f.kind == Self::POINT_INLIER,
                }),
                Self::LINE_INLIER | Self::LINE_OUTLIER => out.lines.push(FrameLine {
                    ends: [f.start, f.end],
                    inlier: f.kind == Self::LINE_INLIER,
                }),
                _ => {}
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tracked_features_read_back_as_a_frame_view_without_corrupt_entries() {
        let feature = |start: [f32; 2], end: [f32; 2], depth: f32, kind: u32| WireTrackedFeature {
            start,
            end,
            depth,
            kind,
        };
        let wire = [
            feature(
                [10.0, 20.0],
                [10.0, 20.0],
                1.5,
                WireTrackedFeature::POINT_INLIER,
            ),
            feature(
                [30.0, 40.0],
                [30.0, 40.0],
                f32::NAN,
                WireTrackedFeature::POINT_OUTLIER,
            ),
            feature(
                [1.0, 2.0],
                [50.0, 60.0],
                0.0,
                WireTrackedFeature::LINE_OUTLIER,
            ),
            feature(
                [f32::NAN, 2.0],
                [5.0, 6.0],
                0.0,
                WireTrackedFeature::LINE_INLIER,
            ),
            feature([1.0, 2.0], [5.0, 6.0], 0.0, 9),
        ];
        let mut view = FrameView::default();
        WireTrackedFeature::view(&wire, &mut view);
        assert_eq!(
            view.points,
            [
                FramePoint {
                    uv: [10.0, 20.0],
                    depth: 1.5,
                    inlier: true
                },
                FramePoint {
                    uv: [30.0, 40.0],
                    depth: 0.0,
                    inlier: false
                }
            ]
        );
        assert_eq!(
            view.lines,
            [FrameLine {
                ends: [[1.0, 2.0], [50.0, 60.0]],
                inlier: false
            }]
        );
        // deploy/iceoryx2.toml documents the layout for other languages.
        assert_eq!(std::mem::size_of::<WireTrackedFeature>(), 24);
    }
}
