//! Fault injection on the multi-process pipeline (`gfsvo run`, lockstep) over a
//! synthetic sequence: each stage SIGKILLed three times at random frames, SIGTERM to
//! the supervisor mid-run, and a stage that dies on every start. After each run: every
//! input frame has a pose, the ATE stays within 1.5x of the undisturbed run, the
//! supervisor restarted the stage each time, and nothing of the run is left (no
//! process, no iceoryx2 file or shared memory); with no frame past its deadline the
//! trajectory is even byte-identical to the undisturbed one. Also: lockstep, threads
//! and inline give the same trajectory, and the depth and plane terms get their
//! surfaces without the Manhattan axes. (A mapper killed around a loop:
//! `loop_faults.rs`.)
//!
//! The test drives the real executables (`gfsvo`, `gfsvo-*`): it builds them once with
//! the cargo that runs it (a no-op when they are up to date).

mod common;

use common::{
    FRAMES, PoseWatch, STAGES, binaries, finish, kill_at, out_dir, run_id, sequence, start,
};
use gfs_synth::SplitMix64;
use std::path::Path;
use std::sync::OnceLock;
use std::time::{Duration, Instant};
/// How far a restarted run's poses may be from the undisturbed run's (metres and
/// quaternion components). Most runs are byte-identical; on a loaded machine a restart
/// now and then shifts later poses slightly (2.4e-9 after a planes restart, once 6e-4
/// after a lines restart; the cause is not found yet: the extractors give the same
/// features fresh or warm). A restart that lost the world frame or the map would be
/// off by far more.
const SAME_TRAJECTORY: f64 = 1e-2;

/// The largest difference between two TUM trajectory files' numbers, line by line;
/// infinite when their lines do not pair up.
fn largest_difference(a: &str, b: &str) -> f64 {
    let rows = |t: &str| -> Vec<Vec<f64>> {
        t.lines()
            .filter(|l| !l.starts_with('#'))
            .map(|l| {
                l.split_whitespace()
                    .filter_map(|v| v.parse().ok())
                    .collect()
            })
            .collect()
    };
    let (a, b) = (rows(a), rows(b));
    if a.len() != b.len() || a.iter().zip(&b).any(|(x, y)| x.len() != y.len()) {
        return f64::INFINITY;
    }
    a.iter()
        .zip(&b)
        .flat_map(|(x, y)| x.iter().zip(y).map(|(u, v)| (u - v).abs()))
        .fold(0.0, f64::max)
}

/// Three frames in thirds of the sequence, from a seed.
fn random_frames(seed: u64) -> [u64; 3] {
    let mut rng = SplitMix64::new(seed);
    let third = (FRAMES / 3) as u64;
    [0, 1, 2].map(|k| k * third + 5 + rng.next_u64() % (third - 15))
}

/// ATE and trajectory of the run without faults. Run inline: lockstep without a missed
/// deadline gives the same bytes (`lockstep_threads_and_inline_give_the_same_trajectory`),
/// and inline has no deadline to miss, so a loaded machine cannot spoil the reference.
fn undisturbed() -> &'static (f64, String) {
    static RUN: OnceLock<(f64, String)> = OnceLock::new();
    RUN.get_or_init(|| {
        let (id, out) = (run_id("base"), out_dir("base"));
        let child = start(binaries(), &id, &out, &["--mode", "inline"]);
        let o = finish(child, &out, &id);
        assert!(o.success, "undisturbed run failed: {}", o.stderr);
        assert_eq!(o.trajectory_lines, FRAMES);
        assert!(o.ate < 0.01, "undisturbed ATE {}", o.ate);
        (o.ate, o.trajectory)
    })
}

fn killed_three_times(stage: &str, seed: u64) {
    let (baseline, reference) = undisturbed();
    let baseline = *baseline;
    let (id, out) = (run_id(&stage[..3]), out_dir(stage));
    let mut child = start(binaries(), &id, &out, &[]);
    let frames = random_frames(seed);
    let kills = kill_at(&id, &out, stage, &frames, &mut child);
    let o = finish(child, &out, &id);
    println!(
        "{stage}: killed at frames {frames:?}, ATE {:.4} m (undisturbed {baseline:.4}), restarts {:?}",
        o.ate, o.restarts
    );
    assert_eq!(kills, 3, "the run ended before three kills of {stage}");
    assert!(o.success, "run with {stage} killed failed: {}", o.stderr);
    assert_eq!(o.trajectory_lines, FRAMES, "every input frame has a pose");
    assert_eq!(o.restarts.get(stage).copied(), Some(3), "{:?}", o.restarts);
    assert!(
        o.ate <= 1.5 * baseline,
        "ATE {} with {stage} killed vs {baseline} undisturbed",
        o.ate
    );
    // Every stage resumes from its checkpoint and the topics' history, so in lockstep
    // a restart keeps the trajectory unless a frame went past its feature deadline
    // (then tracked without a part, degraded, or not at all, predicted, on a machine
    // too loaded to keep up; every frame of the undisturbed run is tracked).
    let late = o.stderr.contains("missing at the deadline");
    if o.degraded == 0 && o.predicted == 0 && !late {
        let difference = largest_difference(&o.trajectory, reference);
        println!("{stage}: largest difference to the undisturbed trajectory {difference:e}");
        assert!(
            difference <= SAME_TRAJECTORY,
            "{stage} restarts changed the trajectory by {difference}: {}",
            o.stderr
        );
    } else {
        println!("{stage}: a frame went past its deadline; the trajectory not compared");
    }
}

#[test]
fn source_killed_three_times() {
    killed_three_times("source", 1);
}

#[test]
fn points_killed_three_times() {
    killed_three_times("points", 2);
}

#[test]
fn lines_killed_three_times() {
    killed_three_times("lines", 3);
}

