//! Monotonic clock stamps that compare across processes.
//!
//! `std::time::Instant` is CLOCK_MONOTONIC on Linux but cannot be read as a number, so it
//! cannot travel in a message. CLOCK_MONOTONIC itself is one system-wide clock: a stamp
//! taken in the source process and one taken in the tracker process subtract to the real
//! time between them (it does not jump with NTP or the wall clock; it does not count
//! suspend time, which is what a pipeline profile wants).

/// Nanoseconds of CLOCK_MONOTONIC (system-wide, comparable between processes of the
/// same boot). Never 0 in practice, so 0 means "not stamped" in [`crate::StageStamp`].
pub fn monotonic_ns() -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; CLOCK_MONOTONIC is always supported on
    // Linux, so the call cannot fail (EINVAL/EFAULT are impossible with these arguments).
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    debug_assert_eq!(rc, 0, "clock_gettime(CLOCK_MONOTONIC) failed");
    // tv_sec and tv_nsec are non-negative for CLOCK_MONOTONIC.
    (ts.tv_sec as u64) * 1_000_000_000 + ts.tv_nsec as u64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn monotonic_never_goes_back_and_agrees_with_instant() {
        let t0 = std::time::Instant::now();
        let a = monotonic_ns();
        std::thread::sleep(std::time::Duration::from_millis(2));
        let b = monotonic_ns();
        let elapsed = t0.elapsed().as_nanos() as u64;
        assert!(a > 0);
        assert!(
            b >= a + 2_000_000,
            "slept 2 ms but clock advanced {} ns",
            b - a
        );
        // Both read CLOCK_MONOTONIC: the stamp difference cannot exceed the Instant span.
        assert!(
            b - a <= elapsed,
            "{} ns > Instant span {} ns",
            b - a,
            elapsed
        );
    }
}
