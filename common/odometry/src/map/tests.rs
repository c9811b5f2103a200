//! The map's link invariant under insert, link, unlink, merge and removal.

use super::*;
use crate::config::OdometryConfig;
use crate::testing::{Scene, descriptor, first_keyframe, relinked};
use gfs_core::ids::FrameId;
use nalgebra::{Isometry3, Point3, Vector3};

/// Keyframe `k`'s slot `i` holds landmark `l` exactly when `l` lists `(k, i)`, and no
/// landmark is without observations.
fn assert_links(map: &Map) {
    fn kind<L: Landmark>(map: &Map) {
        let store = L::store(map);
        for id in store.ids() {
            let l = store.get(id).expect("listed");
            assert!(!l.observations().is_empty(), "{id:?} has no observation");
            for (kf, i) in l.observations() {
                let keyframe = map.keyframe(*kf).expect("observer exists");
                assert_eq!(L::slots(keyframe)[*i as usize], Some(id), "{id:?} in {kf}");
            }
        }
        for keyframe in map.keyframes() {
            for (i, slot) in L::slots(keyframe).iter().enumerate() {
                if let Some(id) = slot {
                    let l = store.get(*id).expect("linked landmark exists");
                    assert!(l.observations().contains(&(keyframe.id, i as u32)));
                }
            }
        }
    }
    kind::<MapPoint>(map);
    kind::<MapLine>(map);
}

fn point(x: f64) -> MapPoint {
    MapPoint {
        position: Point3::new(x, 0.0, 2.0),
        descriptor: descriptor(1, x as u64),
        observations: Vec::new(),
        normal: -Vector3::z(),
        max_distance: 4.0,
        min_distance: 0.5,
        first_kf: KeyFrameId(0),
        visible: 1,
        found: 1,
    }
}

/// A keyframe with `n` keypoints (descriptors of points 0..n) and no links.
fn keyframe(n: usize) -> KeyFrame {
    let scene = Scene::new(n, 0);
    let features = scene.features(0, &Isometry3::identity());
    KeyFrame {
        id: KeyFrameId(0),
        camera_from_world: Isometry3::identity(),
        point_ids: vec![None; n],
        line_ids: Vec::new(),
        plane_ids: Vec::new(),
        loop_correction: Isometry3::identity(),
        features: crate::frontend::features::FrameFeatures {
            id: FrameId(0),
            ..features
        },
    }
}

#[test]
fn inserted_landmarks_are_linked_both_ways_and_a_slot_takes_one() {
    let mut map = Map::default();
    let kf = map.insert_keyframe(keyframe(4));
    let a = map.insert_landmark(point(0.0), kf, 0).expect("free slot");
    assert_eq!(map.insert_landmark(point(1.0), kf, 0), None, "slot taken");
    assert_eq!(
        map.insert_landmark(point(1.0), kf, 9),
        None,
        "no such keypoint"
    );
    assert_eq!(
        map.insert_landmark(point(1.0), KeyFrameId(7), 1),
        None,
        "no keyframe"
    );
    assert_eq!(map.point(a).expect("point").first_kf, kf);
    assert_eq!(map.point_count(), 1);
    assert_links(&map);
}

#[test]
fn a_new_keyframe_observes_existing_landmarks_and_drops_dangling_links() {
    let mut map = Map::default();
    let first = map.insert_keyframe(keyframe(4));
    let a = map.insert_landmark(point(0.0), first, 0).expect("free");
    let mut second = keyframe(4);
    second.point_ids[2] = Some(a);
    second.point_ids[3] = Some(MapPointId(99));
    let kf = map.insert_keyframe(second);
    assert_eq!(map.keyframe(kf).expect("kf").point_ids[3], None);
    assert_eq!(
        map.point(a).expect("a").observations,
        vec![(first, 0), (kf, 2)]
    );
    assert_links(&map);
}

#[test]
fn link_and_unlink_keep_the_invariant_and_the_last_unlink_removes() {
    let mut map = Map::default();
    let k0 = map.insert_keyframe(keyframe(4));
    let k1 = map.insert_keyframe(keyframe(4));
    let a = map.insert_landmark(point(0.0), k0, 0).expect("free");
    assert!(map.link(a, k1, 1));
    assert!(!map.link(a, k1, 1), "slot taken");
    assert!(!map.link(MapPointId(42), k1, 2), "no such point");
    assert_links(&map);
    map.unlink(a, k0);
    assert_eq!(map.keyframe(k0).expect("k0").point_ids[0], None);
    assert_links(&map);
    map.unlink(a, k1);
    assert!(map.point(a).is_none(), "no observation left");
    assert_links(&map);
}

#[test]
fn removing_a_landmark_clears_every_slot_that_saw_it() {
    let mut map = Map::default();
    let k0 = map.insert_keyframe(keyframe(4));
    let k1 = map.insert_keyframe(keyframe(4));
    let a = map.insert_landmark(point(0.0), k0, 0).expect("free");
    map.link(a, k1, 3);
    map.remove_landmark(a);
    assert!(
        map.keyframes()
            .all(|k| k.point_ids.iter().all(Option::is_none))
    );
    assert_links(&map);
}

