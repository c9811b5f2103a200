//! Hung stages: each stage in turn is stopped with SIGSTOP in the middle of a lockstep
//! run whose `[pipeline] hang_timeout_ms` is 2.5 s. The supervisor sees that the stage
//! publishes nothing while its input waits, kills it as hung and restarts it; the run
//! ends with a pose for every frame and nothing of it left in `/dev/shm` or
//! `/tmp/iceoryx2`.

mod common;

use common::{PoseWatch, STAGES, binaries, finish, out_dir, pid_of, run_id, sequence, start};
use std::path::PathBuf;
use std::time::{Duration, Instant};

const FRAMES: usize = 60;

/// The sequence's own config with a short hang timeout (above the feature deadline).
fn config() -> PathBuf {
    let path = out_dir("hang_config.toml");
    let own = std::fs::read_to_string(sequence().join("synthetic.toml")).unwrap();
    let pipeline = "[pipeline]\nlockstep_feature_deadline_ms = 2000\nhang_timeout_ms = 2500\n";
    std::fs::write(&path, format!("{own}\n{pipeline}")).unwrap();
    path
}

fn stopped_stage_is_restarted(stage: &str) {
    let (id, out) = (
        run_id(&format!("hang{}", &stage[..3])),
        out_dir(&format!("hang_{stage}")),
    );
    let config = config();
    let frames = FRAMES.to_string();
    let args = ["--config", config.to_str().unwrap(), "--frames", &frames];
    let mut child = start(binaries(), &id, &out, &args);
    let reached = PoseWatch::new(&id).reach(20, &mut child);
    if !reached {
        let o = finish(child, &out, &id);
        panic!("the run ended before frame 20: {}", o.stderr);
    }
    let stopped = {
        let pid = pid_of(&out, stage).expect("pids.json names the stage");
        // SAFETY: kill(2) has no memory effects.
        assert_eq!(unsafe { libc::kill(pid, libc::SIGSTOP) }, 0);
        Instant::now()
    };
    let o = finish(child, &out, &id);
    println!(
        "{stage}: stopped at frame 20, run ended {:.1} s later, restarts {:?}, ATE {:.4} m",
        stopped.elapsed().as_secs_f64(),
        o.restarts,
        o.ate
    );
    assert!(o.success, "run with {stage} stopped failed: {}", o.stderr);
    assert!(o.stderr.contains("killing it as hung"), "{}", o.stderr);
    assert!(
        o.restarts.get(stage).copied().unwrap_or(0) >= 1,
        "{:?}",
        o.restarts
    );
    assert_eq!(o.trajectory_lines, FRAMES, "every input frame has a pose");
    assert!(o.ate < 0.01, "ATE {}", o.ate);
    assert!(stopped.elapsed() < Duration::from_secs(120));
}

#[test]
fn a_stopped_stage_is_killed_as_hung_and_restarted() {
    // One after the other: six runs at once on a small machine could starve a stage
    // for longer than the short hang timeout.
    // Not the loop stage: the mapper goes on without its verdict after a deadline, so a
    // stopped loop stage holds nothing up (it is restarted when it dies).
    for stage in STAGES.into_iter().filter(|s| *s != "loop") {
        stopped_stage_is_restarted(stage);
    }
}
