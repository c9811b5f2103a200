//! A stage process is killed with SIGKILL while it owns a node, a subscriber and a
//! publisher; its resources stay behind until `IpcRun::cleanup_dead_nodes` removes them,
//! and at the end of the run nothing of it is left in /dev/shm or /tmp/iceoryx2.
//!
//! The test binary is its own child: with `GFS_IPC_TEST_CHILD=<run-id>` set it plays the
//! stage (creates its ports, says "ready", then sleeps until killed).

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::Duration;

use gfs_core::ids::FrameId;
use gfs_ipc::ipc;
use gfs_ipc::{
    IpcRun, Mode, MsgHeader, RunId, TopicKind, TopicPublisher, TopicQos, TopicSubscriber,
};

const CHILD_ENV: &str = "GFS_IPC_TEST_CHILD";
/// The child never outlives the test by more than this, even if the parent dies first.
const CHILD_LIFETIME: Duration = Duration::from_secs(30);

fn qos() -> TopicQos {
    TopicQos::new(Mode::Lockstep, TopicKind::Features)
}

fn child(run_id: &str) {
    let run = IpcRun::new(RunId::new(run_id).expect("run id from parent")).expect("run");
    let node = run.node::<ipc::Service>("points").expect("child node");
    let _sub = TopicSubscriber::<ipc::Service, u32>::create(&run, &node, "frame", &qos())
        .expect("child subscriber");
    let publisher = TopicPublisher::<ipc::Service, u32>::create(&run, &node, "points", &qos(), 64)
        .expect("child publisher");
    publisher
        .publish_slice(&MsgHeader::new(FrameId(0), 0.0), &[1, 2, 3])
        .expect("child publish");
    println!("ready");
    std::thread::sleep(CHILD_LIFETIME);
}

fn parent() {
    let run = IpcRun::new(RunId::unique("dead-node").unwrap()).unwrap();
    {
        let node = run.node::<ipc::Service>("source").unwrap();
        let frames =
            TopicPublisher::<ipc::Service, u32>::create(&run, &node, "frame", &qos(), 64).unwrap();
        let exe = std::env::current_exe().unwrap();
        let mut stage = Command::new(exe)
            .env(CHILD_ENV, run.run_id().as_str())
            .stdout(Stdio::piped())
            .spawn()
            .unwrap();
        let mut line = String::new();
        BufReader::new(stage.stdout.take().unwrap())
            .read_line(&mut line)
            .unwrap();
        assert_eq!(line.trim(), "ready", "child stage did not start");

        // The child's subscriber holds a frame in its queue when it dies.
        let reached = frames
            .publish_slice(&MsgHeader::new(FrameId(1), 0.1), &[7; 16])
            .unwrap();
        assert_eq!(reached, 1);
        let alive = |run: &IpcRun| {
            let mut v: Vec<(String, bool)> = run
                .nodes::<ipc::Service>()
                .unwrap()
                .into_iter()
                .map(|n| (n.name, n.alive))
                .collect();
            v.sort();
            v
        };
        let points = |alive| ("points".to_string(), alive);
        let source = ("source".to_string(), true);
        assert_eq!(alive(&run), vec![points(true), source.clone()]);

        stage.kill().unwrap(); // SIGKILL: no destructor runs in the child
        stage.wait().unwrap();
        assert_eq!(alive(&run), vec![points(false), source.clone()]);
        let before = run.leftovers();

        let report = run.cleanup_dead_nodes::<ipc::Service>().unwrap();
        assert_eq!((report.cleaned, report.failed), (1, 0));
        assert_eq!(alive(&run), vec![source]);
        let after = run.leftovers();
        let removed: Vec<_> = before.iter().filter(|p| !after.contains(p)).collect();
        // The child's node files, its publisher's data segment and its two connections.
        assert!(removed.len() >= 4, "cleanup removed only {removed:?}");
        assert!(after.iter().all(|p| before.contains(p)));
        println!(
            "dead node cleanup removed {} of {} files",
            removed.len(),
            before.len()
        );

        // The survivor keeps publishing; the dead subscriber is gone.
        let reached = frames
            .publish_slice(&MsgHeader::new(FrameId(2), 0.2), &[8; 16])
            .unwrap();
        assert_eq!(reached, 0);
        // A second cleanup finds nothing to do.
        let report = run.cleanup_dead_nodes::<ipc::Service>().unwrap();
        assert_eq!((report.cleaned, report.failed), (0, 0));
    }
    let left = run.finish();
    assert!(
        left.is_empty(),
        "files of run {} left: {left:?}",
        run.run_id()
    );
    println!("test dead_node_cleanup ... ok");
}

fn main() {
    match std::env::var(CHILD_ENV) {
        Ok(run_id) => child(&run_id),
        Err(_) => parent(),
    }
}
