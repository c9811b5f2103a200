use super::*;
use crate::config::OdometryConfig;
use crate::mapping::mapper::Mapper;
use crate::testing::{
    CORNER, Scene, camera, first_keyframe, plane_map, pose, relinked, scale, tracked,
};
use gfs_planes::ManhattanAxes;
use nalgebra::{Isometry3, Rotation3};

#[test]
fn a_lone_keyframe_has_nothing_to_adjust() {
    let config = OdometryConfig::default();
    let (map, _, kf) = first_keyframe(&Scene::new(50, 4), &config);
    let mut ba = LocalMapBa::new(
        config.mapping.clone(),
        camera(),
        scale(),
        PlaneTrackingConfig::default(),
    );
    assert!(ba.assemble(&map, kf, &WorldManhattan::new(false)).is_none());
}

#[test]
fn the_problem_holds_the_new_keyframe_fixed_and_its_neighbours_free() {
    let mut config = OdometryConfig::default();
    config.mapping.local_ba = false;
    let scene = Scene::new(100, 6);
    let (mut map, mut mapper, first): (Map, Mapper, KeyFrameId) = first_keyframe(&scene, &config);
    let at = pose(0.02, 0.0);
    let mut frame = tracked(scene.features(1, &at), at);
    let again = relinked(map.keyframe(first).expect("first"));
    frame.point_ids = again.point_ids;
    frame.line_ids = again.line_ids;
    let kf = mapper.add_keyframe(&mut map, &frame, &mut WorldManhattan::new(false));
    let mut ba = LocalMapBa::new(
        config.mapping.clone(),
        camera(),
        scale(),
        PlaneTrackingConfig::default(),
    );
    let problem = ba
        .assemble(&map, kf, &WorldManhattan::new(false))
        .expect("two keyframes");
    let fixed: Vec<bool> = problem.poses.iter().map(|p| p.fixed).collect();
    assert_eq!(
        fixed,
        vec![true, false],
        "the new keyframe, then its neighbour"
    );
    assert_eq!((problem.points.len(), problem.lines.len()), (100, 6));
    // Every landmark is seen by both keyframes.
    assert_eq!(problem.point_observations.len(), 200);
    assert_eq!(problem.line_observations.len(), 12);
    let depth = problem
        .point_observations
        .iter()
        .filter(|o| o.depth > 0.0)
        .count();
    assert_eq!(depth, 200, "depth enters every observation that has one");
    assert_eq!(problem.line_priors.len(), 6);
    // Alternately vertical and horizontal segments: parallel and perpendicular pairs.
    assert!(!problem.parallel.is_empty() && !problem.perpendicular.is_empty());
    assert!(problem.manhattan.is_empty(), "no world axes known");
}

/// The corner's floor and two walls plus a wall 3 degrees off the first one (x =
/// 1.2 and a plane through x = 2 turned 3 degrees about y), as the BA's planes.
fn corner_and_a_turned_wall(config: &OdometryConfig, manhattan: &WorldManhattan) -> BaProblem {
    let turn = 3f64.to_radians();
    let mut planes = CORNER.to_vec();
    planes.push(([turn.cos(), 0.0, turn.sin()], 2.0));
    let (map, kf) = plane_map(&planes);
    let mut ba = LocalMapBa::new(
        config.mapping.clone(),
        camera(),
        scale(),
        PlaneTrackingConfig::default(),
    );
    let mut problem = BaProblem::new(camera());
    problem.poses.push(BaPose {
        camera_from_world: Isometry3::identity(),
        fixed: true,
    });
    ba.pose_ids.push(kf);
    ba.add_planes(&map, &mut problem);
    ba.add_plane_structure(&map, &mut problem, manhattan);
    problem
}

