//! `gfsvo convert DATASET OUT`: a dataset folder (TUM, 7-Scenes in TUM layout, a
//! `gfsvo synth` folder) as a ROS 2 bag in MCAP, on the topics an RGB-D driver uses, so
//! that the ROS 2 path can be tried on any data at hand (`gfsvo run OUT`, `ros2 bag
//! play OUT`). Colour stays as recorded (rgb8, distorted; the CameraInfo carries the
//! distortion); depth is 32FC1 metres (exact) or, with `--depth-mm`, 16UC1 millimetres
//! (REP 118), stamped like the colour image as aligned-depth drivers do. Chunks are
//! zstd-compressed as `ros2 bag record` writes them (`--mcap-compression`). The bag is
//! written under `OUT.partial` and renamed when complete; a failed conversion leaves no
//! bag behind, and an existing OUT is never replaced.

use super::run::progress_bar;
use crate::CliResult;
use crate::config::Config;
use gfs_core::camera::{Camera, Distortion};
use gfs_dataset::Sequence;
use gfs_ros2::bag::{BagWriter, Compression};
use gfs_ros2::camera_info::info_from_camera;
use gfs_ros2::msg::{Header, Image, Time};
use gfs_ros2::schema;
use std::path::{Path, PathBuf};

/// Arguments of `gfsvo convert`.
#[derive(clap::Args)]
pub struct ConvertArgs {
    /// Dataset folder in TUM RGB-D layout.
    pub dataset: PathBuf,
    /// The bag: a folder (metadata.yaml + one .mcap) or, ending in .mcap, a bare file.
    pub out: PathBuf,
    /// Config TOML (default: chosen from the dataset folder name).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Depth as 16UC1 millimetres (a camera driver's encoding) instead of 32FC1 metres.
    #[arg(long)]
    pub depth_mm: bool,
    /// Convert only the first N frames.
    #[arg(long)]
    pub frames: Option<usize>,
    /// Chunk compression: none, lz4 or zstd (as `ros2 bag record` writes).
    #[arg(long, default_value = "zstd")]
    pub mcap_compression: Compression,
}

/// The optical frame the images are in.
const OPTICAL_FRAME: &str = "camera_color_optical_frame";

/// Writes the bag under a temporary name, renamed to OUT once complete.
pub fn run(args: &ConvertArgs) -> CliResult {
    if args.out.symlink_metadata().is_ok() {
        return Err(format!(
            "{}: exists; convert writes a new bag (remove it or choose another name)",
            args.out.display()
        )
        .into());
    }
    let partial = partial_path(&args.out);
    if partial.symlink_metadata().is_ok() {
        return Err(format!(
            "{}: exists (left by a conversion that did not finish?); remove it first",
            partial.display()
        )
        .into());
    }
    let total = match convert(args, &partial) {
        Ok(total) => total,
        Err(e) => {
            let _ = std::fs::remove_dir_all(&partial);
            let _ = std::fs::remove_file(&partial);
            return Err(e);
        }
    };
    std::fs::rename(&partial, &args.out)
        .map_err(|e| format!("{} -> {}: {e}", partial.display(), args.out.display()))?;
    println!("{total} frames written to {}", args.out.display());
    Ok(())
}

/// `OUT.partial`: where the bag is written until it is complete.
fn partial_path(out: &Path) -> PathBuf {
    let mut name = out.file_name().unwrap_or_default().to_os_string();
    name.push(".partial");
    out.with_file_name(name)
}

