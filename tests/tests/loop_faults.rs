//! Fault injection on a run that closes a loop (slow: renders two laps of the synthetic
//! room, 721 frames, once per target folder, and runs the lockstep pipeline twice).
//! Loop closing lives in the mapper process, so a mapper killed three times around the
//! loop must still close it from its checkpoint. A binary of its own, so that its load
//! does not overlap the timing-sensitive runs of `pipeline_faults.rs`.

mod common;

use common::{binaries, finish, kill_at, out_dir, run_id};
use std::path::Path;
use std::sync::OnceLock;
/// Two laps of the synthetic room (the loop the odometry closes after one lap), rendered
/// once per target folder.
fn loop_sequence() -> &'static Path {
    static DIR: OnceLock<std::path::PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("synth_faults_loop_721");
        if !dir.join("associations.txt").is_file() {
            let config = gfs_synth::SynthConfig {
                trajectory: gfs_synth::TrajectoryKind::Loop,
                frames: 721,
                ..gfs_synth::SynthConfig::default()
            };
            gfs_synth::SynthSequence::new(config)
                .write_tum(&dir, |_| ())
                .unwrap();
        }
        dir
    })
}

/// The mapper killed before the loop, about when it closes and after it: the tracker
/// still takes a correction in (odometry.txt then differs from trajectory.txt) and the
/// trajectory beats the run without loop closing.
#[test]
fn mapper_killed_around_a_loop_still_closes_it() {
    let dataset = loop_sequence();
    let (id, out) = (run_id("nolc"), out_dir("loop_off"));
    let child = common::start_on(binaries(), dataset, &id, &out, &["--no-loop-closing"]);
    let off = finish(child, &out, &id);
    assert!(
        off.success,
        "run without loop closing failed: {}",
        off.stderr
    );
    let (id, out) = (run_id("lkill"), out_dir("loop_killed"));
    let mut child = common::start_on(binaries(), dataset, &id, &out, &[]);
    let kills = kill_at(&id, &out, "mapper", &[200, 365, 550], &mut child);
    let o = finish(child, &out, &id);
    println!(
        "mapper killed around the loop: ATE {:.4} m (odometry {:?}), without loop closing \
         {:.4} m, restarts {:?}",
        o.ate, o.odometry_ate, off.ate, o.restarts
    );
    assert_eq!(kills, 3);
    assert!(o.success, "{}", o.stderr);
    assert_eq!(o.trajectory_lines, 721);
    assert_eq!(o.restarts.get("mapper").copied(), Some(3));
    assert!(
        o.odometry_ate.is_some(),
        "no loop correction reached the tracker"
    );
    assert!(
        o.ate < off.ate,
        "{} against {} without loop closing",
        o.ate,
        off.ate
    );
}
