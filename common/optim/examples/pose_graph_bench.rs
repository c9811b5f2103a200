//! Timing of the pose-graph optimisation on essential-graph-like problems (printed,
//! nothing asserted): laps of a circle, odometry edges with drift, covisibility edges
//! to the next few nodes and loop edges to the previous lap, about 10 edges per node.
//! Times are the thread's CPU time. Run with `cargo run --release -p gfs-optim --example pose_graph_bench`.

#[path = "../tests/pose_graph_fixture/mod.rs"]
mod pose_graph_fixture;

use gfs_core::rng::SplitMix64;
use gfs_optim::PoseGraphConfig;
use pose_graph_fixture::{add_unbiased_edge, circle, odometry_chain, rmse};

/// Covisibility edges from each node to the next `COVISIBLE` nodes.
const COVISIBLE: usize = 4;
/// Nodes per lap of the circle.
const PER_LAP: usize = 200;

/// CPU time of this thread, milliseconds: the machine the benchmark runs on may be
/// shared, and CPU time is what a dedicated core would take.
fn cpu_ms() -> f64 {
    let mut t = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `t` is a valid, writable timespec for the duration of the call.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut t) };
    if rc != 0 {
        return 0.0;
    }
    t.tv_sec as f64 * 1e3 + t.tv_nsec as f64 * 1e-6
}

fn main() {
    for nodes in [200usize, 500, 1000, 2000] {
        let mut rng = SplitMix64::new(nodes as u64);
        let laps = nodes.div_ceil(PER_LAP);
        let build_start = cpu_ms();
        let mut ring = odometry_chain(circle(nodes, laps), &mut rng);
        for i in 0..nodes {
            for k in 2..=COVISIBLE + 1 {
                if i + k < nodes {
                    add_unbiased_edge(&mut ring, i, i + k, &mut rng);
                }
            }
            // The same place one lap before, and its two neighbours.
            if i > PER_LAP && i % 2 == 0 {
                for back in [PER_LAP - 1, PER_LAP, PER_LAP + 1] {
                    add_unbiased_edge(&mut ring, i - back, i, &mut rng);
                }
            }
        }
        if laps == 1 {
            add_unbiased_edge(&mut ring, nodes - 1, 0, &mut rng);
        }
        let build = cpu_ms() - build_start;
        let edges = ring.graph.num_edges();
        let before = rmse(&ring);
        let initial = ring.graph.poses().to_vec();
        let start = cpu_ms();
        let report = ring.graph.optimize(&PoseGraphConfig::default());
        let elapsed = cpu_ms() - start;
        let after = rmse(&ring);
        // Again from the same start: the structure and its analysis are reused.
        for (node, pose) in initial.into_iter().enumerate() {
            ring.graph.set_pose(node, pose);
        }
        let start = cpu_ms();
        let again = ring.graph.optimize(&PoseGraphConfig::default());
        let reused = cpu_ms() - start;
        match (report, again) {
            (Ok(r), Ok(_)) => println!(
                "{nodes:5} nodes {edges:6} edges ({:.1}/node): {:7.1} ms CPU ({:7.1} ms with the \
                 analysis reused), {} iterations, {} solves, RMSE {before:.3} -> {after:.4} m; \
                 graph built in {build:.1} ms",
                2.0 * edges as f64 / nodes as f64,
                elapsed,
                reused,
                r.iterations,
                r.linear_solves
            ),
            (Err(e), _) | (_, Err(e)) => println!("{nodes} nodes: {e}"),
        }
    }
}
