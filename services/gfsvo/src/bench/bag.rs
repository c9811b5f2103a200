//! `gfsvo bench bag BAG`: what playing a ROS 2 bag costs per frame, single-threaded:
//! reading (records, chunk decompression, CDR, pairing), decoding `image_transport`'s
//! compressed images, and converting to gray and metres, in the thread's CPU time (on a
//! machine shared with other work, wall time counts the waits for a core). Comparing
//! bags written with `gfsvo convert --mcap-compression none|lz4|zstd` gives the
//! decompression cost.

use super::BenchArgs;
use super::stats::Summary;
use crate::CliResult;
use crate::cmd::ros2_io::bag_topics;
use crate::config::Config;
use gfs_ros2::bag::BagReader;
use gfs_ros2::image::{FrameConverter, Received};
use gfs_ros2::transport::TransportDecoder;
use serde_json::json;

/// Names of the timed steps (also the JSON keys).
const STEPS: [&str; 3] = ["read", "decode", "convert"];

/// Runs the bag benchmark.
///
/// # Errors
/// Config, bag and image errors.
pub fn run(args: &BenchArgs) -> CliResult {
    let config = Config::load(args.config.as_deref(), &args.dataset)?;
    let camera = config.camera()?;
    let mut bag = BagReader::open(&args.dataset, &bag_topics(&config), config.ros2.slop_s)?;
    let (colour_topic, depth_topic) = bag.image_topics();
    let (colour_topic, depth_topic) = (colour_topic.to_owned(), depth_topic.to_owned());
    let mut decoders = (TransportDecoder::new(), TransportDecoder::new());
    let mut converter = FrameConverter::new(&camera, &config.depth);
    let (w, h) = converter.size();
    let (mut gray, mut depth_m) = (vec![0u8; w * h], vec![0f32; w * h]);
    let mut steps: [Vec<f64>; 3] = Default::default();
    let limit = args.frames.unwrap_or(usize::MAX);
    let ms = |t: f64| thread_cpu_ms() - t;
    while steps[0].len() < limit {
        let t = thread_cpu_ms();
        let Some(frame) = bag.next_frame()? else {
            break;
        };
        steps[0].push(ms(t));
        let t = thread_cpu_ms();
        let colour = decoders.0.colour(&frame.colour, &colour_topic)?;
        let depth = decoders.1.depth(&frame.depth, &depth_topic)?;
        steps[1].push(ms(t));
        let t = thread_cpu_ms();
        let colour = Received {
            image: colour,
            topic: &colour_topic,
        };
        let depth = Received {
            image: depth,
            topic: &depth_topic,
        };
        converter.convert(colour, depth, &mut gray, &mut depth_m)?;
        steps[2].push(ms(t));
    }
    let summaries: Vec<Summary> = steps.iter_mut().map(|s| Summary::of(s)).collect();
    let bytes: u64 = gfs_ros2::bag::bag_files(&args.dataset)?
        .iter()
        .filter_map(|f| f.metadata().ok())
        .map(|m| m.len())
        .sum();
    if args.json {
        let out = json!({
            "bag": args.dataset,
            "colour_topic": colour_topic,
            "depth_topic": depth_topic,
            "frames": summaries[0].count,
            "bytes": bytes,
            "steps_ms": STEPS.iter().zip(&summaries).map(|(n, s)| (n.to_string(), json!(s)))
                .collect::<serde_json::Map<_, _>>(),
        });
        println!("{out}");
        return Ok(());
    }
    println!(
        "{}: {} frames of {w}x{h} ({colour_topic}, {depth_topic}), {:.1} MB",
        args.dataset.display(),
        summaries[0].count,
        bytes as f64 / 1e6
    );
    println!(
        "{:<10} {:>9} {:>9}  (thread CPU time)",
        "step", "median ms", "p90 ms"
    );
    for (name, s) in STEPS.iter().zip(&summaries) {
        println!("{name:<10} {:>9.3} {:>9.3}", s.median, s.p90);
    }
    Ok(())
}

/// CPU time of the calling thread, milliseconds.
fn thread_cpu_ms() -> f64 {
    let mut t = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes the timespec it is given and nothing else.
    unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut t) };
    t.tv_sec as f64 * 1e3 + t.tv_nsec as f64 * 1e-6
}
