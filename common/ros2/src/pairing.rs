//! Approximate-time pairing of colour and depth by stamp (message_filters'
//! ApproximateTime for two topics, simplified): a colour image takes the depth image
//! nearest in time within the slop, decided once a depth at or after its stamp arrived
//! (no later depth can be nearer); a colour with none in the slop is dropped, and so is
//! a colour stamped at or before the last one paired (a repeated or backwards stamp
//! would give two poses for one instant, or poses going back in time).

use std::collections::VecDeque;

/// What the pairer decided about the oldest colour image.
#[derive(Debug, PartialEq)]
pub enum Paired<C, D> {
    /// A colour image and its depth.
    Pair(C, D),
    /// A colour image with no depth within the slop, by stamp (ns).
    ColourWithoutDepth(i64),
    /// A colour image stamped `stamp` (ns), not after the last one paired, `last`: dropped.
    NotAfter {
        /// Its stamp, ns.
        stamp: i64,
        /// The stamp of the last colour image paired, ns.
        last: i64,
    },
}

/// Queues of colour and depth messages waiting for their partner.
pub struct Pairer<C, D> {
    slop_ns: i64,
    capacity: usize,
    colour: VecDeque<(i64, C)>,
    depth: VecDeque<(i64, D)>,
    last_paired: Option<i64>,
}

impl<C, D> Pairer<C, D> {
    /// Pairs within `slop_s` seconds, holding at most `capacity` messages per topic.
    pub fn new(slop_s: f64, capacity: usize) -> Self {
        Self {
            slop_ns: (slop_s * 1e9).round() as i64,
            capacity: capacity.max(1),
            colour: VecDeque::new(),
            depth: VecDeque::new(),
            last_paired: None,
        }
    }

    /// Starts the stamps over from `stamp_ns` (a camera restarted: its clock went back):
    /// colour images from `stamp_ns` on pair again, and depth images stamped after it
    /// (from before the restart) are forgotten.
    pub fn restart(&mut self, stamp_ns: i64) {
        self.last_paired = None;
        let newest = stamp_ns + self.slop_ns;
        self.depth.retain(|(t, _)| *t <= newest);
    }

    /// Queues a colour image stamped `stamp_ns`.
    pub fn push_colour(&mut self, stamp_ns: i64, colour: C) {
        self.colour.push_back((stamp_ns, colour));
    }

    /// Queues a depth image stamped `stamp_ns` (the oldest goes when the queue is full).
    pub fn push_depth(&mut self, stamp_ns: i64, depth: D) {
        if self.depth.len() >= self.capacity {
            self.depth.pop_front();
        }
        self.depth.push_back((stamp_ns, depth));
    }

    /// The next decision, if one can be made now.
    pub fn decide_next(&mut self) -> Option<Paired<C, D>> {
        self.decide(false)
    }

    /// The next decision with what is queued (at the end of a bag: no more depth comes).
    pub fn flush(&mut self) -> Option<Paired<C, D>> {
        self.decide(true)
    }

    fn decide(&mut self, force: bool) -> Option<Paired<C, D>> {
        let &(stamp, _) = self.colour.front()?;
        let newest_depth = self.depth.back().map(|d| d.0);
        let decided =
            force || newest_depth.is_some_and(|t| t >= stamp) || self.colour.len() > self.capacity;
        if !decided {
            return None;
        }
        let best = self
            .depth
            .iter()
            .enumerate()
            .min_by_key(|(_, (t, _))| (t - stamp).abs())
            .filter(|(_, (t, _))| (t - stamp).abs() <= self.slop_ns)
            .map(|(i, _)| i);
        let (_, colour) = self.colour.pop_front()?;
        if let Some(last) = self.last_paired.filter(|&last| stamp <= last) {
            return Some(Paired::NotAfter { stamp, last });
        }
        match best {
            Some(i) => {
                // Depth older than the match cannot pair with a later colour image.
                self.depth.drain(..i);
                let (_, depth) = self.depth.pop_front()?;
                self.last_paired = Some(stamp);
                Some(Paired::Pair(colour, depth))
            }
            None => Some(Paired::ColourWithoutDepth(stamp)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: i64 = 1_000_000;

    #[test]
    fn colour_takes_the_nearest_depth_within_the_slop() {
        let mut p = Pairer::new(0.02, 8);
        p.push_colour(100 * MS, "c100");
        p.push_depth(90 * MS, "d90");
        assert_eq!(p.decide_next(), None, "a later depth could be nearer");
        p.push_depth(103 * MS, "d103");
        assert_eq!(p.decide_next(), Some(Paired::Pair("c100", "d103")));
        p.push_colour(133 * MS, "c133");
        p.push_depth(137 * MS, "d137");
        assert_eq!(p.decide_next(), Some(Paired::Pair("c133", "d137")));
        assert_eq!(p.decide_next(), None);
    }

    #[test]
    fn colour_without_depth_in_the_slop_is_reported_by_stamp() {
        let mut p = Pairer::new(0.01, 8);
        p.push_colour(100 * MS, 1);
        p.push_depth(150 * MS, 2);
        assert_eq!(p.decide_next(), Some(Paired::ColourWithoutDepth(100 * MS)));
        p.push_colour(152 * MS, 3);
        assert_eq!(p.decide_next(), None);
        p.push_depth(160 * MS, 4);
        assert_eq!(p.decide_next(), Some(Paired::Pair(3, 2)));
    }

    #[test]
    fn colour_images_without_any_depth_are_dropped_once_the_queue_is_full() {
        let mut p = Pairer::<i32, i32>::new(0.01, 2);
        for k in 0..3 {
            p.push_colour(k * 33 * MS, k as i32);
        }
        assert_eq!(p.decide_next(), Some(Paired::ColourWithoutDepth(0)));
        assert_eq!(p.decide_next(), None);
    }

    #[test]
    fn repeated_and_backwards_stamps_are_dropped_until_a_restart() {
        let mut p = Pairer::new(0.01, 8);
        p.push_colour(100 * MS, "c100");
        p.push_depth(100 * MS, "d100");
        assert_eq!(p.decide_next(), Some(Paired::Pair("c100", "d100")));
        p.push_colour(100 * MS, "again");
        p.push_depth(101 * MS, "d101");
        let not_after = Paired::NotAfter {
            stamp: 100 * MS,
            last: 100 * MS,
        };
        assert_eq!(p.decide_next(), Some(not_after));
        p.push_colour(50 * MS, "back");
        assert_eq!(
            p.decide_next(),
            Some(Paired::NotAfter {
                stamp: 50 * MS,
                last: 100 * MS
            })
        );
        p.push_colour(133 * MS, "c133");
        p.push_depth(133 * MS, "d133");
        assert_eq!(p.decide_next(), Some(Paired::Pair("c133", "d133")));
        // The camera restarts its clock at 5 ms: pairs from there on.
        p.restart(5 * MS);
        p.push_colour(5 * MS, "c5");
        p.push_depth(5 * MS, "d5");
        assert_eq!(p.decide_next(), Some(Paired::Pair("c5", "d5")));
    }
}
