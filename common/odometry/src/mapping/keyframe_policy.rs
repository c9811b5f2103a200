//! When a frame becomes a keyframe (paper "Keyframe Select and Filter", after ORB-SLAM2's
//! `NeedNewKeyFrame` for RGB-D): when the tracked points **or** the tracked lines fall
//! well below the reference keyframe's, each against its own threshold, when close
//! structure is no longer covered by the map, when the view has moved off the
//! reference's depth, or when the last keyframe is too old.

use crate::config::KeyframeConfig;
use crate::map::Map;
use crate::tracking::status::TrackingStatus;
use crate::tracking::tracker::TrackedFrame;
use gfs_core::ids::KeyFrameId;

/// Close keypoints the map must cover (ORB-SLAM2: fewer than 100 tracked close points
/// while more than 70 close ones are untracked asks for a keyframe).
const CLOSE_TRACKED_MIN: usize = 100;
const CLOSE_UNTRACKED_MAX: usize = 70;
/// The line rule needs a reference keyframe with at least this many map lines: with
/// fewer, losing a handful is noise, not a change of view.
const MIN_REFERENCE_LINES: usize = 10;
/// A keyframe needs at least this many tracked points to anchor the map (ORB-SLAM2: 15).
const MIN_INLIERS_FOR_KEYFRAME: usize = 15;

/// What the decision looks at besides the frame.
#[derive(Clone, Copy, Debug)]
pub struct KeyframeContext<'a> {
    /// The map tracked against.
    pub map: &'a Map,
    /// The reference keyframe.
    pub reference: Option<KeyFrameId>,
    /// Frames tracked since the last keyframe.
    pub frames_since_keyframe: u32,
    /// Depth below which a keypoint is close (`[tracking] close_depth_m`).
    pub close_depth_m: f32,
    /// Point matches a tracking step needs
    /// ([`crate::config::TrackingConfig::min_step_inliers`]).
    pub min_step_points: usize,
    /// The frame, tracked on its depth, has moved off the reference's depth
    /// ([`crate::Tracker::leaves_depth_reference`]).
    pub leaves_depth_reference: bool,
}

