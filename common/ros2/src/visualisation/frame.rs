//! What is shown of each frame: its matched points with their depth, in the camera's
//! optical frame (`/gfsvo/frame_points`, PointCloud2 x y z rgb, green for the inliers
//! of the pose and red for the rejected matches), and the tracking image
//! (`/gfsvo/tracking_image`: rgb8 `sensor_msgs/Image`, or jpeg `CompressedImage` on
//! `.../compressed` as image_transport names it), drawn by `gfs_plot`.

use super::{Visualiser, cloud};
use crate::msg::{CompressedImage, Header, Image, Time};
use gfs_core::RgbImage;
use gfs_core::camera::PinholeCamera;
use gfs_core::scene::FrameView;
use gfs_core::stamp::Stamp;
use nalgebra::Point3;
use serde::Deserialize;

/// Topic of the frame's matched points.
pub const FRAME_POINTS_TOPIC: &str = "/gfsvo/frame_points";
/// Topic of the tracking image (raw; the jpeg one adds `/compressed`).
pub const TRACKING_IMAGE_TOPIC: &str = "/gfsvo/tracking_image";
/// JPEG quality of the compressed tracking image.
const JPEG_QUALITY: u8 = 85;
/// Colours of the inliers and of the rejected matches.
const INLIER_RGB: [u8; 3] = [0, 230, 0];
const OUTLIER_RGB: [u8; 3] = [255, 40, 40];

/// How the tracking image is sent.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ImageFormat {
    /// `sensor_msgs/Image` rgb8 (default: every viewer shows it).
    #[default]
    Raw,
    /// `sensor_msgs/CompressedImage` jpeg, about a tenth of the bytes.
    Jpeg,
}

impl ImageFormat {
    /// The topic of the tracking image in this format.
    pub fn topic(self) -> String {
        match self {
            Self::Raw => TRACKING_IMAGE_TOPIC.to_owned(),
            Self::Jpeg => format!("{TRACKING_IMAGE_TOPIC}/compressed"),
        }
    }
}

/// A tracking image as sent.
#[derive(Clone, Debug, PartialEq)]
pub enum TrackingImage {
    /// rgb8.
    Raw(Image),
    /// jpeg.
    Compressed(CompressedImage),
}

/// Stamp and frame of a frame's messages: the camera frame of its colour image, else
/// `[ros2.visualisation] camera_frame`.
pub fn camera_header(stamp: Time, colour_frame: &str, fallback: &str) -> Header {
    let frame = if colour_frame.is_empty() {
        fallback
    } else {
        colour_frame
    };
    Header {
        stamp,
        frame_id: frame.to_owned(),
    }
}

impl Visualiser {
    /// `/gfsvo/frame_points`: the matched keypoints with a depth, back-projected through
    /// the undistorted `camera` (the keypoints' pixels), in the camera's optical frame.
    pub fn frame_points(
        &self,
        view: &FrameView,
        camera: &PinholeCamera,
        header: Header,
    ) -> crate::visualisation::msg::PointCloud2 {
        let points = view
            .points
            .iter()
            .filter(|p| p.depth > 0.0 && p.depth.is_finite())
            .map(|p| {
                let q =
                    camera.back_project(f64::from(p.uv[0]), f64::from(p.uv[1]), f64::from(p.depth));
                let colour = if p.inlier { INLIER_RGB } else { OUTLIER_RGB };
                (Point3::new(q.x as f32, q.y as f32, q.z as f32), colour)
            })
            .filter(|(p, _)| p.iter().all(|v| v.is_finite()));
        cloud(header, points)
    }
}

/// The tracking image message of the drawn `image`.
///
/// # Errors
/// The JPEG encoder's message.
pub fn tracking_image(
    image: &RgbImage,
    header: Header,
    format: ImageFormat,
) -> Result<TrackingImage, String> {
    let (w, h) = (image.width() as u32, image.height() as u32);
    let bytes = image.as_slice().as_flattened();
    Ok(match format {
        ImageFormat::Raw => TrackingImage::Raw(Image {
            header,
            height: h,
            width: w,
            encoding: "rgb8".to_owned(),
            is_bigendian: 0,
            step: 3 * w,
            data: bytes.to_vec(),
        }),
        ImageFormat::Jpeg => {
            let mut data = Vec::new();
            image::codecs::jpeg::JpegEncoder::new_with_quality(&mut data, JPEG_QUALITY)
                .encode(bytes, w, h, image::ExtendedColorType::Rgb8)
                .map_err(|e| format!("{TRACKING_IMAGE_TOPIC}: cannot encode the jpeg: {e}"))?;
            TrackingImage::Compressed(CompressedImage {
                header,
                format: "rgb8; jpeg compressed bgr8".to_owned(),
                data,
            })
        }
    })
}

/// Whether a frame at `stamp` is due for a message at `rate_hz` of the data's clock,
/// and when the next is: the first frame, then every `1 / rate_hz` seconds.
#[derive(Clone, Copy, Debug)]
pub struct RateGate {
    period_ns: i64,
    next: Option<Stamp>,
}

impl RateGate {
    /// A gate opening at `rate_hz` of the data's stamps.
    pub fn new(rate_hz: f64) -> Self {
        Self {
            period_ns: (1e9 / rate_hz).round() as i64,
            next: None,
        }
    }

    /// True when the frame at `stamp` is due (and then waits a period from it); a stamp
    /// far before the last due one (a camera that restarted its clock) opens it.
    pub fn due(&mut self, stamp: Stamp) -> bool {
        let open = self
            .next
            .is_none_or(|next| stamp >= next || stamp.nanos() < next.nanos() - 2 * self.period_ns);
        if open {
            self.next = Some(Stamp::from_nanos(stamp.nanos() + self.period_ns));
        }
        open
    }
}
