//! A map kept from one run for the next, end to end on the built-in synthetic room: a
//! run maps the first frames and saves its map; a second run loads it and localises
//! (the map fixed) from the first frame, from a frame part-way in and from a pose hint,
//! or extends it with the frames that follow. Poses are compared, without any alignment, with the
//! first run's and with the truth in the first run's frame (its first camera).

mod common;

use common::in_process::InProcess;
use gfs_odometry::map_file::{MapCamera, load_map};
use gfs_odometry::session::LoadedMapUse;
use gfs_odometry::{OdometryConfig, TrackingStatus};
use gfs_points::OrbConfig;
use gfs_synth::{SynthConfig, SynthSequence};
use nalgebra::Isometry3;
use std::ops::Range;
use std::path::{Path, PathBuf};

/// Frames the first run maps.
const MAPPED: usize = 120;

struct Room {
    sequence: SynthSequence,
    /// `T_wc` of frame 0: the first run's world.
    origin: Isometry3<f64>,
}

impl Room {
    fn new(frames: usize) -> Self {
        let sequence = SynthSequence::new(SynthConfig {
            frames,
            ..SynthConfig::default()
        });
        let origin = sequence.pose(0);
        Self { sequence, origin }
    }

    fn camera(&self) -> MapCamera {
        let orb = OrbConfig::default();
        MapCamera {
            camera: self.sequence.config().camera,
            scale_factor: f64::from(orb.scale_factor),
            levels: orb.levels as u8,
        }
    }

    /// Runs `frames` through `vo`: each frame's status and map pose, and its position
    /// error against the truth in the first run's world, metres.
    fn run(
        &self,
        vo: &mut InProcess,
        frames: Range<usize>,
    ) -> Vec<(TrackingStatus, Isometry3<f64>, f64)> {
        frames
            .map(|i| {
                let frame = self.sequence.render(i);
                let pose = vo.process(i, &frame);
                let map_pose = vo.odometry.map_from_odom() * pose.world_from_camera;
                let truth = self.origin.inverse() * frame.pose;
                let error = (truth.translation.vector - map_pose.translation.vector).norm();
                (pose.status, map_pose, error)
            })
            .collect()
    }
}

fn rms(values: impl Iterator<Item = f64>) -> f64 {
    let (sum, n) = values.fold((0.0, 0usize), |(s, n), v| (s + v * v, n + 1));
    (sum / n.max(1) as f64).sqrt()
}