/// Decides whether `frame` should become a keyframe.
pub fn needs_keyframe(
    config: &KeyframeConfig,
    context: &KeyframeContext<'_>,
    frame: &TrackedFrame,
) -> bool {
    let KeyframeContext {
        map,
        reference,
        frames_since_keyframe,
        close_depth_m,
        min_step_points,
        leaves_depth_reference,
    } = *context;
    if !frame.status.is_tracked() {
        return false;
    }
    let Some(reference) = reference.and_then(|id| map.keyframe(id)) else {
        return true;
    };
    // Points seen by two keyframes (all of them while there is one): ORB-SLAM2 asks
    // for three, which with few, sparse keyframes stays so small that the ratio test
    // never fires and new structure goes unmapped.
    let min_observations = if map.keyframe_count() < 2 { 1 } else { 2 };
    let reference_points = reference
        .point_ids
        .iter()
        .flatten()
        .filter(|id| {
            map.point(**id)
                .is_some_and(|p| p.observations.len() >= min_observations)
        })
        .count();
    let reference_lines = reference
        .line_ids
        .iter()
        .flatten()
        .filter(|id| map.line(**id).is_some())
        .count();

    let (mut close_tracked, mut close_untracked) = (0, 0);
    for (kp, id) in frame.features.keypoints.iter().zip(&frame.point_ids) {
        if kp.depth > 0.0 && kp.depth < close_depth_m {
            if id.is_some() {
                close_tracked += 1;
            } else {
                close_untracked += 1;
            }
        }
    }
    let need_close = close_tracked < CLOSE_TRACKED_MIN && close_untracked > CLOSE_UNTRACKED_MAX;
    let points = frame.inliers.points as f32;
    let points_low = points < reference_points as f32 * config.point_ratio;
    // Lines are less stable than points after homogenisation, so their threshold is
    // lower (paper "Keyframe Select and Filter"), but a drop below it asks for a
    // keyframe on its own: the view moved to where the map's lines are not.
    let lines_low = reference_lines >= MIN_REFERENCE_LINES
        && (frame.inliers.lines as f32) < reference_lines as f32 * config.line_ratio;
    let timeout = frames_since_keyframe >= config.max_frames;
    // A frame the depth alignment or the planes determined on their own may map its
    // points too: that is how a low-texture view gets its first landmarks.
    let on_depth_alone = (frame.inliers.depth > 0 || frame.inliers.planes > 0)
        && frame.status == TrackingStatus::Tracked;
    // A `degraded` frame leaving its depth reference renews it (its own surfaces fix
    // its pose, or the reference is leaving its view).
    let posed =
        frame.inliers.points > MIN_INLIERS_FOR_KEYFRAME || on_depth_alone || leaves_depth_reference;
    // Tracked on depth with no map point in view: its close keypoints are the map's
    // only chance to get points here, once there are enough of them for a tracking
    // step. Fewer, mapped, leave the next frame on depth alone again, asking again: a
    // keyframe every frame, each a new depth reference carrying its frame's error.
    let unmapped =
        on_depth_alone && frame.inliers.points == 0 && close_untracked >= min_step_points;
    // In a room without keypoints no rule above fires before the frame goes
    // `degraded`, and a `degraded` frame without points makes a keyframe only when it
    // leaves its depth reference.
    (points_low || lines_low || need_close || timeout || unmapped || leaves_depth_reference)
        && posed
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{OdometryConfig, TrackingConfig};
    use crate::testing::{CORNER, Scene, first_keyframe, plane_map, relinked, tracked};
    use crate::tracking::status::TrackingStatus;
    use nalgebra::Isometry3;

    /// A map of one keyframe (200 points, 20 lines) and that keyframe's frame seen
    /// again, one frame later.
    fn setup() -> (Map, KeyFrameId, TrackedFrame) {
        let (map, _, kf) = first_keyframe(&Scene::new(200, 20), &OdometryConfig::default());
        let frame = relinked(map.keyframe(kf).expect("keyframe"));
        assert_eq!((frame.inliers.points, frame.inliers.lines), (200, 20));
        (map, kf, frame)
    }

    fn decide(map: &Map, reference: Option<KeyFrameId>, frame: &TrackedFrame, since: u32) -> bool {
        decide_on_depth(map, reference, frame, since, false)
    }

    fn decide_on_depth(
        map: &Map,
        reference: Option<KeyFrameId>,
        frame: &TrackedFrame,
        since: u32,
        leaves_depth_reference: bool,
    ) -> bool {
        let context = KeyframeContext {
            map,
            reference,
            frames_since_keyframe: since,
            close_depth_m: 3.1,
            min_step_points: TrackingConfig::default().min_step_inliers(),
            leaves_depth_reference,
        };
        needs_keyframe(&KeyframeConfig::default(), &context, frame)
    }

    #[test]
    fn a_frame_that_sees_what_its_reference_saw_needs_no_keyframe() {
        let (map, kf, frame) = setup();
        assert!(!decide(&map, Some(kf), &frame, 1));
    }

    #[test]
    fn without_a_reference_a_tracked_frame_becomes_one() {
        let (map, _, mut frame) = setup();
        assert!(decide(&map, None, &frame, 1));
        frame.status = TrackingStatus::Predicted;
        assert!(
            !decide(&map, None, &frame, 1),
            "an untracked frame never does"
        );
    }

    #[test]
    fn points_below_the_point_ratio_ask_for_a_keyframe() {
        let (map, kf, mut frame) = setup();
        // point_ratio 0.9 of the reference's 200 points: 180.
        frame.inliers.points = 181;
        assert!(!decide(&map, Some(kf), &frame, 1));
        frame.inliers.points = 179;
        assert!(decide(&map, Some(kf), &frame, 1));
    }

    #[test]
    fn lines_below_the_line_ratio_ask_for_a_keyframe_on_their_own() {
        let (map, kf, mut frame) = setup();
        // line_ratio 0.3 of the reference's 20 lines: 6; the points stay high.
        frame.inliers.points = 195;
        frame.inliers.lines = 6;
        assert!(!decide(&map, Some(kf), &frame, 1));
        frame.inliers.lines = 5;
        assert!(decide(&map, Some(kf), &frame, 1));
    }

    #[test]
    fn a_reference_with_few_lines_does_not_trigger_the_line_rule() {
        let (map, _, kf, frame) = {
            let (map, mapper, kf) = first_keyframe(&Scene::new(200, 9), &OdometryConfig::default());
            let frame = relinked(map.keyframe(kf).expect("keyframe"));
            (map, mapper, kf, frame)
        };
        let mut frame = frame;
        frame.inliers.lines = 0;
        assert!(!decide(&map, Some(kf), &frame, 1));
    }

    #[test]
    fn a_view_off_the_reference_depth_asks_for_a_keyframe() {
        let (map, kf, mut frame) = setup();
        // The features ask for none (the frame sees what the reference saw): the
        // depth's judgement alone decides.
        frame.inliers.depth = 500;
        assert!(!decide_on_depth(&map, Some(kf), &frame, 1, false));
        assert!(decide_on_depth(&map, Some(kf), &frame, 1, true));
        // A `degraded` frame without points makes one only when its depth leaves the
        // reference (`degraded_frame_renews`), though its points fell below the
        // reference's.
        frame.inliers.points = 0;
        frame.status = TrackingStatus::Degraded;
        assert!(!decide_on_depth(&map, Some(kf), &frame, 1, false));
        assert!(decide_on_depth(&map, Some(kf), &frame, 1, true));
    }

    #[test]
    fn a_frame_on_depth_alone_maps_its_close_keypoints_once_a_tracking_step_could_use_them() {
        // A room of three planes and no map point; the frame is tracked on its depth and
        // sees `n` close keypoints the map does not have.
        let (map, kf) = plane_map(&CORNER);
        let min_step_points = TrackingConfig::default().min_step_inliers();
        let frame_seeing = |n: usize| {
            let mut features = Scene::new(n, 0).features(1, &Isometry3::identity());
            features.keypoints.iter_mut().for_each(|kp| kp.depth = 2.0);
            let mut frame = tracked(features, Isometry3::identity());
            frame.inliers.depth = 500;
            frame
        };
        let (few, enough) = (
            frame_seeing(min_step_points - 1),
            frame_seeing(min_step_points),
        );
        assert!(!decide(&map, Some(kf), &few, 1));
        assert!(decide(&map, Some(kf), &enough, 1));
        // Enough keypoints, but the frame tracks map points: they are not all there is.
        let mut frame = frame_seeing(min_step_points);
        frame.inliers.points = 1;
        assert!(!decide(&map, Some(kf), &frame, 1));
    }

    #[test]
    fn max_frames_after_the_last_keyframe_ask_for_one() {
        let (map, kf, frame) = setup();
        assert!(!decide(&map, Some(kf), &frame, 29));
        assert!(decide(&map, Some(kf), &frame, 30));
    }

    #[test]
    fn close_keypoints_the_map_does_not_cover_ask_for_a_keyframe() {
        let (map, kf, mut frame) = setup();
        // Unlink close keypoints until fewer than 100 close ones are tracked and more
        // than 70 are not; the inlier count stays high.
        let close: Vec<usize> = (0..frame.point_ids.len())
            .filter(|&i| frame.features.keypoints[i].depth < 3.1)
            .collect();
        assert!(close.len() > 160, "{} close keypoints", close.len());
        for &i in close.iter().take(close.len() - 90) {
            frame.point_ids[i] = None;
        }
        assert!(decide(&map, Some(kf), &frame, 1));
    }

    #[test]
    fn a_frame_with_too_few_points_never_becomes_a_keyframe() {
        let (map, kf, mut frame) = setup();
        frame.inliers.points = MIN_INLIERS_FOR_KEYFRAME;
        assert!(!decide(&map, Some(kf), &frame, 30));
        frame.inliers.points = MIN_INLIERS_FOR_KEYFRAME + 1;
        assert!(decide(&map, Some(kf), &frame, 30));
    }
}
