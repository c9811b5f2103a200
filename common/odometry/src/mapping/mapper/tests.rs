use super::*;
use crate::testing::{Scene, first_keyframe, pose, tracked};

/// The scene seen again 2 cm to the right, with the even keypoints tracked (linked
/// to the first keyframe's points) and the odd ones not.
fn second_frame(scene: &Scene, map: &Map, first: KeyFrameId) -> TrackedFrame {
    let at = pose(0.02, 0.0);
    let mut frame = tracked(scene.features(1, &at), at);
    let links = &map.keyframe(first).expect("first").point_ids;
    for (i, slot) in frame.point_ids.iter_mut().enumerate().step_by(2) {
        *slot = links[i];
    }
    frame
}

#[test]
fn the_first_keyframe_maps_every_keypoint_with_depth_and_every_3d_line() {
    let (map, _, kf) = first_keyframe(&Scene::new(200, 20), &OdometryConfig::default());
    let keyframe = map.keyframe(kf).expect("keyframe");
    assert_eq!((map.point_count(), map.line_count()), (200, 20));
    assert!(keyframe.point_ids.iter().all(Option::is_some));
    assert!(keyframe.line_ids.iter().all(Option::is_some));
    // Geometry: each point looks back at the camera, within its scale range.
    for id in map.point_ids() {
        let p = map.point(id).expect("point");
        let distance = p.position.coords.norm();
        assert!((p.normal + p.position.coords / distance).norm() < 1e-9);
        assert!(p.min_distance < distance && distance <= p.max_distance + 1e-12);
    }
}

#[test]
fn a_second_keyframe_fuses_its_new_points_into_the_existing_ones() {
    let config = OdometryConfig::default();
    let scene = Scene::new(200, 20);
    let (mut map, mut mapper, first) = first_keyframe(&scene, &config);
    let frame = second_frame(&scene, &map, first);
    let kf = mapper.add_keyframe(&mut map, &frame, &mut WorldManhattan::new(false));
    // The odd keypoints got new points at keyframe creation; fusion merged each
    // with the first keyframe's point it duplicates.
    assert_eq!(map.point_count(), 200);
    for id in map.point_ids() {
        let observers: Vec<_> = map
            .point(id)
            .expect("p")
            .observations
            .iter()
            .map(|o| o.0)
            .collect();
        assert!(
            observers.contains(&first) && observers.contains(&kf),
            "{id}: {observers:?}"
        );
    }
    assert_eq!(map.connected(kf), vec![(first, 200)]);
}

#[test]
fn landmarks_tracking_rarely_finds_are_culled_at_the_next_keyframe() {
    let config = OdometryConfig::default();
    let scene = Scene::new(200, 20);
    let (mut map, mut mapper, first) = first_keyframe(&scene, &config);
    let keyframe = map.keyframe(first).expect("first");
    let (point, kept_point) = (
        keyframe.point_ids[2].unwrap(),
        keyframe.point_ids[4].unwrap(),
    );
    let (line, kept_line) = (keyframe.line_ids[0].unwrap(), keyframe.line_ids[1].unwrap());
    // Predicted in view often, found once: below MIN_FOUND_RATIO.
    map.point_mut(point).expect("p").visible = 5;
    map.line_mut(line).expect("l").visible = LINE_CULL_MIN_VISIBLE;
    // Too few predictions to judge a line yet.
    map.line_mut(kept_line).expect("l").visible = LINE_CULL_MIN_VISIBLE - 1;
    let frame = second_frame(&scene, &map, first);
    mapper.add_keyframe(&mut map, &frame, &mut WorldManhattan::new(false));
    assert!(map.point(point).is_none() && map.point(kept_point).is_some());
    assert!(map.line(line).is_none() && map.line(kept_line).is_some());
}

#[test]
fn a_keyframe_whose_points_and_lines_others_see_is_culled() {
    let mut config = OdometryConfig::default();
    config.keyframes.redundant_observers = 1;
    let scene = Scene::new(200, 4);
    let (mut map, mut mapper, first) = first_keyframe(&scene, &config);
    let mut ids = vec![first];
    for k in 1..4 {
        let at = pose(0.01 * k as f64, 0.0);
        let mut frame = tracked(scene.features(k, &at), at);
        frame.point_ids = map.keyframe(first).expect("first").point_ids.clone();
        frame.line_ids = map.keyframe(first).expect("first").line_ids.clone();
        ids.push(mapper.add_keyframe(&mut map, &frame, &mut WorldManhattan::new(false)));
    }
    // Keyframe 1 is seen through by 2 and 3 (more than one other observer for every
    // point and line); the first keyframe and the newest are never culled.
    assert!(map.keyframe(ids[1]).is_none());
    assert!(map.keyframe(ids[0]).is_some() && map.keyframe(ids[3]).is_some());
}

#[test]
fn a_keyframe_of_a_place_an_earlier_pass_mapped_needs_fewer_observers() {
    let connected = |ids: &[u64]| -> Vec<(KeyFrameId, u32)> {
        ids.iter().map(|&k| (KeyFrameId(k), 30)).collect()
    };
    let mut rule = Redundancy {
        observers: 3,
        revisit_observers: 2,
        closed_through: None,
        gap: 20,
    };
    let kf = KeyFrameId(50);
    assert_eq!(
        rule.observers_for(kf, || connected(&[49, 5])),
        3,
        "no loop yet"
    );
    rule.closed_through = Some(KeyFrameId(34));
    assert_eq!(
        rule.observers_for(kf, || connected(&[49, 5])),
        2,
        "5: earlier pass"
    );
    assert_eq!(
        rule.observers_for(kf, || connected(&[49, 40])),
        3,
        "40: after the loop"
    );
    assert_eq!(
        rule.observers_for(KeyFrameId(30), || connected(&[29, 28])),
        3
    );
}
