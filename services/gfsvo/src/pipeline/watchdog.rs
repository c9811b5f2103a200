//! Hung stages: a stage whose input waits (its upstream published a frame it has not
//! answered) while it publishes nothing for `timeout` is taken for hung (SIGSTOP, a
//! deadlock, an endless loop) and killed, so that the supervisor restarts it as a dead
//! one. Read from the progress board the stages write; a stage waiting for a stage that
//! is itself overdue is not blamed.

use gfs_ipc::{Mode, Stage};
use gfs_pipeline::progress::{ProgressBoard, StageProgress};
use std::time::{Duration, Instant};

/// Watches the board of a run of `total` frames (`None`: a live source, a camera, whose
/// pauses are not hangs).
pub struct Watchdog {
    board: ProgressBoard,
    timeout: Duration,
    total: Option<u64>,
    mode: Mode,
    /// Per stage: its `made` counter when last seen, and since when it stands still
    /// with input waiting.
    still: [(u64, Option<Instant>); Stage::COUNT],
}

impl Watchdog {
    /// A watchdog on `board`.
    pub fn new(board: ProgressBoard, timeout: Duration, total: Option<usize>, mode: Mode) -> Self {
        Self {
            board,
            timeout,
            total: total.map(|t| t as u64),
            mode,
            still: [(0, None); Stage::COUNT],
        }
    }

    /// The stages overdue now (each reported once; it is watched afresh after).
    pub fn overdue(&mut self) -> Vec<(Stage, Duration)> {
        let p = Stage::ALL.map(|s| self.board.read(s));
        let waiting = waiting(&p, self.total, self.mode);
        let now = Instant::now();
        let mut out = Vec::new();
        for stage in Stage::ALL {
            let i = stage.index();
            let (made, since) = &mut self.still[i];
            if *made != p[i].made || !waiting[i] {
                *made = p[i].made;
                *since = None;
                continue;
            }
            let started = *since.get_or_insert(now);
            if now.duration_since(started) > self.timeout {
                out.push((stage, now.duration_since(started)));
                *since = None;
            }
        }
        // A stage waiting on an overdue mapper is not hung itself.
        if out.iter().any(|(s, _)| *s == Stage::Mapper) {
            out.retain(|(s, _)| *s != Stage::Tracker);
        }
        out
    }
}

/// Which stages have input waiting, from what every stage has published (frame + 1).
fn waiting(
    p: &[StageProgress; Stage::COUNT],
    total: Option<u64>,
    mode: Mode,
) -> [bool; Stage::COUNT] {
    let made = |s: Stage| p[s.index()].made;
    let source = made(Stage::Source);
    let features = made(Stage::Points)
        .max(made(Stage::Lines))
        .max(made(Stage::Planes));
    let tracker = made(Stage::Tracker);
    let mapper_waits = p[Stage::Tracker.index()].requested > made(Stage::Mapper);
    Stage::ALL.map(|stage| match stage {
        // Lockstep: the next frame is due once the last one has its pose.
        Stage::Source => {
            total.is_some_and(|t| source < t) && (mode == Mode::Realtime || tracker >= source)
        }
        Stage::Points | Stage::Lines | Stage::Planes => source > made(stage),
        Stage::Tracker => features > tracker && !mapper_waits,
        Stage::Mapper => mapper_waits,
        // The mapper never waits on it for long (a deadline): a dead one is restarted.
        Stage::Loop => false,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn progress(made: [u64; Stage::COUNT], requested: u64) -> [StageProgress; Stage::COUNT] {
        let mut p = [StageProgress::default(); Stage::COUNT];
        for (slot, m) in p.iter_mut().zip(made) {
            slot.made = m;
        }
        p[Stage::Tracker.index()].requested = requested;
        p
    }

    #[test]
    fn only_a_stage_with_input_waiting_is_waiting() {
        // source 5 frames out, points done, lines at 3, planes done, tracker at 4.
        let p = progress([5, 5, 3, 5, 4, 0, 0], 0);
        let w = waiting(&p, Some(10), Mode::Lockstep);
        assert_eq!(w, [false, false, true, false, true, false, false]);
        // Everything posed: the source is due (lockstep), nobody else.
        let p = progress([5, 5, 5, 5, 5, 2, 2], 2);
        assert_eq!(
            waiting(&p, Some(10), Mode::Lockstep),
            [true, false, false, false, false, false, false]
        );
        // The last frame posed: nothing is due.
        let p = progress([10, 10, 10, 10, 10, 2, 2], 2);
        assert_eq!(waiting(&p, Some(10), Mode::Lockstep), [false; Stage::COUNT]);
        // A live camera that pauses is not a hung source.
        assert!(!waiting(&p, None, Mode::Realtime)[Stage::Source.index()]);
        // A keyframe waits for the mapper: the tracker is not blamed.
        let p = progress([6, 6, 6, 6, 5, 2, 0], 6);
        assert_eq!(
            waiting(&p, Some(10), Mode::Lockstep),
            [false, false, false, false, false, true, false]
        );
    }
}