#[test]
fn removing_a_keyframe_takes_the_landmarks_only_it_saw_and_reanchors_the_others() {
    let mut map = Map::default();
    let k0 = map.insert_keyframe(keyframe(4));
    let k1 = map.insert_keyframe(keyframe(4));
    let shared = map.insert_landmark(point(0.0), k0, 0).expect("free");
    let alone = map.insert_landmark(point(1.0), k0, 1).expect("free");
    map.link(shared, k1, 0);
    map.remove_keyframe(k0);
    assert!(map.point(alone).is_none());
    let p = map.point(shared).expect("still seen by k1");
    assert_eq!((p.first_kf, p.observations.clone()), (k1, vec![(k1, 0)]));
    assert_links(&map);
    map.clear_keyframes();
    assert_eq!((map.keyframe_count(), map.point_count()), (0, 0));
}

#[test]
fn merging_moves_observations_adds_sightings_and_keeps_one_link_per_keyframe() {
    let mut map = Map::default();
    let k0 = map.insert_keyframe(keyframe(4));
    let k1 = map.insert_keyframe(keyframe(4));
    let into = map.insert_landmark(point(0.0), k0, 0).expect("free");
    let from = map.insert_landmark(point(0.1), k0, 1).expect("free");
    map.link(from, k1, 2);
    map.merge(from, into);
    assert!(map.point(from).is_none());
    let p = map.point(into).expect("survivor");
    // k0 saw both: its link to `into` stays, the other slot is freed.
    assert_eq!(p.observations, vec![(k0, 0), (k1, 2)]);
    assert_eq!(map.keyframe(k0).expect("k0").point_ids[1], None);
    assert_eq!((p.visible, p.found), (2, 2));
    assert_links(&map);
}

#[test]
fn covisibility_counts_shared_landmarks_and_connected_keeps_the_strong_ones() {
    let config = OdometryConfig::default();
    let (mut map, _, k0) = first_keyframe(&Scene::new(40, 4), &config);
    let mut frame = relinked(map.keyframe(k0).expect("k0"));
    // The second keyframe sees 20 of the points and 2 of the lines again.
    for slot in frame.point_ids.iter_mut().skip(20) {
        *slot = None;
    }
    for slot in frame.line_ids.iter_mut().skip(2) {
        *slot = None;
    }
    let k1 = map.insert_keyframe(KeyFrame {
        id: KeyFrameId(0),
        camera_from_world: frame.camera_from_world,
        features: frame.features.clone(),
        point_ids: frame.point_ids.clone(),
        line_ids: frame.line_ids.clone(),
        plane_ids: Vec::new(),
        loop_correction: Isometry3::identity(),
    });
    assert_eq!(map.covisible(k0, 1), vec![(k1, 22)]);
    assert_eq!(map.covisible(k0, 23), Vec::new());
    assert_eq!(map.connected(k1), vec![(k0, 22)]);
    assert_links(&map);
}

#[test]
fn the_descriptor_is_the_observation_closest_to_the_others() {
    let mut map = Map::default();
    let base = keyframe(1).features.point_descriptors[0];
    let mut near = base;
    near[0] ^= 0b1;
    let mut far = base;
    far[1] = !far[1];
    let mut ids = Vec::new();
    for d in [far, base, near] {
        let mut k = keyframe(1);
        k.features.point_descriptors[0] = d;
        ids.push(map.insert_keyframe(k));
    }
    let p = map.insert_landmark(point(0.0), ids[0], 0).expect("free");
    map.link(p, ids[1], 0);
    map.link(p, ids[2], 0);
    map.update_descriptor(p);
    assert_eq!(map.point(p).expect("p").descriptor, base);
}

#[test]
fn canonical_copies_encode_alike_however_they_were_built() {
    let (mut map, _, _) = first_keyframe(&Scene::new(60, 6), &OdometryConfig::default());
    let mut copy = map.clone();
    for id in map.point_ids().collect::<Vec<_>>().into_iter().step_by(3) {
        copy.remove_landmark(id);
        map.remove_landmark(id);
    }
    map.canonicalise();
    let config = bincode::config::standard();
    let encode = |m: &Map| bincode::serde::encode_to_vec(m, config).expect("encode");
    let (mut decoded, _): (Map, usize) =
        bincode::serde::decode_from_slice(&encode(&copy), config).expect("decode");
    decoded.canonicalise();
    assert_eq!(encode(&map), encode(&decoded));
}

#[test]
fn a_loop_correction_moves_a_plane_with_its_keyframe() {
    let mut map = Map::default();
    let mut kf = keyframe(1);
    kf.plane_ids = vec![None];
    let kf = map.insert_keyframe(kf);
    // The floor 1.5 m below the camera (y down): n = (0, -1, 0), offset 1.5.
    let id = map
        .insert_landmark(MapPlane::new(-Vector3::y(), 1.5), kf, 0)
        .expect("free plane slot");
    let on_floor = Point3::new(0.4, 1.5, 2.0);
    let t = Isometry3::new(Vector3::new(0.1, -0.2, 0.3), Vector3::new(0.05, 0.2, -0.1));
    map.move_landmarks(|k| (k == kf).then_some(t));
    let plane = map.plane(id).expect("plane kept");
    let moved = t * on_floor;
    assert!((plane.normal - t.rotation * -Vector3::y()).norm() < 1e-12);
    assert!((plane.normal.dot(&moved.coords) + plane.offset).abs() < 1e-12);
}
