//! `gfsvo convert DATASET OUT`: a dataset folder (TUM, 7-Scenes in TUM layout, a
//! `gfsvo synth` folder) as a ROS 2 bag in MCAP, on the topics an RGB-D driver uses, so
//! that the ROS 2 path can be tried on any data at hand (`gfsvo run OUT`, `ros2 bag
//! play OUT`). Colour stays as recorded (rgb8, distorted; the CameraInfo carries the
//! distortion); depth is 32FC1 metres (exact) or, with `--depth-mm`, 16UC1 millimetres
//! (REP 118), stamped like the colour image as aligned-depth drivers do. Chunks are
//! zstd-compressed as `ros2 bag record` writes them (`--mcap-compression`). A folder's
//! `imu.txt` goes to `[ros2] imu_topic` (`/camera/imu`) as `sensor_msgs/Imu` in the
//! IMU's frame, logged at its stamps between the frames (no orientation; the
//! covariances of the config's `[imu]` noise at the file's rate). The bag is
//! written under `OUT.partial` and renamed when complete; a failed conversion leaves no
//! bag behind, and an existing OUT is never replaced.

use super::run::progress_bar;
use crate::CliResult;
use crate::config::Config;
use gfs_core::camera::{Camera, Distortion};
use gfs_core::stamp::Stamp;
use gfs_dataset::{IMU_LIST, ImuList, Sequence, read_imu};
use gfs_inertial::ImuSample;
use gfs_ros2::bag::{BagWriter, Compression};
use gfs_ros2::camera_info::info_from_camera;
use gfs_ros2::imu::imu_message;
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
/// The IMU's frame (`[imu] camera_from_imu` places it in the optical frame).
const IMU_FRAME: &str = "camera_imu_optical_frame";

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
    println!(
        "{} frames and {} IMU samples written to {}",
        total.0,
        total.1,
        args.out.display()
    );
    Ok(())
}

/// `OUT.partial`: where the bag is written until it is complete.
fn partial_path(out: &Path) -> PathBuf {
    let mut name = out.file_name().unwrap_or_default().to_os_string();
    name.push(".partial");
    out.with_file_name(name)
}

/// Writes the bag of `args` at `partial`; the number of frames and of IMU samples.
fn convert(args: &ConvertArgs, partial: &Path) -> CliResult<(usize, usize)> {
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
    let mut imu = ImuWriter::open(&args.dataset, &config)?;
    let mut reader = sequence.frames(Some(total));
    while let Some(frame) = reader.next() {
        let frame = frame?;
        let stamp = Time::from(frame.timestamp);
        let time = u64::try_from(stamp.nanos()).unwrap_or(0);
        imu.write_through(&mut writer, frame.timestamp, &ros2.imu_topic)?;
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
    // The rest of imu.txt; with --frames, up to the first sample past the last frame.
    let end =
        (args.frames.is_some() && first_last.1 > 0).then(|| Stamp::from_nanos(first_last.1 as i64));
    imu.write_rest(&mut writer, end, &ros2.imu_topic)?;
    writer.finish()?;
    bar.finish_and_clear();
    if let Some(dir) = dir {
        write_metadata(&dir, &file, (total, imu.written), first_last, ros2)?;
    }
    Ok((total, imu.written))
}

/// A folder's IMU samples, written between the frames at their stamps.
struct ImuWriter {
    samples: std::vec::IntoIter<ImuSample>,
    next: Option<ImuSample>,
    noise: gfs_inertial::ImuNoise,
    rate_hz: f64,
    written: usize,
    last: Option<Stamp>,
}

impl ImuWriter {
    /// The folder's `imu.txt` (none: nothing to write); its skipped lines are said.
    fn open(dataset: &Path, config: &Config) -> CliResult<Self> {
        let list = read_imu(dataset)?.unwrap_or_else(ImuList::default);
        for warning in &list.warnings {
            eprintln!("warning: {warning}");
        }
        let mut steps: Vec<f64> = list
            .samples
            .windows(2)
            .map(|w| w[1].stamp.secs_since(w[0].stamp))
            .collect();
        steps.sort_by(f64::total_cmp);
        let rate_hz = steps.get(steps.len() / 2).map_or(0.0, |dt| 1.0 / dt);
        if !list.samples.is_empty() {
            println!(
                "{}: {} samples at {rate_hz:.0} Hz",
                dataset.join(IMU_LIST).display(),
                list.samples.len()
            );
        }
        let mut samples = list.samples.into_iter();
        Ok(Self {
            next: samples.next(),
            samples,
            noise: config.imu.noise(),
            rate_hz,
            written: 0,
            last: None,
        })
    }

    /// Writes the samples up to `stamp` and the first one past it.
    fn write_through(&mut self, writer: &mut BagWriter, stamp: Stamp, topic: &str) -> CliResult {
        while let Some(sample) = self.next {
            self.write(writer, &sample, topic)?;
            if sample.stamp > stamp {
                break;
            }
        }
        Ok(())
    }

    /// Writes the rest, or up to `end` and the first one past it.
    fn write_rest(&mut self, writer: &mut BagWriter, end: Option<Stamp>, topic: &str) -> CliResult {
        if end.is_some_and(|end| self.last.is_some_and(|last| last > end)) {
            return Ok(());
        }
        self.write_through(writer, end.unwrap_or(Stamp::from_nanos(i64::MAX)), topic)
    }

    fn write(&mut self, writer: &mut BagWriter, sample: &ImuSample, topic: &str) -> CliResult {
        let time = u64::try_from(sample.stamp.nanos()).unwrap_or(0);
        let message = imu_message(sample, IMU_FRAME, &self.noise, self.rate_hz);
        writer.write(topic, &schema::IMU, time, &message)?;
        self.written += 1;
        self.last = Some(sample.stamp);
        self.next = self.samples.next();
        Ok(())
    }
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
    (frames, imu): (usize, usize),
    (first, last): (u64, u64),
    ros2: &gfs_ros2::Ros2Config,
) -> CliResult {
    let name = file
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let first = if frames == 0 { 0 } else { first };
    let topic = |topic: &str, ty: &str, count: usize| {
        format!(
            "    - topic_metadata:\n        name: {topic}\n        type: {ty}\n        \
             serialization_format: cdr\n        offered_qos_profiles: ''\n      message_count: {count}\n"
        )
    };
    let imu_topic = if imu > 0 {
        topic(&ros2.imu_topic, "sensor_msgs/msg/Imu", imu)
    } else {
        String::new()
    };
    let text = format!(
        "rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: mcap\n  \
         duration:\n    nanoseconds: {}\n  starting_time:\n    nanoseconds_since_epoch: {first}\n  \
         message_count: {}\n  topics_with_message_count:\n{}{}{}{}  compression_format: ''\n  \
         compression_mode: ''\n  relative_file_paths:\n    - {name}\n  files:\n    - path: {name}\n      \
         starting_time:\n        nanoseconds_since_epoch: {first}\n      duration:\n        \
         nanoseconds: {}\n      message_count: {}\n",
        last.saturating_sub(first),
        3 * frames + imu,
        topic(&ros2.colour_topic, "sensor_msgs/msg/Image", frames),
        topic(&ros2.depth_topic, "sensor_msgs/msg/Image", frames),
        topic(
            &ros2.camera_info_topic,
            "sensor_msgs/msg/CameraInfo",
            frames
        ),
        imu_topic,
        last.saturating_sub(first),
        3 * frames + imu,
    );
    std::fs::write(dir.join("metadata.yaml"), text)?;
    Ok(())
}