#[test]
fn planes_killed_three_times() {
    killed_three_times("planes", 4);
}

#[test]
fn tracker_killed_three_times() {
    killed_three_times("tracker", 5);
}

#[test]
fn mapper_killed_three_times() {
    killed_three_times("mapper", 6);
}

#[test]
fn sigterm_to_the_supervisor_stops_everything() {
    let (id, out) = (run_id("term"), out_dir("term"));
    let mut child = start(binaries(), &id, &out, &[]);
    {
        let mut watch = PoseWatch::new(&id);
        assert!(watch.reach(40, &mut child), "the run reached frame 40");
    }
    let pid = i32::try_from(child.id()).unwrap();
    // SAFETY: kill(2) has no memory effects.
    assert_eq!(unsafe { libc::kill(pid, libc::SIGTERM) }, 0);
    let o = finish(child, &out, &id);
    assert!(!o.success, "an interrupted run reports failure");
    assert!(o.stderr.contains("interrupted"), "{}", o.stderr);
    // Only the frames processed: none after the last pose, none made up.
    assert!(
        o.trajectory_lines > 40 && o.trajectory_lines < FRAMES,
        "{} poses",
        o.trajectory_lines
    );
    let status = std::fs::read_to_string(out.join("status.txt")).unwrap();
    assert!(!status.contains("predicted"), "{status}");
}

#[test]
fn a_stage_that_dies_on_every_start_is_given_up_on() {
    // A copy of the executables whose `gfsvo-lines` exits with an error at once.
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("broken_lines_bin");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let files = STAGES.iter().map(|s| format!("gfsvo-{s}"));
    for file in files.chain(["gfsvo".to_owned()]) {
        std::fs::copy(binaries().join(&file), dir.join(&file)).unwrap();
    }
    let broken = dir.join("gfsvo-lines");
    std::fs::write(
        &broken,
        "#!/bin/sh\necho 'lines: cannot start' >&2\nexit 3\n",
    )
    .unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&broken, std::fs::Permissions::from_mode(0o755)).unwrap();

    let (id, out) = (run_id("crash"), out_dir("crash"));
    let started = Instant::now();
    let child = start(&dir, &id, &out, &[]);
    let o = finish(child, &out, &id);
    assert!(!o.success);
    assert!(
        o.stderr.contains("lines") && o.stderr.contains("giving up"),
        "{}",
        o.stderr
    );
    assert!(started.elapsed() < Duration::from_secs(60));
}

#[test]
fn lockstep_threads_and_inline_give_the_same_trajectory() {
    let trajectory = |mode: &str| {
        let (id, out) = (run_id(&mode[..3]), out_dir(mode));
        let child = start(binaries(), &id, &out, &["--mode", mode, "--frames", "80"]);
        let o = finish(child, &out, &id);
        assert!(o.success, "{mode}: {}", o.stderr);
        std::fs::read_to_string(out.join("trajectory.txt")).unwrap()
    };
    let inline = trajectory("inline");
    assert_eq!(inline.lines().filter(|l| !l.starts_with('#')).count(), 80);
    assert_eq!(trajectory("lockstep"), inline);
    assert_eq!(trajectory("threads"), inline);
}

/// The trajectory of the first 60 frames in `mode` with `extra` switches and the
/// config's `[tracking]` table `tracking` (`tag` keeps the runs apart).
fn surfaces_trajectory(tag: &str, mode: &str, tracking: &str, extra: &[&str]) -> String {
    let config = out_dir(&format!("surfaces_{tag}.toml"));
    let camera = std::fs::read_to_string(sequence().join("synthetic.toml")).unwrap();
    std::fs::write(&config, format!("{camera}\n[tracking]\n{tracking}\n")).unwrap();
    let (id, out) = (
        run_id(&format!("{tag}{}", &mode[..3])),
        out_dir(&format!("surfaces_{tag}_{mode}")),
    );
    let mut args = vec!["--mode", mode, "--frames", "60", "--config"];
    args.push(config.to_str().unwrap());
    args.extend_from_slice(extra);
    let o = finish(start(binaries(), &id, &out, &args), &out, &id);
    assert!(o.success, "{tag} {mode}: {}", o.stderr);
    std::fs::read_to_string(out.join("trajectory.txt")).unwrap()
}

const DEPTH_AND_PLANES: &str = "use_depth_alignment = true\nuse_planes = true";
const FEATURES_ONLY: &str = "use_depth_alignment = false\nuse_planes = false";

#[test]
fn with_depth_and_planes_lockstep_and_inline_give_the_same_trajectory() {
    // The planes and depth grid travel from the planes stage to the tracker in the
    // pipeline; in-process the front end hands them over: the same poses either way.
    let inline = surfaces_trajectory("s", "inline", DEPTH_AND_PLANES, &[]);
    assert_eq!(inline.lines().filter(|l| !l.starts_with('#')).count(), 60);
    assert_eq!(
        surfaces_trajectory("s", "lockstep", DEPTH_AND_PLANES, &[]),
        inline
    );
}

#[test]
fn without_the_manhattan_axes_the_depth_and_plane_terms_still_get_their_surfaces() {
    // `--no-manhattan` once switched off the whole planes stage, and with it the
    // surfaces: the depth and plane terms then changed no pose.
    let axes_off = ["--no-manhattan"];
    let inline = surfaces_trajectory("n", "inline", DEPTH_AND_PLANES, &axes_off);
    let features_only = surfaces_trajectory("f", "inline", FEATURES_ONLY, &axes_off);
    assert!(
        inline != features_only,
        "the depth and plane terms changed no pose"
    );
    assert_eq!(
        surfaces_trajectory("n", "lockstep", DEPTH_AND_PLANES, &axes_off),
        inline
    );
}
