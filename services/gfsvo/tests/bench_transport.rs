//! `gfsvo bench transport` end to end: the executable starts its own subscriber process,
//! times a few frames and leaves no iceoryx2 files behind.

use std::process::Command;

#[test]
fn transport_bench_prints_both_strategies() {
    let out = Command::new(env!("CARGO_BIN_EXE_gfsvo"))
        .args(["bench", "transport", "--frames", "30", "--warmup", "3"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains("(2.46 MB: gray u8 + depth f32 + rgb), 30 frames after 3 warm-up"));
    for strategy in ["event", "spin"] {
        assert!(text.contains(&format!("subscriber waits by {strategy} (µs):")));
    }
    // Four rows per strategy, each with four numbers (median, p90, p99, max) in order.
    let rows: Vec<Vec<f64>> = text
        .lines()
        .filter(|l| l.contains("send -> ") || l.contains("copy into") || l.contains("loan+"))
        .map(|l| {
            l.split_whitespace()
                .filter_map(|w| w.parse().ok())
                .collect()
        })
        .collect();
    assert_eq!(rows.len(), 8, "{text}");
    for row in &rows {
        assert_eq!(row.len(), 4, "{text}");
        assert!(row.windows(2).all(|w| w[0] <= w[1]), "{row:?}");
    }
}
