//! Map files in the supervised pipeline (`gfsvo run --mode lockstep`, the stage
//! processes), on the synthetic room: the mapper saves the same file the inline
//! odometry saves; a run started on it (localising, from a pose hint, or extending it)
//! gives the inline run's trajectory byte for byte; a mapper or tracker killed while
//! localising comes back on the loaded map (no keyframe added, the same ATE within
//! 1 mm); a save request on the `save-map` topic and
//! SIGINT both write the map; a run started part-way into the sequence (`--start`)
//! localises in the map in every mode. On TUM fr1_rpy (skipped when the data is absent): the
//! pipeline localised in its own saved map, as docs/maps.md reports for inline.

mod common;

use common::{Outcome, binaries, finish, kill_at, out_dir, run_id, start, start_on};
use gfs_ipc::{
    IpcRun, MAX_VARIABLE_MESSAGE_BYTES, Mode, MsgHeader, RunId, TopicPublisher, TopicSubscriber,
    encode_message, ipc, topics,
};
use gfs_odometry::map_file::{MapCamera, load_map};
use gfs_pipeline::map_files::{SaveMapReply, SaveMapRequest};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Frames each run plays.
const FRAMES: &str = "80";

/// A run of `mode` over the synthetic sequence with `extra` switches, to the end.
fn run(tag: &str, mode: &str, extra: &[&str]) -> (Outcome, PathBuf) {
    let (id, out) = (run_id(tag), out_dir(&format!("map_{tag}")));
    let mut args = vec!["--mode", mode, "--frames", FRAMES];
    args.extend_from_slice(extra);
    let o = finish(start(binaries(), &id, &out, &args), &out, &id);
    assert!(o.success, "{tag}: {}", o.stderr);
    (o, out)
}

fn map_path(name: &str) -> PathBuf {
    out_dir("map_files").join(name)
}

/// The camera the synthetic sequence's config gives (its map files must match).
fn synthetic_camera() -> MapCamera {
    gfs_pipeline::Config::built_in("synthetic")
        .unwrap()
        .map_camera()
        .unwrap()
}

fn text(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap()
}

#[test]
fn the_pipeline_saves_and_starts_from_a_map_as_inline_does() {
    std::fs::create_dir_all(out_dir("map_files")).unwrap();
    let (inline_map, lockstep_map) = (map_path("inline.gfsmap"), map_path("lockstep.gfsmap"));
    let (mapped, _) = run(
        "mi",
        "inline",
        &["--save-map", inline_map.to_str().unwrap()],
    );
    run(
        "ml",
        "lockstep",
        &["--save-map", lockstep_map.to_str().unwrap()],
    );
    // The mapper stage writes the map the inline odometry writes, byte for byte.
    assert_eq!(
        std::fs::read(&inline_map).unwrap(),
        std::fs::read(&lockstep_map).unwrap()
    );
    let map = inline_map.to_str().unwrap();
    let hint = "0.01,0,0,0,0,0,1";
    let cases: [(&str, Vec<&str>); 3] = [
        ("l", vec!["--load-map", map, "--localize"]),
        (
            "h",
            vec!["--load-map", map, "--localize", "--initial-pose", hint],
        ),
        ("e", vec!["--load-map", map]),
    ];
    for (tag, extra) in cases {
        let (inline, inline_out) = run(&format!("{tag}i"), "inline", &extra);
        let (lockstep, lockstep_out) = run(&format!("{tag}l"), "lockstep", &extra);
        println!(
            "{extra:?}: ATE {:.4} m inline, {:.4} m lockstep (mapping run {:.4} m); \
             keyframes added {} / {}",
            inline.ate,
            lockstep.ate,
            mapped.ate,
            inline.json["keyframes_added"],
            lockstep.json["keyframes_added"]
        );
        assert_eq!(
            text(&lockstep_out.join("trajectory.txt")),
            text(&inline_out.join("trajectory.txt")),
            "{extra:?}"
        );
        assert_eq!(lockstep.predicted, 0, "{extra:?}");
        assert_eq!(
            lockstep.json["keyframes_added"], inline.json["keyframes_added"],
            "{extra:?}"
        );
        let added = lockstep.json["keyframes_added"].as_u64().unwrap();
        if tag == "e" {
            assert!(added > 0, "extending adds keyframes");
        } else {
            assert_eq!(added, 0, "{extra:?}");
            assert!(lockstep.ate <= mapped.ate + 1e-3, "{extra:?}");
        }
    }
}

