//! Queue sizes per topic and mode: how many samples a subscriber buffers, how much
//! history a late or restarted subscriber receives, and how many ports may attach.
//!
//! Every process of a run derives the same [`TopicQos`] from the same (mode, kind), so
//! opening a service never fails on mismatched settings. Safe overflow is always on (a
//! full subscriber queue drops its oldest sample instead of blocking the publisher):
//! a publisher never waits on a dead or slow subscriber. Lockstep mode never overflows
//! because the source only publishes frame k+1 after the tracker finished frame k.

/// How the pipeline is paced (DESIGN.md "Modes").
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Mode {
    /// One frame in flight; reproducible. Queues keep every message.
    Lockstep,
    /// Stages overlap; a stage that falls behind takes the newest frame.
    Realtime,
}

/// What a topic carries; decides its queue sizes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TopicKind {
    /// Frame images (~2 MB per sample at 640x480 RGB-D): few samples in flight.
    Frame,
    /// Per-frame feature slices (points, lines, Manhattan axes): the tracker joins them
    /// by frame id, so a few frames are buffered.
    Features,
    /// Per-frame poses (a few hundred bytes each): every frame's is recorded, by a
    /// supervisor that drains its queue between its other chores. Cleaning up after a
    /// dead stage held it 110-190 ms (more on a loaded machine) while the other stages
    /// went on, and a queue of 4 lost 2-10 poses of 80 frames to a mapper restart.
    Poses,
    /// Rare variable-size bincode messages (keyframes, local-map snapshots):
    /// never dropped, and a restarted subscriber gets the latest ones back.
    Variable,
}

/// Queue sizes of one topic (iceoryx2 publish/subscribe service settings).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TopicQos {
    /// Samples the publisher keeps for subscribers that connect later
    /// (`history_size`); a restarted stage receives them on connection.
    pub history: usize,
    /// Samples a subscriber queue holds (`subscriber_max_buffer_size`).
    pub subscriber_buffer: usize,
    /// Samples a subscriber may hold while processing (`subscriber_max_borrowed_samples`).
    pub max_borrowed: usize,
    /// Publishers of the topic; one more than needed so a restarted publisher can attach
    /// before the dead one is cleaned up.
    pub max_publishers: usize,
    /// Subscribers of the topic, with the same restart slack.
    pub max_subscribers: usize,
    /// Nodes that may open the topic at once.
    pub max_nodes: usize,
}

/// Stages that may subscribe to one topic (points, lines, planes, tracker, mapper,
/// recorder) plus two restart slots.
const MAX_SUBSCRIBERS: usize = 8;
/// One publisher per topic plus one restart slot.
const MAX_PUBLISHERS: usize = 2;
/// Subscribers + publishers + slack for nodes that only look.
const MAX_NODES: usize = 16;

impl TopicQos {
    /// The settings of a `kind` topic in `mode`.
    ///
    /// iceoryx2 reserves shared memory for the worst case of every port that may attach
    /// (measured on the 1.54 MB frame topic: 216 samples in realtime, 288 in lockstep),
    /// but the reservation is sparse: tmpfs only backs the pages that are written, a few
    /// samples per topic (a whole run wrote under 10 MB of /dev/shm).
    pub fn new(mode: Mode, kind: TopicKind) -> Self {
        let (history, subscriber_buffer) = match (mode, kind) {
            // Lockstep: the frame k the tracker still needs plus one, for a restart.
            (Mode::Lockstep, TopicKind::Frame) => (2, 2),
            (Mode::Lockstep, TopicKind::Features) => (2, 4),
            (_, TopicKind::Poses) => (2, 256),
            // Realtime: newest frame wins; features keep a few frames for the join.
            (Mode::Realtime, TopicKind::Frame) => (1, 1),
            (Mode::Realtime, TopicKind::Features) => (2, 8),
            // At most one keyframe request (and its answer) in flight, plus a resend.
            (_, TopicKind::Variable) => (2, 4),
        };
        Self {
            history,
            subscriber_buffer,
            max_borrowed: 2,
            max_publishers: MAX_PUBLISHERS,
            max_subscribers: MAX_SUBSCRIBERS,
            max_nodes: MAX_NODES,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn history_reaches_restarted_subscribers() {
        // iceoryx2 delivers min(history, subscriber buffer) samples on connection.
        for mode in [Mode::Lockstep, Mode::Realtime] {
            for kind in [
                TopicKind::Frame,
                TopicKind::Features,
                TopicKind::Poses,
                TopicKind::Variable,
            ] {
                let q = TopicQos::new(mode, kind);
                assert!(q.history >= 1, "{mode:?} {kind:?}");
                assert!(q.subscriber_buffer >= 1);
                assert!(q.max_publishers >= 2 && q.max_subscribers >= 7);
            }
        }
        assert_eq!(
            TopicQos::new(Mode::Realtime, TopicKind::Frame).subscriber_buffer,
            1
        );
        assert_eq!(TopicQos::new(Mode::Lockstep, TopicKind::Frame).history, 2);
    }
}
