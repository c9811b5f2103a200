//! Fault injection on the multi-process pipeline (`gfsvo run`, lockstep) over a
//! synthetic sequence: each stage SIGKILLed three times at random frames, SIGTERM to
//! the supervisor mid-run, and a stage that dies on every start. After each run: every
//! input frame has a pose, the ATE stays within 1.5x of the undisturbed run, the
//! supervisor restarted the stage each time, and nothing of the run is left (no
//! process, no iceoryx2 file or shared memory); with no frame past its deadline the
//! trajectory is even byte-identical to the undisturbed one. Also: lockstep, threads
//! and inline give the same trajectory.
//!
//! The test drives the real executables (`gfsvo`, `gfsvo-*`): it builds them once with
//! the cargo that runs it (a no-op when they are up to date).

use gfs_ipc::{IpcRun, Mode, RunId, TopicSubscriber, ipc, topics};
use gfs_pipeline::wire::WirePose;
use gfs_synth::{SplitMix64, SynthConfig, SynthSequence};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

const FRAMES: usize = 150;
const STAGES: [&str; 6] = ["source", "points", "lines", "planes", "tracker", "mapper"];

/// The folder holding `gfsvo` and the stage executables, built if needed.
fn binaries() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let exe = std::env::current_exe().unwrap();
        // <target>/release/deps/<test> -> <target>/release
        let dir = exe.parent().and_then(Path::parent).unwrap().to_path_buf();
        let target = dir.parent().unwrap();
        let workspace = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap();
        let mut build = Command::new(env!("CARGO"));
        build
            .args(["build", "--release", "--bins", "--manifest-path"])
            .arg(workspace.join("Cargo.toml"))
            .env("CARGO_TARGET_DIR", target);
        for package in ["gfsvo"].iter().chain(STAGES.iter()) {
            let name = if *package == "gfsvo" {
                "gfsvo".to_owned()
            } else {
                format!("gfsvo-{package}")
            };
            build.args(["-p", &name]);
        }
        let status = build.status().expect("cargo runs");
        assert!(status.success(), "building the executables failed");
        dir
    })
}

/// The synthetic sequence every run plays (rendered once per target folder).
fn sequence() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("synth_faults_{FRAMES}"));
        if !dir.join("associations.txt").is_file() {
            let config = SynthConfig {
                frames: FRAMES,
                ..SynthConfig::default()
            };
            SynthSequence::new(config).write_tum(&dir, |_| ()).unwrap();
        }
        dir
    })
}

struct Outcome {
    success: bool,
    ate: f64,
    degraded: u64,
    trajectory: String,
    restarts: BTreeMap<String, u64>,
    trajectory_lines: usize,
    stderr: String,
}