#[test]
fn a_stage_killed_while_localising_comes_back_on_the_loaded_map() {
    std::fs::create_dir_all(out_dir("map_files")).unwrap();
    let path = map_path("kills.gfsmap");
    let (mapped, _) = run("km", "inline", &["--save-map", path.to_str().unwrap()]);
    let map = path.to_str().unwrap();
    let (undisturbed, _) = run("ku", "lockstep", &["--load-map", map, "--localize"]);
    for (tag, stage) in [("kt", "tracker"), ("kp", "mapper")] {
        let (id, out) = (run_id(tag), out_dir(&format!("map_{tag}")));
        let args = ["--mode", "lockstep", "--frames", FRAMES];
        let mut child = start(
            binaries(),
            &id,
            &out,
            &[&args[..], &["--load-map", map, "--localize"]].concat(),
        );
        let kills = kill_at(&id, &out, stage, &[20, 50], &mut child);
        let o = finish(child, &out, &id);
        assert!(o.success, "{stage}: {}", o.stderr);
        println!(
            "{stage} killed {kills} times: ATE {:.4} m (undisturbed {:.4} m, mapping run \
             {:.4} m), keyframes added {}, predicted frames {}",
            o.ate, undisturbed.ate, mapped.ate, o.json["keyframes_added"], o.predicted
        );
        assert_eq!(kills, 2, "{stage}");
        assert_eq!(o.restarts.get(stage), Some(&2), "{stage}");
        // Every frame has a pose from the tracker, none interpolated (the recorder's queue
        // outlasts the supervisor's restart of a stage).
        assert_eq!(o.trajectory_lines, 80, "{stage}");
        assert_eq!(o.predicted, 0, "{stage}");
        assert_eq!(o.json["keyframes_added"], 0, "{stage}: the map stays fixed");
        assert!(o.ate <= undisturbed.ate + 1e-3, "{stage}: {} m", o.ate);
    }
}

/// Asks the mapper of run `id` to save its map to `path`; its reply.
fn request_save(id: &str, path: &Path) -> SaveMapReply {
    let run = IpcRun::new(RunId::new(id).unwrap()).unwrap();
    let node = run.node::<ipc::Service>("savetest").unwrap();
    let qos = topics::SAVE_MAP.qos(Mode::Lockstep);
    let requests =
        TopicPublisher::<ipc::Service, u8>::create(&run, &node, topics::SAVE_MAP.name, &qos, 256)
            .unwrap();
    let replies = TopicSubscriber::<ipc::Service, u8>::create(
        &run,
        &node,
        topics::MAP_SAVED.name,
        &topics::MAP_SAVED.qos(Mode::Lockstep),
    )
    .unwrap();
    let request = SaveMapRequest {
        id: 7,
        path: path.to_owned(),
    };
    let mut bytes = Vec::new();
    encode_message(&request, &mut bytes).unwrap();
    let deadline = Instant::now() + Duration::from_secs(60);
    let mut sent = None::<Instant>;
    while Instant::now() < deadline {
        if sent.is_none_or(|t| t.elapsed() > Duration::from_secs(2)) {
            requests.update_connections().unwrap();
            if requests.subscriber_count() > 0 {
                requests
                    .publish_slice(&MsgHeader::default(), &bytes)
                    .unwrap();
                sent = Some(Instant::now());
            }
        }
        if let Some((_, reply)) = replies
            .receive_decoded::<SaveMapReply>(MAX_VARIABLE_MESSAGE_BYTES)
            .unwrap()
        {
            return reply;
        }
        let _ = replies.wait(Duration::from_millis(20));
    }
    panic!("no reply to the save request in 60 s");
}

#[test]
fn a_save_request_and_sigint_write_the_pipeline_map() {
    std::fs::create_dir_all(out_dir("map_files")).unwrap();
    let (asked, at_stop) = (map_path("asked.gfsmap"), map_path("sigint.gfsmap"));
    let _ = std::fs::remove_file(&at_stop);
    let (id, out) = (run_id("sv"), out_dir("map_sv"));
    let mut child = start(
        binaries(),
        &id,
        &out,
        &[
            "--mode",
            "lockstep",
            "--save-map",
            at_stop.to_str().unwrap(),
        ],
    );
    let mut watch = common::PoseWatch::new(&id);
    assert!(watch.reach(40, &mut child), "the run reaches frame 40");
    let reply = request_save(&id, &asked);
    assert_eq!((reply.id, &reply.path), (7, &asked));
    let bytes = reply.result.expect("the mapper saved");
    assert_eq!(std::fs::metadata(&asked).unwrap().len(), bytes);
    let camera = synthetic_camera();
    let early = load_map(&asked, &camera).expect("the requested map loads");
    assert!(watch.reach(90, &mut child), "the run reaches frame 90");
    drop(watch);
    let pid = i32::try_from(child.id()).unwrap();
    // SAFETY: kill(2) has no memory effects.
    assert_eq!(unsafe { libc::kill(pid, libc::SIGINT) }, 0);
    let o = finish(child, &out, &id);
    assert!(!o.success, "an interrupted run fails");
    let last = load_map(&at_stop, &camera).expect("the map saved at SIGINT loads");
    println!(
        "keyframes: {} in the map asked for at frame 40+, {} in the map saved at SIGINT",
        early.map.keyframe_count(),
        last.map.keyframe_count()
    );
    assert!(early.map.keyframe_count() >= 2);
    assert!(last.map.next_keyframe_id() > early.map.next_keyframe_id());
}

