//! A stage process that owns a node, a subscriber and a publisher is stopped from the
//! outside, as the supervisor will do:
//! - SIGKILL: its resources stay behind until `IpcRun::cleanup_dead_nodes` removes them,
//!   and a restarted stage receives the frames it missed from the publisher's history;
//! - SIGTERM: a stage built on `IpcRun::stage_node` sees the termination request in its
//!   loop, drops its ports and exits 0 with nothing left to clean.
//!
//! Afterwards nothing of the run is left in /dev/shm or /tmp/iceoryx2. The test binary is
//! its own child: with `GFS_IPC_TEST_CHILD=<role>:<run-id>` set it plays the stage.

use std::io::{BufRead, BufReader};
use std::process::{Child, ChildStdout, Command, Stdio};
use std::time::{Duration, Instant};

use gfs_core::ids::FrameId;
use gfs_core::stamp::Stamp;
use gfs_ipc::{
    IpcRun, Mode, MsgHeader, RunId, Stage, TopicKind, TopicPublisher, TopicQos, TopicSubscriber,
    ipc,
};
use iceoryx2::node::NodeWaitFailure;

const CHILD_ENV: &str = "GFS_IPC_TEST_CHILD";
/// The child never outlives the test by more than this, even if the parent dies first.
const CHILD_LIFETIME: Duration = Duration::from_secs(30);

fn qos() -> TopicQos {
    TopicQos::new(Mode::Lockstep, TopicKind::Features)
}

/// The stage: subscribes to `frame`, publishes on `points`, says "ready", then either
/// sleeps until killed (`sleep`) or runs a stage loop until SIGTERM (`loop`).
fn child(role: &str, run_id: &str) {
    let run = IpcRun::new(RunId::new(run_id).expect("run id from parent")).expect("run");
    let node = match role {
        "loop" => run.stage_node::<ipc::Service>(Stage::Points),
        _ => run.node::<ipc::Service>("points"),
    }
    .expect("child node");
    let frames = TopicSubscriber::<ipc::Service, u32>::create(&run, &node, "frame", &qos())
        .expect("child subscriber");
    let publisher = TopicPublisher::<ipc::Service, u32>::create(&run, &node, "points", &qos(), 64)
        .expect("child publisher");
    publisher
        .publish_slice(&MsgHeader::new(FrameId(0), Stamp::default()), &[1, 2, 3])
        .expect("child publish");
    println!("ready");
    if role == "restart" {
        // A restarted stage: its history arrives once the publisher updates its
        // connections, without a wake-up, so poll (bounded).
        let mut ids = Vec::new();
        let start = Instant::now();
        while ids.len() < 2 && start.elapsed() < CHILD_LIFETIME {
            match frames.receive().expect("child receive") {
                Some(s) => ids.push(s.user_header().frame_id.to_string()),
                None => std::thread::sleep(Duration::from_millis(1)),
            }
        }
        println!("got {}", ids.join(","));
        return;
    }
    if role != "loop" {
        std::thread::sleep(CHILD_LIFETIME);
        return;
    }
    let start = Instant::now();
    while start.elapsed() < CHILD_LIFETIME {
        match node.wait(Duration::from_millis(5)) {
            Err(NodeWaitFailure::TerminationRequest) => return,
            Ok(()) | Err(NodeWaitFailure::Interrupt) => {}
        }
        while let Ok(Some(_)) = frames.receive() {}
    }
    std::process::exit(2);
}

/// Starts a stage child and waits for its "ready"; returns it with its stdout lines.
fn spawn_stage(run: &IpcRun, role: &str) -> (Child, std::io::Lines<BufReader<ChildStdout>>) {
    let mut stage = Command::new(std::env::current_exe().unwrap())
        .env(CHILD_ENV, format!("{role}:{}", run.run_id()))
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(stage.stdout.take().unwrap()).lines();
    let ready = lines.next().and_then(Result::ok).unwrap_or_default();
    assert_eq!(ready, "ready", "child stage did not start");
    (stage, lines)
}

/// (name, alive) of every node of the run, sorted.
fn nodes(run: &IpcRun) -> Vec<(String, bool)> {
    let mut v: Vec<(String, bool)> = run
        .nodes::<ipc::Service>()
        .unwrap()
        .into_iter()
        .map(|n| (n.name, n.alive))
        .collect();
    v.sort();
    v
}

