//! The loop's pose graph over every keyframe of the map (SE(3), ORB-SLAM2's essential
//! graph without its scale), optimised with the old side of the loop held. It reads the
//! map only: the corrected poses go into a [`super::LoopCorrection`], applied to the
//! map (possibly a newer one, in the loop stage) by [`super::apply_correction`].
//!
//! Edges, each measuring `i_from_j` as the map had it before the correction:
//! - the chain of keyframes in id order (the spanning tree of a map grown one keyframe
//!   after the other);
//! - strong covisibility: pairs sharing at least `STRONG_COVISIBILITY` landmarks;
//! - the loop: the candidate to the current keyframe and to the current keyframe's
//!   connected neighbours, measured from the verified pose (the neighbours moved rigidly
//!   with the current keyframe).
//!
//! Every edge has the same information (ORB-SLAM2 weighs its essential graph the same
//! way): the chain and the covisibility edges hold the shape of each side, the loop
//! edges pull the current side onto the old one, and the error is spread along the loop.

use super::verify::LoopMatch;
use crate::map::Map;
use gfs_core::ids::KeyFrameId;
use gfs_optim::{PoseGraph, PoseGraphConfig, PoseGraphError};
use nalgebra::{Isometry3, Matrix6};
use std::collections::HashMap;

/// Landmarks shared for a covisibility edge (ORB-SLAM2's essential graph: 100).
const STRONG_COVISIBILITY: u32 = 100;

/// Optimises the keyframe poses of `map` for the verified loop `found` of keyframe
/// `current`. Returns the optimised `world_from_camera` of every keyframe, in id order.
///
/// # Errors
/// [`PoseGraphError`] when the graph could not be optimised.
pub fn optimise_loop(
    map: &Map,
    current: KeyFrameId,
    found: &LoopMatch,
) -> Result<Vec<(KeyFrameId, Isometry3<f64>)>, PoseGraphError> {
    let ids = map.keyframe_ids();
    let old: Vec<Isometry3<f64>> = ids
        .iter()
        .filter_map(|k| map.keyframe(*k).map(|k| k.world_from_camera()))
        .collect();
    let node: HashMap<KeyFrameId, usize> = ids.iter().enumerate().map(|(n, k)| (*k, n)).collect();
    let (Some(&cur), Some(&cand)) = (node.get(&current), node.get(&found.candidate)) else {
        return Err(PoseGraphError::MissingNode {
            from: current.0 as usize,
            to: found.candidate.0 as usize,
            nodes: ids.len(),
        });
    };
    // The current side moves rigidly with the current keyframe to start with.
    let corrected_current = found.camera_from_world.inverse();
    let new_from_old = corrected_current * old[cur].inverse();
    let current_side: Vec<usize> = std::iter::once(cur)
        .chain(
            map.connected(current)
                .into_iter()
                .filter_map(|(k, _)| node.get(&k).copied()),
        )
        .filter(|n| *n != cand)
        .collect();
    let mut graph = PoseGraph::new();
    for (n, pose) in old.iter().enumerate() {
        let start = if current_side.contains(&n) {
            new_from_old * pose
        } else {
            *pose
        };
        graph.add_node(start, n == cand || n == 0);
    }
    let information = Matrix6::identity();
    for n in 1..old.len() {
        graph.add_edge(n - 1, n, old[n - 1].inverse() * old[n], information)?;
    }
    for (a, kf) in ids.iter().enumerate() {
        for (other, _) in map.covisible(*kf, STRONG_COVISIBILITY) {
            if let Some(&b) = node.get(&other)
                && b > a + 1
            {
                graph.add_edge(a, b, old[a].inverse() * old[b], information)?;
            }
        }
    }
    for &n in &current_side {
        let corrected = new_from_old * old[n];
        graph.add_edge(cand, n, old[cand].inverse() * corrected, information)?;
    }
    graph.optimize(&PoseGraphConfig::default())?;
    Ok(ids
        .iter()
        .enumerate()
        .map(|(n, kf)| (*kf, *graph.pose(n)))
        .collect())
}
