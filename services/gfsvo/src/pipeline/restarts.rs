//! When to stop restarting a stage: more than `max` deaths within a sliding window.

use super::children::ChildError;
use gfs_ipc::Stage;
use std::collections::VecDeque;
use std::time::{Duration, Instant};

/// Deaths per stage, and the limit.
#[derive(Debug)]
pub struct RestartPolicy {
    max: usize,
    window: Duration,
    recent: [VecDeque<Instant>; Stage::COUNT],
    total: [u32; Stage::COUNT],
}

impl RestartPolicy {
    /// At most `max` restarts of one stage within `window`.
    pub fn new(max: u32, window: Duration) -> Self {
        Self {
            max: max as usize,
            window,
            recent: Default::default(),
            total: [0; Stage::COUNT],
        }
    }

    /// Records a death of `stage` (`how`: exit status or reason).
    ///
    /// # Errors
    /// [`ChildError::GaveUp`] when this death exceeds the limit.
    pub fn record(&mut self, stage: Stage, how: &str) -> Result<(), ChildError> {
        let now = Instant::now();
        let recent = &mut self.recent[stage.index()];
        while recent
            .front()
            .is_some_and(|t| now.duration_since(*t) > self.window)
        {
            recent.pop_front();
        }
        recent.push_back(now);
        self.total[stage.index()] += 1;
        if recent.len() > self.max {
            return Err(ChildError::GaveUp {
                stage: stage.name(),
                count: recent.len(),
                window_s: self.window.as_secs(),
                last: how.to_owned(),
            });
        }
        Ok(())
    }

    /// Restarts of `stage` over the run.
    pub fn total(&self, stage: Stage) -> u32 {
        self.total[stage.index()]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gives_up_after_max_deaths_in_the_window() {
        let mut p = RestartPolicy::new(2, Duration::from_secs(60));
        assert!(p.record(Stage::Lines, "killed").is_ok());
        assert!(p.record(Stage::Lines, "killed").is_ok());
        assert!(p.record(Stage::Points, "exit 1").is_ok());
        let e = p.record(Stage::Lines, "exit 1").unwrap_err().to_string();
        assert!(e.contains("lines") && e.contains("3 times"), "{e}");
        assert_eq!((p.total(Stage::Lines), p.total(Stage::Points)), (3, 1));
    }
}
