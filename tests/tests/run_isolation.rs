//! A run owns its run id and its output folder while it lives, and nothing of a run is
//! left in `/dev/shm` or `/tmp/iceoryx2` however it ends: a second run on the same id
//! or folder is refused at start (the first one goes on undisturbed), a SIGKILLed
//! supervisor's files are removed by `gfsvo clean`, a stopped `gfsvo record` and a run
//! stopped right after it started leave nothing. Every check looks at its own run id
//! only: other pipelines may run on the machine meanwhile.
//!
//! Every run starts by sweeping the machine's dead runs, so the test that leaves a dead
//! run for `gfsvo clean` holds [`SWEEPS`] exclusively while the other tests of this file
//! start runs under its shared side.

mod common;

use common::{
    FRAMES, PoseWatch, assert_nothing_left, binaries, finish, gfsvo, out_dir, run_id, sequence,
    start,
};
use gfs_ipc::{IpcRun, RunId};
use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::{PoisonError, RwLock, RwLockReadGuard};
use std::time::{Duration, Instant};

/// Keeps the runs of the other tests (whose start sweeps dead runs) away from the dead
/// run that `gfsvo clean` must find.
static SWEEPS: RwLock<()> = RwLock::new(());

fn sweeping() -> RwLockReadGuard<'static, ()> {
    SWEEPS.read().unwrap_or_else(PoisonError::into_inner)
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

fn leftovers(id: &str) -> usize {
    IpcRun::new(RunId::new(id).unwrap())
        .unwrap()
        .leftovers()
        .len()
}

/// Waits until no process has `id` on its command line (stages die with the supervisor
/// through their parent-death signal, a moment after it).
fn await_no_process_of(id: &str) {
    let deadline = Instant::now() + Duration::from_secs(20);
    let needle = format!("={id}\0");
    while Instant::now() < deadline {
        let alive = std::fs::read_dir("/proc")
            .unwrap()
            .flatten()
            .filter_map(|e| std::fs::read(e.path().join("cmdline")).ok())
            .any(|c| text(&c).contains(&needle) || text(&c).contains(&format!("\0{id}\0")));
        if !alive {
            return;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn a_second_run_on_the_same_run_id_or_output_folder_is_refused() {
    let _sweeps = sweeping();
    let (id, out) = (run_id("own"), out_dir("own"));
    let mut child = start(binaries(), &id, &out, &[]);
    {
        let mut watch = PoseWatch::new(&id);
        assert!(
            watch.reach(10, &mut child),
            "the first run reached frame 10"
        );
    }
    let other_out = out_dir("own2");
    let _ = std::fs::remove_dir_all(&other_out);
    let seq = sequence().to_str().unwrap();
    let same_id = gfsvo(&[
        "run",
        seq,
        "--run-id",
        &id,
        "--out",
        other_out.to_str().unwrap(),
        "--frames",
        "5",
    ]);
    let stderr = text(&same_id.stderr);
    assert!(!same_id.status.success());
    assert!(
        stderr.contains(&format!("run id {id} is in use")),
        "{stderr}"
    );
    assert!(
        !other_out.join("trajectory.txt").exists(),
        "the refused run wrote nothing"
    );
    let other_id = run_id("own3");
    let same_out = gfsvo(&[
        "run",
        seq,
        "--run-id",
        &other_id,
        "--out",
        out.to_str().unwrap(),
        "--frames",
        "5",
    ]);
    let stderr = text(&same_out.stderr);
    assert!(!same_out.status.success());
    assert!(
        stderr.contains(&format!("output folder {} is in use", out.display())),
        "{stderr}"
    );
    let inline_same_out = gfsvo(&[
        "run",
        seq,
        "--mode",
        "inline",
        "--out",
        out.to_str().unwrap(),
        "--frames",
        "5",
    ]);
    assert!(!inline_same_out.status.success());
    let o = finish(child, &out, &id);
    assert!(o.success, "the first run went on: {}", o.stderr);
    assert_eq!(o.trajectory_lines, FRAMES);
    assert!(o.ate < 0.01, "ATE {}", o.ate);
    assert_nothing_left(&other_id);
}

#[test]
fn files_of_a_sigkilled_supervisor_are_removed_by_gfsvo_clean() {
    let _alone = SWEEPS.write().unwrap_or_else(PoisonError::into_inner);
    let (id, out) = (run_id("kill"), out_dir("kill"));
    let mut child = start(binaries(), &id, &out, &[]);
    {
        let mut watch = PoseWatch::new(&id);
        assert!(watch.reach(20, &mut child), "the run reached frame 20");
    }
    child.kill().unwrap();
    child.wait().unwrap();
    await_no_process_of(&id);
    let left = leftovers(&id);
    assert!(left > 0, "a SIGKILLed run leaves its files until cleaned");
    let clean = gfsvo(&["clean", "--verbose"]);
    let stdout = text(&clean.stdout);
    assert!(clean.status.success(), "{}", text(&clean.stderr));
    assert!(stdout.contains(&format!("removed run {id}")), "{stdout}");
    println!("SIGKILL of the supervisor left {left} files; gfsvo clean: {stdout}");
    assert_nothing_left(&id);
    // The id is free again, and a run on it is clean from the start.
    let again = gfsvo(&[
        "run",
        sequence().to_str().unwrap(),
        "--run-id",
        &id,
        "--out",
        out.to_str().unwrap(),
        "--frames",
        "5",
    ]);
    assert!(again.status.success(), "{}", text(&again.stderr));
    assert_nothing_left(&id);
}

#[test]
fn a_run_stopped_as_it_starts_leaves_nothing() {
    let _sweeps = sweeping();
    let (id, out) = (run_id("early"), out_dir("early"));
    let child = start(binaries(), &id, &out, &[]);
    let deadline = Instant::now() + Duration::from_secs(30);
    while !out.join("pids.json").exists() && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(1));
    }
    let pid = i32::try_from(child.id()).unwrap();
    // SAFETY: kill(2) has no memory effects.
    assert_eq!(unsafe { libc::kill(pid, libc::SIGTERM) }, 0);
    let o = finish(child, &out, &id);
    assert!(!o.success, "an interrupted run reports failure");
    assert!(o.stderr.contains("interrupted"), "{}", o.stderr);
}

#[test]
fn no_frame_to_run_is_refused_before_any_work() {
    let _sweeps = sweeping();
    let (id, out) = (run_id("zero"), out_dir("zero"));
    let o = gfsvo(&[
        "run",
        sequence().to_str().unwrap(),
        "--frames",
        "0",
        "--run-id",
        &id,
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(
        text(&o.stderr).contains("--frames 0"),
        "{}",
        text(&o.stderr)
    );
    assert_nothing_left(&id);
}

#[test]
fn a_stopped_recorder_leaves_nothing() {
    let _sweeps = sweeping();
    let (id, out) = (run_id("rec"), out_dir("rec"));
    let mut child = Command::new(binaries().join("gfsvo"))
        .args(["record", "--run-id", &id, "--out"])
        .arg(&out)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(30);
    while leftovers(&id) == 0 && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(5));
    }
    let pid = i32::try_from(child.id()).unwrap();
    // SAFETY: kill(2) has no memory effects.
    assert_eq!(unsafe { libc::kill(pid, libc::SIGINT) }, 0);
    let status = child.wait().unwrap();
    assert!(status.success());
    assert!(Path::new(&out).join("trajectory.txt").exists());
    assert_nothing_left(&id);
}
