//! Rate limiting of warnings about a stream: a sensor that goes bad repeats its fault
//! at its rate (hundreds a second for an IMU); the log says the first at once and then
//! at most one per period, with how many it held back.

use std::time::{Duration, Instant};

/// At most one warning per period.
#[derive(Clone, Debug)]
pub struct Throttle {
    period: Duration,
    last: Option<Instant>,
    held: usize,
}

impl Throttle {
    /// One warning per `period`.
    pub fn new(period: Duration) -> Self {
        Self {
            period,
            last: None,
            held: 0,
        }
    }

    /// `Some(held back since the last one)` when a warning may be said now; counts it
    /// as held back otherwise.
    pub fn admit(&mut self) -> Option<usize> {
        self.admit_at(Instant::now())
    }

    fn admit_at(&mut self, now: Instant) -> Option<usize> {
        if self
            .last
            .is_some_and(|last| now.duration_since(last) < self.period)
        {
            self.held += 1;
            return None;
        }
        self.last = Some(now);
        Some(std::mem::take(&mut self.held))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_warning_per_period_with_the_count_held_back() {
        let mut t = Throttle::new(Duration::from_secs(1));
        let start = Instant::now();
        let at = |ms| start + Duration::from_millis(ms);
        let said: Vec<Option<usize>> = [0, 5, 10, 999, 1000, 1500, 2100]
            .into_iter()
            .map(|ms| t.admit_at(at(ms)))
            .collect();
        assert_eq!(said, [Some(0), None, None, None, Some(3), None, Some(1)]);
    }
}