fn temp_file(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("gfs-map-file-e2e-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// Loads `path` into a fresh odometry that uses it as `use_`.
fn started_on(room: &Room, path: &Path, use_: LoadedMapUse) -> InProcess {
    let mut vo = InProcess::new(room.sequence.config().camera, OdometryConfig::default());
    let saved = load_map(path, &room.camera()).expect("the saved map loads");
    vo.odometry.start_from(saved, &use_);
    vo
}

#[test]
fn localising_in_a_saved_map_poses_every_frame_in_its_frame() {
    let room = Room::new(MAPPED);
    let mut first = InProcess::new(room.sequence.config().camera, OdometryConfig::default());
    let mapped = room.run(&mut first, 0..MAPPED);
    assert!(mapped.iter().all(|(s, _, _)| s.is_tracked()));
    let path = temp_file("room.gfsmap");
    first
        .odometry
        .save_map(&path, &room.camera())
        .expect("saved");
    let map = first.odometry.map();
    let (keyframes, points) = (map.keyframe_count(), map.point_count());
    let mapped_error = rms(mapped.iter().map(|(_, _, e)| *e));

    for start in [0, 60] {
        let localise = LoadedMapUse {
            localise: true,
            initial_pose: None,
        };
        let mut vo = started_on(&room, &path, localise);
        let localised = room.run(&mut vo, start..MAPPED);
        let lost: Vec<usize> = (start..)
            .zip(&localised)
            .filter(|(_, (s, _, _))| !s.is_tracked())
            .map(|(i, _)| i)
            .collect();
        let difference = rms(localised
            .iter()
            .zip(&mapped[start..])
            .map(|((_, a, _), (_, b, _))| (a.translation.vector - b.translation.vector).norm()));
        let error = rms(localised.iter().map(|(_, _, e)| *e));
        println!(
            "from frame {start}: {} frames, {} not posed, RMS difference to the mapping run \
             {difference:.4} m, error {error:.4} m (mapping run {mapped_error:.4} m), \
             relocalisations {}",
            localised.len(),
            lost.len(),
            vo.odometry.relocalisations()
        );
        assert!(
            lost.is_empty(),
            "from frame {start}: frames not posed {lost:?}"
        );
        assert!(difference <= 0.02, "from frame {start}: {difference} m");
        // With the depth alignment and planes on (the default), a run localised in the
        // fixed map errs 7.0 mm from frame 0 where the mapping run erred 5.0 mm (before
        // they were on: 4.2 against 4.7): the local BAs moved the map's first keyframes
        // 7 mm after the mapping run tracked its first frames (docs/maps.md); held here
        // to what it is.
        assert!(
            error <= 1.5 * mapped_error,
            "from frame {start}: {error} m against {mapped_error} m"
        );
        assert_eq!(vo.odometry.keyframes_added(), 0);
        // The first frame was found in the whole map, and nothing else was needed.
        assert_eq!(vo.odometry.relocalisations(), 1, "from frame {start}");
        let after = vo.odometry.map();
        assert_eq!(
            (after.keyframe_count(), after.point_count()),
            (keyframes, points)
        );
    }

    // A hint (where the mapping run had frame 60, off by 5 cm) places the first frame
    // around the nearest keyframe, without a search of the whole map.
    let mut hint = mapped[60].1;
    hint.translation.vector.x += 0.05;
    let use_ = LoadedMapUse {
        localise: true,
        initial_pose: Some(hint),
    };
    let mut vo = started_on(&room, &path, use_);
    let localised = room.run(&mut vo, 60..MAPPED);
    assert!(localised.iter().all(|(s, _, _)| s.is_tracked()));
    assert_eq!(vo.odometry.relocalisations(), 0, "found from the hint");
    let first = (localised[0].1.translation.vector - mapped[60].1.translation.vector).norm();
    assert!(first < 0.01, "{first} m");
    let _ = std::fs::remove_file(path);
}

#[test]
fn extending_a_saved_map_continues_in_its_frame() {
    const SPLIT: usize = 100;
    let room = Room::new(2 * SPLIT);
    let mut first = InProcess::new(room.sequence.config().camera, OdometryConfig::default());
    let before = room.run(&mut first, 0..SPLIT);
    let path = temp_file("extend.gfsmap");
    first
        .odometry
        .save_map(&path, &room.camera())
        .expect("saved");
    let keyframes = first.odometry.map().keyframe_count();

    let mut vo = started_on(&room, &path, LoadedMapUse::default());
    let after = room.run(&mut vo, SPLIT..2 * SPLIT);
    assert!(after.iter().all(|(s, _, _)| s.is_tracked()));
    assert!(vo.odometry.keyframes_added() > 0, "mapping went on");
    assert!(vo.odometry.map().next_keyframe_id().0 > keyframes as u64);
    let (e_before, e_after) = (
        rms(before.iter().map(|(_, _, e)| *e)),
        rms(after.iter().map(|(_, _, e)| *e)),
    );
    // One trajectory in one frame: the second run goes on where the first stopped.
    let seam = (after[0].1.translation.vector - before[SPLIT - 1].1.translation.vector).norm();
    let step = (room.sequence.pose(SPLIT).translation.vector
        - room.sequence.pose(SPLIT - 1).translation.vector)
        .norm();
    println!(
        "error before {e_before:.4} m, after {e_after:.4} m; seam {seam:.4} m (true step {step:.4} m)"
    );
    assert!(e_after < 0.02, "{e_after} m");
    assert!(
        (seam - step).abs() < 0.01,
        "seam {seam} m, true step {step} m"
    );
    let _ = std::fs::remove_file(path);
}
