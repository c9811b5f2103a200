//! Quadtree distribution of corners (ORB-SLAM2 `DistributeOctTree`): the detection
//! area is split into nodes, every node holding more than one corner is divided in four
//! until there are as many nodes as features wanted, and each node keeps its strongest
//! corner. Features thereby cover the image instead of crowding in strong texture.
//!
//! Storage: the corners of a node are a contiguous range of one index array; dividing a
//! node partitions its range in place, so nothing is allocated per node or per frame.
//!
//! One deliberate change from ORB-SLAM2: it stops as soon as a round of divisions leaves
//! the node count unchanged (all corners of every node fell in one child), which can end
//! with far fewer features than wanted when corners cluster; here division goes on while
//! any node holds two corners (corner positions are distinct, so it terminates).

use crate::fast::{Corner, Rect};

#[derive(Clone, Copy, Debug)]
struct Node {
    x0: i32,
    x1: i32,
    y0: i32,
    y1: i32,
    /// Range of `Distributor::order` holding this node's corners.
    start: u32,
    end: u32,
}

impl Node {
    fn count(&self) -> u32 {
        self.end - self.start
    }
}

/// Reusable scratch of the distribution.
#[derive(Debug, Default)]
pub(crate) struct Distributor {
    nodes: Vec<Node>,
    order: Vec<u32>,
    expand: Vec<(u32, u32)>,
    winners: Vec<u32>,
}

impl Distributor {
    /// Indices into `corners` (all inside `area`) of at most `budget` corners spread over
    /// `area`, appended to `out`.
    pub(crate) fn distribute(
        &mut self,
        corners: &[Corner],
        area: Rect,
        budget: usize,
        out: &mut Vec<u32>,
    ) {
        self.nodes.clear();
        self.winners.clear();
        if corners.is_empty() || budget == 0 || area.x1 <= area.x0 || area.y1 <= area.y0 {
            return;
        }
        let width = (area.x1 - area.x0) as f32;
        let height = (area.y1 - area.y0) as f32;
        // Initial nodes: round(width / height) of them side by side along x, at least one
        // (ORB-SLAM2 divides by zero on a taller-than-wide area).
        let n_ini = ((width / height).round() as usize).max(1);
        let node_w = width / n_ini as f32;
        let ini_of =
            |c: &Corner| (((c.x as usize - area.x0) as f32 / node_w) as usize).min(n_ini - 1);
        self.order.clear();
        self.order.extend(0..corners.len() as u32);
        self.order
            .sort_unstable_by_key(|&i| (ini_of(&corners[i as usize]), i));
        let mut start = 0usize;
        for k in 0..n_ini {
            let mut end = start;
            while end < self.order.len() && ini_of(&corners[self.order[end] as usize]) == k {
                end += 1;
            }
            if end > start {
                self.nodes.push(Node {
                    x0: area.x0 as i32 + (node_w * k as f32) as i32,
                    x1: if k + 1 == n_ini {
                        area.x1 as i32
                    } else {
                        area.x0 as i32 + (node_w * (k + 1) as f32) as i32
                    },
                    y0: area.y0 as i32,
                    y1: area.y1 as i32,
                    start: start as u32,
                    end: end as u32,
                });
            }
            start = end;
        }

        // Coarse rounds: divide every node with two or more corners.
        loop {
            let before = self.nodes.len();
            for i in 0..before {
                if self.nodes[i].count() > 1 {
                    self.divide(i, corners);
                }
            }
            let expandable = self.nodes.iter().filter(|n| n.count() > 1).count();
            if self.nodes.len() >= budget || expandable == 0 {
                break;
            }
            if self.nodes.len() + 3 * expandable > budget {
                // The next full round would overshoot: divide the most crowded nodes
                // first and stop at the budget.
                self.fine_rounds(corners, budget);
                break;
            }
        }

        for n in &self.nodes {
            let range = &self.order[n.start as usize..n.end as usize];
            let mut best = range[0];
            for &i in &range[1..] {
                if corners[i as usize].score > corners[best as usize].score {
                    best = i;
                }
            }
            self.winners.push(best);
        }
        if self.winners.len() > budget {
            self.winners
                .sort_unstable_by_key(|&i| (std::cmp::Reverse(corners[i as usize].score), i));
            self.winners.truncate(budget);
        }
        out.extend_from_slice(&self.winners);
    }

