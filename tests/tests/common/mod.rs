//! What the end-to-end tests of the pipeline share: the executables (built once), the
//! synthetic sequence, starting a `gfsvo run` and reading its outcome, watching its
//! poses, and checking that nothing of a run is left. Each test binary uses a part.
#![allow(dead_code)]

use gfs_ipc::{IpcRun, Mode, RunId, TopicSubscriber, ipc, topics};
use gfs_pipeline::wire::WirePose;
use gfs_synth::{SynthConfig, SynthImu, SynthSequence};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

pub mod in_process;

pub const FRAMES: usize = 150;
pub const STAGES: [&str; 7] = [
    "source", "points", "lines", "planes", "tracker", "mapper", "loop",
];

/// The folder holding `gfsvo` and the stage executables, built if needed.
pub fn binaries() -> &'static Path {
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

/// The synthetic sequence every run plays (rendered once per target folder), with a
/// RealSense-like IMU at 200 Hz (`imu.txt`), whose samples go to the tracker with the
/// frames through every restart.
pub fn sequence() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("synth_faults_imu_{FRAMES}"));
        if !dir.join("associations.txt").is_file() {
            let config = SynthConfig {
                frames: FRAMES,
                imu: Some(SynthImu::realsense_like(200.0)),
                ..SynthConfig::default()
            };
            SynthSequence::new(config).write_tum(&dir, |_| ()).unwrap();
        }
        dir
    })
}

pub struct Outcome {
    pub success: bool,
    pub ate: f64,
    /// ATE of `odometry.txt`, when loop corrections made it differ from the trajectory.
    pub odometry_ate: Option<f64>,
    pub degraded: u64,
    pub predicted: u64,
    pub trajectory: String,
    pub restarts: BTreeMap<String, u64>,
    pub trajectory_lines: usize,
    pub stderr: String,
    /// The `--json` summary.
    pub json: serde_json::Value,
}

pub fn start(bin: &Path, run_id: &str, out: &Path, extra: &[&str]) -> Child {
    start_on(bin, sequence(), run_id, out, extra)
}

/// [`start`] on another dataset folder.
pub fn start_on(bin: &Path, dataset: &Path, run_id: &str, out: &Path, extra: &[&str]) -> Child {
    let _ = std::fs::remove_dir_all(out);
    std::fs::create_dir_all(out).unwrap();
    Command::new(bin.join("gfsvo"))
        .arg("run")
        .arg(dataset)
        .arg("--out")
        .arg(out)
        .args(["--run-id", run_id, "--json", "--log", "warn"])
        .args(extra)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

pub fn finish(child: Child, out: &Path, run_id: &str) -> Outcome {
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
        odometry_ate: json["odometry_ate_rmse_m"].as_f64(),
        degraded: json["status"]["degraded"].as_u64().unwrap_or(0),
        predicted: json["status"]["predicted"].as_u64().unwrap_or(0),
        trajectory,
        restarts,
        trajectory_lines,
        stderr,
        json,
    }
}

/// No process of the run alive, no iceoryx2 file or shared memory of it.
pub fn assert_nothing_left(run_id: &str) {
    let needles = [
        format!("--run-id\0{run_id}\0"),
        format!("--run-id={run_id}\0"),
    ];
    let alive: Vec<String> = std::fs::read_dir("/proc")
        .unwrap()
        .flatten()
        .filter_map(|e| std::fs::read(e.path().join("cmdline")).ok())
        .map(|c| String::from_utf8_lossy(&c).into_owned())
        .filter(|c| needles.iter().any(|n| c.contains(n.as_str())))
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
pub struct PoseWatch {
    _node: iceoryx2::node::Node<ipc::Service>,
    poses: TopicSubscriber<ipc::Service, WirePose>,
    _run: IpcRun,
    last: Option<u64>,
}

impl PoseWatch {
    pub fn new(run_id: &str) -> Self {
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
    pub fn reach(&mut self, id: u64, child: &mut Child) -> bool {
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

pub fn pid_of(out: &Path, stage: &str) -> Option<i32> {
    let text = std::fs::read_to_string(out.join("pids.json")).ok()?;
    let map: BTreeMap<String, i32> = serde_json::from_str(&text).ok()?;
    map.get(stage).copied()
}

pub fn run_id(tag: &str) -> String {
    format!("ft{tag}{}", std::process::id() % 100_000)
}

pub fn out_dir(tag: &str) -> PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("faults_{tag}"))
}

/// Runs `gfsvo` with `args` to the end.
pub fn gfsvo(args: &[&str]) -> std::process::Output {
    Command::new(binaries().join("gfsvo"))
        .args(args)
        .stdin(Stdio::null())
        .output()
        .unwrap()
}

/// Kills `stage` with SIGKILL when frames `at` are reached; returns the kills done.
pub fn kill_at(run_id: &str, out: &Path, stage: &str, at: &[u64], child: &mut Child) -> usize {
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