fn sigkill_leaves_resources_until_cleanup() {
    let run = IpcRun::new(RunId::unique("sigkill").unwrap()).unwrap();
    {
        let node = run.node::<ipc::Service>("source").unwrap();
        let frames =
            TopicPublisher::<ipc::Service, u32>::create(&run, &node, "frame", &qos(), 64).unwrap();
        let (mut stage, _) = spawn_stage(&run, "sleep");
        // The child's subscriber holds a frame in its queue when it dies.
        let reached = frames
            .publish_slice(
                &MsgHeader::new(FrameId(1), Stamp::from_nanos(100_000_000)),
                &[7; 16],
            )
            .unwrap();
        assert_eq!(reached, 1);
        let points = |alive| ("points".to_string(), alive);
        let source = ("source".to_string(), true);
        assert_eq!(nodes(&run), vec![points(true), source.clone()]);

        stage.kill().unwrap(); // SIGKILL: no destructor runs in the child
        stage.wait().unwrap();
        assert_eq!(nodes(&run), vec![points(false), source.clone()]);
        let before = run.leftovers();

        let report = run.cleanup_dead_nodes::<ipc::Service>().unwrap();
        assert_eq!((report.cleaned, report.failed), (1, 0));
        assert_eq!(nodes(&run), vec![source]);
        let after = run.leftovers();
        let removed: Vec<_> = before.iter().filter(|p| !after.contains(p)).collect();
        // At least the node's files, its publisher's data segment, its connections and
        // its listener socket.
        assert!(removed.len() >= 6, "cleanup removed only {removed:?}");
        assert!(after.iter().all(|p| before.contains(p)));
        println!(
            "SIGKILL: dead node cleanup removed {} of {} files",
            removed.len(),
            before.len()
        );

        // The survivor keeps publishing; the dead subscriber is gone.
        let reached = frames
            .publish_slice(
                &MsgHeader::new(FrameId(2), Stamp::from_nanos(200_000_000)),
                &[8; 16],
            )
            .unwrap();
        assert_eq!(reached, 0);
        let report = run.cleanup_dead_nodes::<ipc::Service>().unwrap();
        assert_eq!((report.cleaned, report.failed), (0, 0));

        // The restarted stage gets the frames it missed from the publisher's history
        // (2 deep) once the idle publisher updates its connections.
        let (mut restarted, mut lines) = spawn_stage(&run, "restart");
        frames.update_connections().unwrap();
        let got = lines.next().and_then(Result::ok).unwrap_or_default();
        assert_eq!(got, "got 1,2");
        assert!(restarted.wait().unwrap().success());
        println!("SIGKILL: restarted stage received history frames 1 and 2");
    }
    let left = run.finish();
    assert!(
        left.is_empty(),
        "files of run {} left: {left:?}",
        run.run_id()
    );
}

fn sigterm_is_a_clean_exit() {
    let run = IpcRun::new(RunId::unique("sigterm").unwrap()).unwrap();
    {
        let node = run.node::<ipc::Service>("source").unwrap();
        let frames =
            TopicPublisher::<ipc::Service, u32>::create(&run, &node, "frame", &qos(), 64).unwrap();
        let (mut stage, _) = spawn_stage(&run, "loop");
        frames
            .publish_slice(
                &MsgHeader::new(FrameId(1), Stamp::from_nanos(100_000_000)),
                &[7; 16],
            )
            .unwrap();
        let pid = i32::try_from(stage.id()).unwrap();
        // SAFETY: sending a signal to our own child process by pid has no memory effects.
        assert_eq!(unsafe { libc::kill(pid, libc::SIGTERM) }, 0);
        let status = stage.wait().unwrap();
        assert!(status.success(), "stage exit status {status}");
        assert_eq!(nodes(&run), vec![("source".to_string(), true)]);
        let report = run.cleanup_dead_nodes::<ipc::Service>().unwrap();
        assert_eq!((report.cleaned, report.failed), (0, 0));
        println!("SIGTERM: stage exited cleanly, nothing to clean");
    }
    let left = run.finish();
    assert!(
        left.is_empty(),
        "files of run {} left: {left:?}",
        run.run_id()
    );
}

fn main() {
    if let Ok(spec) = std::env::var(CHILD_ENV) {
        let (role, run_id) = spec.split_once(':').expect("role:run-id");
        child(role, run_id);
        return;
    }
    sigkill_leaves_resources_until_cleanup();
    println!("test sigkill_leaves_resources_until_cleanup ... ok");
    sigterm_is_a_clean_exit();
    println!("test sigterm_is_a_clean_exit ... ok");
}