fn start(bin: &Path, run_id: &str, out: &Path, extra: &[&str]) -> Child {
    let _ = std::fs::remove_dir_all(out);
    std::fs::create_dir_all(out).unwrap();
    Command::new(bin.join("gfsvo"))
        .arg("run")
        .arg(sequence())
        .arg("--out")
        .arg(out)
        .args(["--run-id", run_id, "--json", "--log", "warn"])
        .args(extra)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

fn finish(child: Child, out: &Path, run_id: &str) -> Outcome {
    let output = child.wait_with_output().unwrap();
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    let json: serde_json::Value = stdout
        .lines()
        .last()
        .and_then(|l| serde_json::from_str(l).ok())
        .unwrap_or_default();
    let restarts = json["restarts"]
        .as_object()
        .map(|m| {
            m.iter()
                .map(|(k, v)| (k.clone(), v.as_u64().unwrap_or(0)))
                .collect()
        })
        .unwrap_or_default();
    let trajectory = std::fs::read_to_string(out.join("trajectory.txt")).unwrap_or_default();
    let trajectory_lines = trajectory.lines().filter(|l| !l.starts_with('#')).count();
    assert_nothing_left(run_id);
    Outcome {
        success: output.status.success(),
        ate: json["ate_rmse_m"].as_f64().unwrap_or(f64::INFINITY),
        degraded: json["status"]["degraded"].as_u64().unwrap_or(0),
        trajectory,
        restarts,
        trajectory_lines,
        stderr,
    }
}

/// No process of the run alive, no iceoryx2 file or shared memory of it.
fn assert_nothing_left(run_id: &str) {
    let needle = format!("--run-id\0{run_id}\0");
    let alive: Vec<String> = std::fs::read_dir("/proc")
        .unwrap()
        .flatten()
        .filter_map(|e| std::fs::read(e.path().join("cmdline")).ok())
        .map(|c| String::from_utf8_lossy(&c).into_owned())
        .filter(|c| c.contains(&needle))
        .collect();
    assert!(
        alive.is_empty(),
        "processes of run {run_id} alive: {alive:?}"
    );
    let run = IpcRun::new(RunId::new(run_id).unwrap()).unwrap();
    assert_eq!(
        run.leftovers(),
        Vec::<PathBuf>::new(),
        "files of run {run_id}"
    );
}

/// Watches the poses of a run from the test process.
struct PoseWatch {
    _node: iceoryx2::node::Node<ipc::Service>,
    poses: TopicSubscriber<ipc::Service, WirePose>,
    _run: IpcRun,
    last: Option<u64>,
}

impl PoseWatch {
    fn new(run_id: &str) -> Self {
        let run = IpcRun::new(RunId::new(run_id).unwrap()).unwrap();
        let node = run.node::<ipc::Service>("faulttest").unwrap();
        let poses = TopicSubscriber::create(
            &run,
            &node,
            topics::POSE.name,
            &topics::POSE.qos(Mode::Lockstep),
        )
        .unwrap();
        Self {
            _node: node,
            poses,
            _run: run,
            last: None,
        }
    }

    /// Waits until frame `id` has a pose (false if the run ended first).
    fn reach(&mut self, id: u64, child: &mut Child) -> bool {
        let deadline = Instant::now() + Duration::from_secs(120);
        while Instant::now() < deadline {
            while let Ok(Some(s)) = self.poses.receive() {
                if let Some(p) = s.payload().first() {
                    self.last = Some(self.last.map_or(p.frame_id, |l| l.max(p.frame_id)));
                }
            }
            if self.last.is_some_and(|l| l >= id) {
                return true;
            }
            if matches!(child.try_wait(), Ok(Some(_))) {
                return false;
            }
            let _ = self.poses.wait(Duration::from_millis(5));
        }
        false
    }
}

fn pid_of(out: &Path, stage: &str) -> Option<i32> {
    let text = std::fs::read_to_string(out.join("pids.json")).ok()?;
    let map: BTreeMap<String, i32> = serde_json::from_str(&text).ok()?;
    map.get(stage).copied()
}

/// Kills `stage` with SIGKILL when frames `at` are reached; returns the kills done.
fn kill_at(run_id: &str, out: &Path, stage: &str, at: &[u64], child: &mut Child) -> usize {
    let mut watch = PoseWatch::new(run_id);
    let mut kills = 0;
    for &frame in at {
        if !watch.reach(frame, child) {
            break;
        }
        let Some(pid) = pid_of(out, stage) else { break };
        // SAFETY: kill(2) has no memory effects.
        assert_eq!(unsafe { libc::kill(pid, libc::SIGKILL) }, 0, "kill {stage}");
        kills += 1;
        let deadline = Instant::now() + Duration::from_secs(30);
        while pid_of(out, stage) == Some(pid) && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(5));
        }
    }
    kills
}

/// Three frames in thirds of the sequence, from a seed.
fn random_frames(seed: u64) -> [u64; 3] {
    let mut rng = SplitMix64::new(seed);
    let third = (FRAMES / 3) as u64;
    [0, 1, 2].map(|k| k * third + 5 + rng.next_u64() % (third - 15))
}

fn run_id(tag: &str) -> String {
    format!("ft{tag}{}", std::process::id() % 100_000)
}

fn out_dir(tag: &str) -> PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("faults_{tag}"))
}

/// ATE and trajectory of the run without faults.
fn undisturbed() -> &'static (f64, String) {
    static RUN: OnceLock<(f64, String)> = OnceLock::new();
    RUN.get_or_init(|| {
        let (id, out) = (run_id("base"), out_dir("base"));
        let child = start(binaries(), &id, &out, &[]);
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
    // a restart changes nothing unless a frame went past its deadline (degraded).
    if o.degraded == 0 {
        assert!(
            o.trajectory == *reference,
            "{stage} restarts changed the trajectory"
        );
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
    assert_eq!(
        o.trajectory_lines, FRAMES,
        "the partial trajectory has every frame"
    );
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
