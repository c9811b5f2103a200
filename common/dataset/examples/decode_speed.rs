//! Time of decoding one frame (colour PNG/JPEG + 16-bit depth + undistortion + gray):
//! median and 90th percentile over the frames of a dataset, on one thread, then the
//! throughput of the read-ahead iterator. Besides wall-clock time it prints the thread's
//! CPU time per frame (Linux `/proc/thread-self/schedstat`), which stays meaningful on a
//! loaded machine.
//!
//! ```text
//! cargo run --release -p gfs-dataset --example decode_speed -- DATASET_DIR configs/tum1.toml [FRAMES]
//! ```

use gfs_core::camera::{Camera, CameraConfig};
use gfs_dataset::{DepthConfig, Sequence};
use std::time::Instant;

/// The tables of a config file this example needs (others are ignored).
#[derive(serde::Deserialize)]
struct Config {
    camera: CameraConfig,
    #[serde(default)]
    depth: DepthConfig,
}

/// Nanoseconds this thread has run on a CPU, when the kernel tells.
fn thread_cpu_ns() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    text.split_whitespace().next()?.parse().ok()
}

/// Median and 90th percentile of `v` (sorted in place).
fn median_p90(v: &mut [f64]) -> (f64, f64) {
    v.sort_by(f64::total_cmp);
    let pick = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    (pick(0.5), pick(0.9))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 {
        return Err("usage: decode_speed DATASET_DIR CONFIG.toml [FRAMES]".into());
    }
    let config: Config = toml::from_str(&std::fs::read_to_string(&args[2])?)?;
    let camera = Camera::from_config(&config.camera)?;
    let t_open = Instant::now();
    let seq = Sequence::open(std::path::Path::new(&args[1]), &camera, &config.depth)?;
    let open_ms = t_open.elapsed().as_secs_f64() * 1e3;
    let frames = args
        .get(3)
        .map_or(Ok(seq.len()), |s| s.parse())?
        .min(seq.len());

    if frames == 0 {
        return Err("no frames to time".into());
    }
    let mut wall_ms = Vec::with_capacity(frames);
    let mut cpu_ms = Vec::with_capacity(frames);
    for index in 0..frames {
        let (t, c) = (Instant::now(), thread_cpu_ns());
        let frame = seq.load(index)?;
        wall_ms.push(t.elapsed().as_secs_f64() * 1e3);
        if let (Some(c0), Some(c1)) = (c, thread_cpu_ns()) {
            cpu_ms.push((c1 - c0) as f64 * 1e-6);
        }
        std::hint::black_box(frame);
    }
    let (wall_med, wall_p90) = median_p90(&mut wall_ms);

    let t_iter = Instant::now();
    let mut reader = seq.frames(Some(frames));
    while let Some(frame) = reader.next() {
        reader.recycle(frame?);
    }
    let iter_ms = t_iter.elapsed().as_secs_f64() * 1e3 / frames as f64;

    println!(
        "{} frames of {}x{} (distortion: {}), open + lists + undistortion table {open_ms:.1} ms",
        frames,
        camera.pinhole.width,
        camera.pinhole.height,
        !camera.distortion.is_zero()
    );
    println!("load (one thread), wall: median {wall_med:.2} ms, p90 {wall_p90:.2} ms per frame");
    if !cpu_ms.is_empty() {
        let (cpu_med, cpu_p90) = median_p90(&mut cpu_ms);
        println!("load (one thread), CPU:  median {cpu_med:.2} ms, p90 {cpu_p90:.2} ms per frame");
    }
    println!("frames() iterator with recycling: {iter_ms:.2} ms per frame");
    Ok(())
}
