//! Timing of the pose-graph optimisation on essential-graph-like problems (printed,
//! nothing asserted): laps of a circle, odometry edges with drift, covisibility edges
//! to the next few nodes and loop edges to the previous lap, about 10 edges per node.
//! Run with `cargo run --release -p gfs-optim --example pose_graph_bench`.

#[path = "../tests/pose_graph_fixture/mod.rs"]
mod pose_graph_fixture;

use gfs_core::rng::SplitMix64;
use gfs_optim::PoseGraphConfig;
use pose_graph_fixture::{add_unbiased_edge, circle, odometry_chain, rmse};
use std::time::Instant;

/// Covisibility edges from each node to the next `COVISIBLE` nodes.
const COVISIBLE: usize = 4;
/// Nodes per lap of the circle.
const PER_LAP: usize = 200;

fn main() {
    for nodes in [200usize, 500, 1000, 2000] {
        let mut rng = SplitMix64::new(nodes as u64);
        let laps = nodes.div_ceil(PER_LAP);
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
        let edges = ring.graph.num_edges();
        let before = rmse(&ring);
        let start = Instant::now();
        let report = ring.graph.optimize(&PoseGraphConfig::default());
        let elapsed = start.elapsed();
        let after = rmse(&ring);
        match report {
            Ok(r) => println!(
                "{nodes:5} nodes {edges:6} edges ({:.1}/node): {:8.1} ms, {} iterations, \
                 {} solves, RMSE {before:.3} -> {after:.4} m",
                2.0 * edges as f64 / nodes as f64,
                elapsed.as_secs_f64() * 1e3,
                r.iterations,
                r.linear_solves
            ),
            Err(e) => println!("{nodes} nodes: {e}"),
        }
    }
}