#[test]
fn planes_near_parallel_or_perpendicular_pair_up_and_planes_near_an_axis_are_tied_to_it() {
    let config = OdometryConfig::default();
    let problem = corner_and_a_turned_wall(&config, &WorldManhattan::new(false));
    assert_eq!(problem.planes.len(), 4);
    assert!(problem.plane_axes.is_empty(), "no world axes known");
    // The two x walls are 3 degrees from parallel (gate 5); every other pair is
    // perpendicular within 3 degrees.
    assert_eq!(problem.plane_parallel, vec![(1, 3)]);
    assert_eq!(problem.plane_perpendicular.len(), 5);

    // With the world axes known, all four planes are within 6 degrees of an axis:
    // tied to it, and no pair is left (the axes imply them).
    let mut manhattan = WorldManhattan::new(true);
    let seen = ManhattanAxes {
        rotation: Rotation3::identity(),
        observed: [true, true, true],
        support: [0.4, 0.4, 0.2],
        confidence: 1.0,
    };
    manhattan.observe(&Isometry3::identity(), &seen);
    let problem = corner_and_a_turned_wall(&config, &manhattan);
    let tied: Vec<usize> = problem.plane_axes.iter().map(|a| a.plane).collect();
    assert_eq!(tied, vec![0, 1, 2, 3]);
    assert!(problem.plane_parallel.is_empty() && problem.plane_perpendicular.is_empty());

    // A 2-degree gate leaves out the turned wall's pairs with the two walls (3
    // degrees off); it stays square to the floor. Sigma 0 adds no term.
    let mut narrow = config.clone();
    narrow.mapping.plane_structure_angle_deg = 2.0;
    let problem = corner_and_a_turned_wall(&narrow, &WorldManhattan::new(false));
    assert!(problem.plane_parallel.is_empty());
    assert_eq!(problem.plane_perpendicular.len(), 4);
    let mut off = config;
    off.mapping.ba.plane_structure_sigma_deg = 0.0;
    let problem = corner_and_a_turned_wall(&off, &manhattan);
    assert!(problem.plane_axes.is_empty() && problem.plane_parallel.is_empty());
}

#[test]
fn keyframes_that_share_only_planes_are_adjusted_through_them() {
    // Two keyframes of the corner's floor and two walls, no point or line; the
    // older one stored 8 mm and 0.3 degrees off. The planes alone determine it: the
    // new keyframe's BA brings it back.
    let config = OdometryConfig::default();
    let mut map = Map::default();
    let mut mapper = Mapper::new(&config, camera(), scale());
    let mut manhattan = WorldManhattan::new(false);
    let keyframe_at = |map: &mut Map, mapper: &mut Mapper, manhattan: &mut WorldManhattan, at| {
        let features = crate::FrameFeatures {
            planes: crate::testing::planes_of(&at, &CORNER),
            ..crate::FrameFeatures::default()
        };
        mapper.add_keyframe(map, &tracked(features, at), manhattan)
    };
    let older = keyframe_at(&mut map, &mut mapper, &mut manhattan, Isometry3::identity());
    let newer = keyframe_at(&mut map, &mut mapper, &mut manhattan, pose(0.1, 0.05));
    let off = Isometry3::from_parts(
        nalgebra::Translation3::new(0.008, -0.003, 0.002),
        nalgebra::UnitQuaternion::from_euler_angles(0.0, 0.0, 0.3f64.to_radians()),
    );
    map.keyframe_mut(older).unwrap().camera_from_world = off;

    let mut ba = LocalMapBa::new(
        config.mapping.clone(),
        camera(),
        scale(),
        PlaneTrackingConfig::default(),
    );
    ba.run(&mut map, newer, &manhattan, &|| false);
    let error = map.keyframe(older).unwrap().camera_from_world;
    assert!(error.translation.vector.norm() < 5e-4, "{error}");
    assert!(error.rotation.angle() < 0.02f64.to_radians(), "{error}");
}

#[test]
fn a_keyframe_with_few_point_observations_is_held_only_when_asked() {
    let mut problem = BaProblem::new(camera());
    for fixed in [true, false, false] {
        problem.poses.push(BaPose {
            camera_from_world: Isometry3::identity(),
            fixed,
        });
    }
    problem.points.push(Vector3::new(0.0, 0.0, 2.0));
    for (pose, n) in [(0, 50), (1, 5), (2, 40)] {
        for _ in 0..n {
            problem.point_observations.push(BaPointObservation {
                pose,
                point: 0,
                uv: nalgebra::Vector2::new(319.5, 239.5),
                inv_sigma2: 1.0,
                depth: 2.0,
            });
        }
    }
    hold_keyframes_with_few_points(&mut problem, 0);
    let fixed = |p: &BaProblem| p.poses.iter().map(|p| p.fixed).collect::<Vec<_>>();
    assert_eq!(fixed(&problem), vec![true, false, false]);
    hold_keyframes_with_few_points(&mut problem, 30);
    assert_eq!(fixed(&problem), vec![true, true, false]);
}