/// Writes the bag of `args` at `partial`; the number of frames.
fn convert(args: &ConvertArgs, partial: &Path) -> CliResult<usize> {
    let config = Config::load(args.config.as_deref(), &args.dataset)?;
    let camera = config.camera()?;
    // Without distortion the reader hands the colour over as recorded.
    let raw = Camera {
        distortion: Distortion::default(),
        ..camera
    };
    let sequence = Sequence::open(&args.dataset, &raw, &config.depth)?;
    let total = args
        .frames
        .map_or(sequence.len(), |n| n.min(sequence.len()));
    let (dir, file) = bag_paths(&args.out, partial)?;
    let ros2 = &config.ros2;
    let mut writer = BagWriter::create(&file, args.mcap_compression)?;
    let bar = progress_bar(total as u64, false);
    let mut colour = Image::default();
    let mut depth = Image::default();
    let mut first_last = (u64::MAX, 0u64);
    let mut reader = sequence.frames(Some(total));
    while let Some(frame) = reader.next() {
        let frame = frame?;
        let stamp = Time::from(frame.timestamp);
        let time = u64::try_from(stamp.nanos()).unwrap_or(0);
        first_last = (first_last.0.min(time), first_last.1.max(time));
        let header = Header {
            stamp,
            frame_id: OPTICAL_FRAME.to_owned(),
        };
        let (w, h) = (frame.rgb.width(), frame.rgb.height());
        colour.header = header.clone();
        (colour.width, colour.height, colour.step) = (w as u32, h as u32, 3 * w as u32);
        colour.encoding = "rgb8".to_owned();
        colour.data.clear();
        colour
            .data
            .extend_from_slice(frame.rgb.as_slice().as_flattened());
        depth.header = header.clone();
        (depth.width, depth.height) = (w as u32, h as u32);
        depth.data.clear();
        if args.depth_mm {
            depth.encoding = "16UC1".to_owned();
            depth.step = 2 * w as u32;
            for m in frame.depth.as_slice() {
                let mm = (f64::from(*m) * 1000.0).round().clamp(0.0, 65535.0) as u16;
                depth.data.extend_from_slice(&mm.to_le_bytes());
            }
        } else {
            depth.encoding = "32FC1".to_owned();
            depth.step = 4 * w as u32;
            for m in frame.depth.as_slice() {
                depth.data.extend_from_slice(&m.to_le_bytes());
            }
        }
        writer.write(
            &ros2.camera_info_topic,
            &schema::CAMERA_INFO,
            time,
            &info_from_camera(&camera, header),
        )?;
        writer.write(&ros2.colour_topic, &schema::IMAGE, time, &colour)?;
        writer.write(&ros2.depth_topic, &schema::IMAGE, time, &depth)?;
        bar.inc(1);
        reader.recycle(frame);
    }
    writer.finish()?;
    bar.finish_and_clear();
    if let Some(dir) = dir {
        write_metadata(&dir, &file, total, first_last, ros2)?;
    }
    Ok(total)
}

/// The bag folder (None for a bare .mcap) and the .mcap file, written at `partial`
/// until renamed to `out` (the .mcap in a folder is named after `out`, as rosbag2 names
/// it).
fn bag_paths(out: &Path, partial: &Path) -> CliResult<(Option<PathBuf>, PathBuf)> {
    if out.extension().is_some_and(|e| e == "mcap") {
        return Ok((None, partial.to_path_buf()));
    }
    std::fs::create_dir(partial).map_err(|e| format!("{}: {e}", partial.display()))?;
    let name = out
        .file_name()
        .map_or_else(|| "bag".to_owned(), |n| n.to_string_lossy().into_owned());
    Ok((
        Some(partial.to_path_buf()),
        partial.join(format!("{name}_0.mcap")),
    ))
}

/// `metadata.yaml` of a rosbag2 folder (format version 5, read by `ros2 bag` from Humble
/// on and by rosbags).
fn write_metadata(
    dir: &Path,
    file: &Path,
    frames: usize,
    (first, last): (u64, u64),
    ros2: &gfs_ros2::Ros2Config,
) -> CliResult {
    let name = file
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let first = if frames == 0 { 0 } else { first };
    let topic = |topic: &str, ty: &str| {
        format!(
            "    - topic_metadata:\n        name: {topic}\n        type: {ty}\n        \
             serialization_format: cdr\n        offered_qos_profiles: ''\n      message_count: {frames}\n"
        )
    };
    let text = format!(
        "rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: mcap\n  \
         duration:\n    nanoseconds: {}\n  starting_time:\n    nanoseconds_since_epoch: {first}\n  \
         message_count: {}\n  topics_with_message_count:\n{}{}{}  compression_format: ''\n  \
         compression_mode: ''\n  relative_file_paths:\n    - {name}\n  files:\n    - path: {name}\n      \
         starting_time:\n        nanoseconds_since_epoch: {first}\n      duration:\n        \
         nanoseconds: {}\n      message_count: {}\n",
        last.saturating_sub(first),
        3 * frames,
        topic(&ros2.colour_topic, "sensor_msgs/msg/Image"),
        topic(&ros2.depth_topic, "sensor_msgs/msg/Image"),
        topic(&ros2.camera_info_topic, "sensor_msgs/msg/CameraInfo"),
        last.saturating_sub(first),
        3 * frames,
    );
    std::fs::write(dir.join("metadata.yaml"), text)?;
    Ok(())
}
