//! The per-frame visualisation topics of the `--mcap` recording: `/gfsvo/frame_points`
//! for every frame the tracker sent its matches of, and the tracking image at
//! `[ros2.visualisation] tracking_image_rate_hz` of the data's clock, drawn on the
//! frame's colour image read again from the folder or bag after the run.

use crate::CliResult;
use crate::config::Config;
use crate::pipeline::FrameViews;
use gfs_core::RgbImage;
use gfs_core::camera::PinholeCamera;
use gfs_core::scene::FrameView;
use gfs_dataset::Sequence;
use gfs_odometry::FramePose;
use gfs_ros2::bag::{BagReader, BagWriter};
use gfs_ros2::image::{FrameConverter, Received};
use gfs_ros2::msg::Time;
use gfs_ros2::schema;
use gfs_ros2::transport::TransportDecoder;
use gfs_ros2::visualisation::frame::{
    FRAME_POINTS_TOPIC, RateGate, TrackingImage, camera_header, tracking_image,
};
use gfs_ros2::visualisation::{Visualiser, msg};
use std::path::Path;

/// Where the colour images of the frames are read again.
pub enum ColourFrames<'a> {
    /// None (a live run): no tracking image.
    None,
    /// A dataset folder (undistorted by its reader).
    Folder(&'a Sequence),
    /// A bag, read forward frame by frame.
    Bag(Box<BagColours>),
}

/// A bag's colour images in frame order, undistorted as the bag source converts them.
pub struct BagColours {
    reader: BagReader,
    converter: FrameConverter,
    decoder: TransportDecoder,
    topic: String,
    next: u64,
}

impl ColourFrames<'_> {
    /// The bag at `path` read with `config`'s topics and camera.
    ///
    /// # Errors
    /// The bag cannot be opened, or the config's camera is invalid.
    pub fn bag(path: &Path, config: &Config) -> CliResult<Self> {
        let reader = BagReader::open(
            path,
            &super::ros2_io::bag_topics(config),
            config.ros2.slop_s,
        )?;
        let topic = reader.image_topics().0.to_owned();
        Ok(Self::Bag(Box::new(BagColours {
            reader,
            converter: FrameConverter::new(&config.camera()?, &config.depth),
            decoder: TransportDecoder::new(),
            topic,
            next: 0,
        })))
    }

    /// Frame `id`'s undistorted colour into `out`, and its camera frame name (empty for
    /// a folder); `None` when it cannot be read (with a warning) or there are no images.
    /// A bag is read forward: an earlier frame than the last one read is not found.
    fn load(&mut self, id: u64, out: &mut RgbImage) -> Option<String> {
        match self {
            Self::None => None,
            Self::Folder(sequence) => match sequence.load(id as usize) {
                Ok(frame) => {
                    *out = frame.rgb;
                    Some(String::new())
                }
                Err(e) => {
                    tracing::warn!("tracking image of frame {id}: {e}");
                    None
                }
            },
            Self::Bag(bag) => bag.load(id, out),
        }
    }
}

impl BagColours {
    fn load(&mut self, id: u64, out: &mut RgbImage) -> Option<String> {
        while self.next <= id {
            let frame = match self.reader.next_frame() {
                Ok(Some(frame)) => frame,
                Ok(None) => return None,
                Err(e) => {
                    tracing::warn!("tracking image of frame {id}: {e}");
                    return None;
                }
            };
            self.next += 1;
            if self.next <= id {
                continue;
            }
            let converted = self
                .decoder
                .colour(&frame.colour, &self.topic)
                .and_then(|image| {
                    let received = Received {
                        image,
                        topic: &self.topic,
                    };
                    self.converter.undistorted_colour(received, out)?;
                    Ok(image.header.frame_id.clone())
                });
            return match converted {
                Ok(frame_id) => Some(frame_id),
                Err(e) => {
                    tracing::warn!("tracking image of frame {id}: {e}");
                    None
                }
            };
        }
        None
    }
}

/// Writes the per-frame topics of a recording, frame after frame.
pub struct FrameVisuals<'a> {
    config: &'a Config,
    visualiser: Visualiser,
    camera: PinholeCamera,
    views: &'a FrameViews,
    colours: ColourFrames<'a>,
    gate: RateGate,
    image: RgbImage,
    empty: FrameView,
}

impl<'a> FrameVisuals<'a> {
    /// The writer for `config`'s switches, with the frames' matches and colour images.
    ///
    /// # Errors
    /// The config's camera is invalid.
    pub fn new(
        config: &'a Config,
        views: &'a FrameViews,
        colours: ColourFrames<'a>,
    ) -> CliResult<Self> {
        Ok(Self {
            visualiser: Visualiser::new(&config.ros2),
            camera: config.camera()?.pinhole,
            gate: RateGate::new(config.ros2.visualisation.tracking_image_rate_hz),
            views,
            colours,
            config,
            image: RgbImage::new(0, 0),
            empty: FrameView::default(),
        })
    }

    /// The writer of `gfsvo run`'s recording: the colour images read again from the
    /// dataset folder (`sequence`) or the bag at `dataset`.
    ///
    /// # Errors
    /// The bag cannot be opened, or the config's camera is invalid.
    pub fn of_run(
        config: &'a Config,
        dataset: &Path,
        sequence: Option<&'a Sequence>,
        views: &'a FrameViews,
    ) -> CliResult<Self> {
        let colours = match sequence {
            _ if !config.ros2.visualisation.tracking_image => ColourFrames::None,
            Some(sequence) => ColourFrames::Folder(sequence),
            None => ColourFrames::bag(dataset, config)?,
        };
        Self::new(config, views, colours)
    }

    /// The frame points and (when due) the tracking image of `pose`'s frame, stamped
    /// `stamp` (`time_ns` in the bag); `keyframes` made so far for the status line.
    ///
    /// # Errors
    /// The bag cannot be written.
    pub fn write(
        &mut self,
        writer: &mut BagWriter,
        pose: &FramePose,
        (stamp, time_ns): (Time, u64),
        keyframes: usize,
    ) -> CliResult {
        let shown = &self.config.ros2.visualisation;
        let id = pose.id.0;
        let view = self.views.get(&id);
        let due = shown.tracking_image && self.gate.due(pose.timestamp);
        let colour_frame = if due {
            self.colours.load(id, &mut self.image)
        } else {
            None
        };
        let frame_name = colour_frame.as_deref().unwrap_or_default();
        let header = camera_header(stamp, frame_name, &shown.camera_frame);
        if shown.frame_points
            && let Some(view) = view
        {
            let cloud = self
                .visualiser
                .frame_points(view, &self.camera, header.clone());
            writer.write(FRAME_POINTS_TOPIC, &msg::POINT_CLOUD2, time_ns, &cloud)?;
        }
        if colour_frame.is_some() {
            let view = view.unwrap_or(&self.empty);
            let status = gfs_plot::status_line(pose.status.as_str(), id, view, keyframes);
            gfs_plot::draw_tracking_image(&mut self.image, view, &status)?;
            let topic = shown.tracking_image_format.topic();
            match tracking_image(&self.image, header, shown.tracking_image_format)? {
                TrackingImage::Raw(image) => {
                    writer.write(&topic, &schema::IMAGE, time_ns, &image)?
                }
                TrackingImage::Compressed(image) => {
                    writer.write(&topic, &schema::COMPRESSED_IMAGE, time_ns, &image)?;
                }
            }
        }
        Ok(())
    }
}
