//! Pose graphs with a known answer: laps of a circle driven by biased, noisy odometry,
//! shared by the pose-graph tests and the benchmark example.

use gfs_core::rng::SplitMix64;
use gfs_core::se3::exp;
use gfs_optim::PoseGraph;
use nalgebra::{Isometry3, Matrix6, Translation3, UnitQuaternion, Vector3, Vector6};

/// Sigma of the odometry's translation noise per edge, metres.
pub const SIGMA_T: f64 = 0.01;
/// Sigma of the odometry's rotation noise per edge, radians (0.2 degree).
pub const SIGMA_R: f64 = 0.2 * std::f64::consts::PI / 180.0;

/// A generated graph and its ground truth.
pub struct Ring {
    /// Ground-truth `world_from_camera` of every node.
    pub truth: Vec<Isometry3<f64>>,
    /// The graph, nodes at the dead-reckoned odometry, node 0 fixed at the truth.
    pub graph: PoseGraph,
}

/// Ground truth: `nodes` poses on `laps` turns of a 5 m circle, camera looking along
/// the tangent, with a little height and roll wobble.
pub fn circle(nodes: usize, laps: usize) -> Vec<Isometry3<f64>> {
    let per_lap = nodes.div_ceil(laps.max(1));
    (0..nodes)
        .map(|i| {
            let a = std::f64::consts::TAU * i as f64 / per_lap as f64;
            let position = Vector3::new(5.0 * a.cos(), 5.0 * a.sin(), 0.2 * (3.0 * a).sin());
            // Camera z along the tangent, y down (world z up), then a small roll.
            let forward = Vector3::new(-a.sin(), a.cos(), 0.0);
            let down = Vector3::new(0.0, 0.0, -1.0);
            let right = down.cross(&forward);
            let r = nalgebra::Matrix3::from_columns(&[right, down, forward]);
            let base = UnitQuaternion::from_matrix(&r);
            let roll = UnitQuaternion::from_scaled_axis(Vector3::z() * 0.05 * (5.0 * a).sin());
            Isometry3::from_parts(Translation3::from(position), base * roll)
        })
        .collect()
}

/// Information of an odometry-like edge with the module's sigmas.
pub fn information() -> Matrix6<f64> {
    let t = 1.0 / (SIGMA_T * SIGMA_T);
    let r = 1.0 / (SIGMA_R * SIGMA_R);
    Matrix6::from_diagonal(&Vector6::new(t, t, t, r, r, r))
}

/// `truth_i^-1 truth_j` corrupted by Gaussian noise of the module's sigmas and, when
/// `biased`, a systematic drift (0.5 % scale-like forward offset, 0.3 degree of yaw).
pub fn measure(
    truth: &[Isometry3<f64>],
    i: usize,
    j: usize,
    biased: bool,
    rng: &mut SplitMix64,
) -> Isometry3<f64> {
    let rel = truth[i].inverse() * truth[j];
    let noise = exp(&Vector6::new(
        SIGMA_T * rng.gaussian(),
        SIGMA_T * rng.gaussian(),
        SIGMA_T * rng.gaussian(),
        SIGMA_R * rng.gaussian(),
        SIGMA_R * rng.gaussian(),
        SIGMA_R * rng.gaussian(),
    ));
    let drift = if biased {
        let forward = 0.005 * rel.translation.vector.norm();
        exp(&Vector6::new(
            0.0,
            0.0,
            forward,
            0.0,
            0.3f64.to_radians(),
            0.0,
        ))
    } else {
        Isometry3::identity()
    };
    rel * drift * noise
}

/// A graph over `truth` whose nodes are dead-reckoned along the biased odometry edges
/// `(i, i + 1)`; node 0 is fixed at its true pose. Add the other edges afterwards.
pub fn odometry_chain(truth: Vec<Isometry3<f64>>, rng: &mut SplitMix64) -> Ring {
    let mut graph = PoseGraph::new();
    let mut pose = truth[0];
    graph.add_node(pose, true);
    let mut odometry = Vec::new();
    for i in 1..truth.len() {
        let z = measure(&truth, i - 1, i, true, rng);
        pose *= z;
        graph.add_node(pose, false);
        odometry.push(z);
    }
    for (i, z) in odometry.into_iter().enumerate() {
        graph
            .add_edge(i, i + 1, z, information())
            .expect("nodes exist");
    }
    Ring { truth, graph }
}

/// Adds an edge `(i, j)` measured like the odometry but without its drift (a
/// covisibility or loop edge from a fresh registration).
pub fn add_unbiased_edge(ring: &mut Ring, i: usize, j: usize, rng: &mut SplitMix64) {
    let z = measure(&ring.truth, i, j, false, rng);
    ring.graph
        .add_edge(i, j, z, information())
        .expect("nodes exist");
}

/// Root-mean-square translation error of the graph's poses against the truth, metres.
pub fn rmse(ring: &Ring) -> f64 {
    let sum: f64 = ring
        .graph
        .poses()
        .iter()
        .zip(&ring.truth)
        .map(|(p, t)| (p.translation.vector - t.translation.vector).norm_squared())
        .sum();
    (sum / ring.truth.len() as f64).sqrt()
}