    fn fine_rounds(&mut self, corners: &[Corner], budget: usize) {
        while self.nodes.len() < budget {
            self.expand.clear();
            for (i, n) in self.nodes.iter().enumerate() {
                if n.count() > 1 {
                    self.expand.push((n.count(), i as u32));
                }
            }
            if self.expand.is_empty() {
                return;
            }
            self.expand
                .sort_unstable_by_key(|&(count, i)| (std::cmp::Reverse(count), i));
            for k in 0..self.expand.len() {
                let i = self.expand[k].1 as usize;
                self.divide(i, corners);
                if self.nodes.len() >= budget {
                    return;
                }
            }
        }
    }

    /// Divides node `i` in four (halves rounded up, as ORB-SLAM2): the first non-empty
    /// child replaces it, the other non-empty children are appended.
    fn divide(&mut self, i: usize, corners: &[Corner]) {
        let n = self.nodes[i];
        let mx = n.x0 + (n.x1 - n.x0 + 1) / 2;
        let my = n.y0 + (n.y1 - n.y0 + 1) / 2;
        let range = &mut self.order[n.start as usize..n.end as usize];
        let top = partition(range, |k| (corners[k as usize].y as i32) < my);
        let (upper, lower) = range.split_at_mut(top);
        let left_top = partition(upper, |k| (corners[k as usize].x as i32) < mx);
        let left_bottom = partition(lower, |k| (corners[k as usize].x as i32) < mx);
        let s = n.start;
        let cuts = [
            s,
            s + left_top as u32,
            s + top as u32,
            s + (top + left_bottom) as u32,
            n.end,
        ];
        let boxes = [
            (n.x0, mx, n.y0, my),
            (mx, n.x1, n.y0, my),
            (n.x0, mx, my, n.y1),
            (mx, n.x1, my, n.y1),
        ];
        let mut replaced = false;
        for (c, &(x0, x1, y0, y1)) in boxes.iter().enumerate() {
            let (start, end) = (cuts[c], cuts[c + 1]);
            if end == start {
                continue;
            }
            let child = Node {
                x0,
                x1,
                y0,
                y1,
                start,
                end,
            };
            if replaced {
                self.nodes.push(child);
            } else {
                self.nodes[i] = child;
                replaced = true;
            }
        }
    }
}

/// Moves the elements satisfying `pred` to the front; returns how many there are.
fn partition(v: &mut [u32], pred: impl Fn(u32) -> bool) -> usize {
    let mut front = 0;
    for j in 0..v.len() {
        if pred(v[j]) {
            v.swap(front, j);
            front += 1;
        }
    }
    front
}

#[cfg(test)]
mod tests {
    use super::*;

    fn corner(x: u32, y: u32, score: u8) -> Corner {
        Corner { x, y, score }
    }

    #[test]
    fn a_dense_cluster_does_not_take_the_whole_budget() {
        // 400 strong corners packed in a 20x20 block at the top left, 12 weak ones spread
        // over the rest of a 300x300 area: with a budget of 16, all 12 isolated corners
        // survive and the cluster gets the remaining nodes.
        let mut corners = Vec::new();
        for y in 0..20 {
            for x in 0..20 {
                corners.push(corner(20 + x, 20 + y, 100 + (x + y) as u8));
            }
        }
        let lonely = [
            (150, 30),
            (250, 30),
            (30, 150),
            (150, 150),
            (250, 150),
            (30, 250),
            (150, 250),
            (250, 250),
            (100, 200),
            (200, 100),
            (280, 200),
            (200, 280),
        ];
        for &(x, y) in &lonely {
            corners.push(corner(x, y, 10));
        }
        let area = Rect {
            x0: 10,
            x1: 310,
            y0: 10,
            y1: 310,
        };
        let mut d = Distributor::default();
        let mut out = Vec::new();
        d.distribute(&corners, area, 16, &mut out);
        assert_eq!(out.len(), 16);
        let kept_lonely = out
            .iter()
            .filter(|&&i| corners[i as usize].score == 10)
            .count();
        assert_eq!(kept_lonely, 12);
        // Every node keeps its strongest corner: the cluster's picks are local maxima of
        // the score ramp, i.e. the largest score is among them.
        assert!(out.iter().any(|&i| corners[i as usize].score == 138));
    }

    #[test]
    fn budget_larger_than_corners_keeps_them_all_once() {
        let corners: Vec<Corner> = (0..50)
            .map(|i| corner(10 + i * 3, 10 + (i * 7) % 40, 30))
            .collect();
        let area = Rect {
            x0: 0,
            x1: 200,
            y0: 0,
            y1: 60,
        };
        let mut d = Distributor::default();
        let mut out = Vec::new();
        d.distribute(&corners, area, 500, &mut out);
        out.sort_unstable();
        assert_eq!(out, (0..50).collect::<Vec<u32>>());
        out.clear();
        d.distribute(&[], area, 500, &mut out);
        assert!(out.is_empty());
    }
}