/// The built-in sequence mapped inline (80 frames) and saved, then localised in that map
/// from frame 30 on (`--start 30 --frames 50`) in every mode: every frame posed (none
/// predicted), no keyframe added, the poses in the mapping run's frame: RMS position
/// difference to its poses of the same frames <= 2 cm without any alignment.
#[test]
fn a_run_started_part_way_in_localises_in_every_mode() {
    const START: usize = 30;
    const PLAYED: usize = 50;
    std::fs::create_dir_all(out_dir("map_files")).unwrap();
    let path = map_path("started.gfsmap");
    let (mapped, mapped_out) = run("sm", "inline", &["--save-map", path.to_str().unwrap()]);
    let same_frames: String = text(&mapped_out.join("trajectory.txt"))
        .lines()
        .filter(|l| !l.starts_with('#'))
        .skip(START)
        .take(PLAYED)
        .map(|l| format!("{l}\n"))
        .collect();
    let (start_at, frames) = (START.to_string(), PLAYED.to_string());
    for (tag, mode) in [
        ("si", "inline"),
        ("sl", "lockstep"),
        ("st", "threads"),
        ("sr", "realtime"),
    ] {
        let (id, out) = (run_id(tag), out_dir(&format!("map_{tag}")));
        let mut args = vec!["--mode", mode, "--frames", &frames, "--start", &start_at];
        args.extend(["--load-map", path.to_str().unwrap(), "--localize"]);
        // Realtime at a rate a loaded machine keeps up with: a frame dropped is predicted.
        if mode == "realtime" {
            args.extend(["--max-rate", "5"]);
        }
        let o = finish(start(binaries(), &id, &out, &args), &out, &id);
        assert!(o.success, "{mode}: {}", o.stderr);
        let difference = rms_difference(&same_frames, &o.trajectory);
        println!(
            "{mode} --start {START}: {} poses, {} predicted, keyframes added {}, RMS \
             difference to the mapping run {difference:.4} m, ATE {:.4} m (mapping run \
             {:.4} m)",
            o.trajectory_lines, o.predicted, o.json["keyframes_added"], o.ate, mapped.ate
        );
        assert_eq!(o.trajectory_lines, PLAYED, "{mode}");
        assert_eq!(o.predicted, 0, "{mode}");
        assert_eq!(o.json["keyframes_added"], 0, "{mode}");
        assert!(difference <= 0.02, "{mode}: {difference} m");
    }
}

/// TUM fr1_rpy's first 300 frames mapped and saved by the pipeline, then localised in
/// the saved map from frame 0: every frame posed, no keyframe added, poses in the
/// mapping run's frame (RMS difference <= 2 cm without alignment) and an ATE no worse
/// than the mapping run's.
#[test]
fn tum_fr1_localised_in_the_pipeline_map() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/tum_fr1_rpy_head300");
    if !data.join("groundtruth.txt").is_file() {
        println!("skipped: {} is absent", data.display());
        return;
    }
    std::fs::create_dir_all(out_dir("map_files")).unwrap();
    let path = map_path("tum.gfsmap");
    let go = |tag: &str, extra: &[&str]| {
        let (id, out) = (run_id(tag), out_dir(&format!("map_{tag}")));
        let child = start_on(
            binaries(),
            &data,
            &id,
            &out,
            &[&["--mode", "lockstep"], extra].concat(),
        );
        let o = finish(child, &out, &id);
        assert!(o.success, "{tag}: {}", o.stderr);
        o
    };
    let mapped = go("tm", &["--save-map", path.to_str().unwrap()]);
    let localised = go("tl", &["--load-map", path.to_str().unwrap(), "--localize"]);
    let difference = rms_difference(&mapped.trajectory, &localised.trajectory);
    println!(
        "TUM fr1_rpy 300 frames, lockstep: mapping ATE {:.4} m ({} keyframes); localised \
         ATE {:.4} m, RMS difference {difference:.4} m, keyframes added {}, status {}",
        mapped.ate,
        mapped.json["keyframes"],
        localised.ate,
        localised.json["keyframes_added"],
        localised.json["status"]
    );
    assert_eq!(localised.trajectory_lines, 300);
    assert_eq!(localised.predicted, 0);
    assert_eq!(localised.json["keyframes_added"], 0);
    assert!(difference <= 0.02, "{difference} m");
    assert!(localised.ate <= mapped.ate + 1e-3, "{} m", localised.ate);
}

/// RMS position difference of two TUM trajectories, line by line.
fn rms_difference(a: &str, b: &str) -> f64 {
    let positions = |t: &str| -> Vec<[f64; 3]> {
        t.lines()
            .filter(|l| !l.starts_with('#'))
            .map(|l| {
                let v: Vec<f64> = l
                    .split_whitespace()
                    .filter_map(|x| x.parse().ok())
                    .collect();
                [v[1], v[2], v[3]]
            })
            .collect()
    };
    let (a, b) = (positions(a), positions(b));
    assert_eq!(a.len(), b.len());
    let sum: f64 = a
        .iter()
        .zip(&b)
        .map(|(p, q)| (0..3).map(|i| (p[i] - q[i]).powi(2)).sum::<f64>())
        .sum();
    (sum / a.len().max(1) as f64).sqrt()
}
