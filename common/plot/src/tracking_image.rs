//! The tracking image, as ORB-SLAM2's frame view: the frame's matched keypoints (boxes
//! around a dot) and lines drawn on its colour image, green for the inliers of its pose
//! and red for the matches its optimisation rejected, and a status bar below them.

use crate::canvas::{FONT, PlotError, register_fonts};
use gfs_core::RgbImage;
use gfs_core::scene::FrameView;
use plotters::prelude::*;

/// Colour of the inliers of the frame's pose.
pub const INLIER_COLOR: [u8; 3] = [0, 230, 0];
/// Colour of the matches the pose optimisation rejected.
pub const OUTLIER_COLOR: [u8; 3] = [255, 40, 40];
/// Half side of a keypoint's box, pixels.
const BOX_HALF: i32 = 4;
/// Height of the status bar and its text, pixels.
const BAR_HEIGHT: i32 = 22;
const TEXT_SIZE: u32 = 16;

/// Draws `view` and the `status` line into `image` (the frame's undistorted colour
/// image, where the view's pixels are).
///
/// # Errors
/// [`PlotError::Draw`] when the image has no pixel or the font cannot be read.
pub fn draw_tracking_image(
    image: &mut RgbImage,
    view: &FrameView,
    status: &str,
) -> Result<(), PlotError> {
    let (w, h) = (image.width(), image.height());
    let size = u32::try_from(w)
        .ok()
        .zip(u32::try_from(h).ok())
        .filter(|(w, h)| *w > 0 && *h > 0)
        .ok_or_else(|| PlotError::Draw(format!("a {w}x{h} image")))?;
    register_fonts()?;
    let root = BitMapBackend::with_buffer(image.as_mut_slice().as_flattened_mut(), size)
        .into_drawing_area();
    let style = |inlier: bool| {
        let [r, g, b] = if inlier { INLIER_COLOR } else { OUTLIER_COLOR };
        RGBColor(r, g, b)
    };
    let px = |uv: [f32; 2]| (uv[0].round() as i32, uv[1].round() as i32);
    for line in &view.lines {
        let color = style(line.inlier).stroke_width(2);
        root.draw(&PathElement::new(
            vec![px(line.ends[0]), px(line.ends[1])],
            color,
        ))?;
    }
    for point in &view.points {
        let (u, v) = px(point.uv);
        let color = style(point.inlier);
        let corners = [(u - BOX_HALF, v - BOX_HALF), (u + BOX_HALF, v + BOX_HALF)];
        root.draw(&Rectangle::new(corners, color.stroke_width(1)))?;
        root.draw(&Circle::new((u, v), 1, color.filled()))?;
    }
    let bar_top = size.1 as i32 - BAR_HEIGHT;
    root.draw(&Rectangle::new(
        [(0, bar_top), (size.0 as i32, size.1 as i32)],
        BLACK.mix(0.75).filled(),
    ))?;
    root.draw(&Text::new(
        status.to_owned(),
        (6, bar_top + 3),
        (FONT, TEXT_SIZE).into_font().color(&WHITE),
    ))?;
    root.present()?;
    Ok(())
}

/// The status line of a tracking image: the status, the frame, the matches and the
/// keyframes so far.
pub fn status_line(status: &str, frame: u64, view: &FrameView, keyframes: usize) -> String {
    let count = |inliers: bool, lines: bool| -> usize {
        if lines {
            view.lines.iter().filter(|l| l.inlier == inliers).count()
        } else {
            view.points.iter().filter(|p| p.inlier == inliers).count()
        }
    };
    format!(
        "{} | frame {frame} | points {} in, {} out | lines {} in, {} out | keyframes {keyframes}",
        status.to_uppercase(),
        count(true, false),
        count(false, false),
        count(true, true),
        count(false, true),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use gfs_core::scene::{FrameLine, FramePoint};

    #[test]
    fn inliers_are_green_outliers_red_and_the_status_bar_is_dark() {
        let mut image = RgbImage::new(160, 120);
        image.as_mut_slice().fill([128, 128, 128]);
        let view = FrameView {
            points: vec![
                FramePoint {
                    uv: [20.0, 20.0],
                    depth: 1.0,
                    inlier: true,
                },
                FramePoint {
                    uv: [60.0, 20.0],
                    depth: 0.0,
                    inlier: false,
                },
            ],
            lines: vec![FrameLine {
                ends: [[10.0, 60.0], [150.0, 60.0]],
                inlier: true,
            }],
        };
        let status = status_line("tracked", 7, &view, 3);
        assert_eq!(
            status,
            "TRACKED | frame 7 | points 1 in, 1 out | lines 1 in, 0 out | keyframes 3"
        );
        draw_tracking_image(&mut image, &view, &status).unwrap();
        let at = |u: usize, v: usize| image.as_slice()[v * 160 + u];
        // The box edge 4 px left of each keypoint, its centre dot, the line's middle.
        assert_eq!(at(16, 20), INLIER_COLOR);
        assert_eq!(at(20, 20), INLIER_COLOR);
        assert_eq!(at(56, 20), OUTLIER_COLOR);
        assert_eq!(at(80, 60), INLIER_COLOR);
        // Away from the features the image is untouched; the bar darkens the bottom.
        assert_eq!(at(100, 30), [128, 128, 128]);
        assert!(at(150, 117)[0] < 40, "{:?}", at(150, 117));
        // Text is drawn in the bar: some pixels of its left part are bright.
        let bright = (100..118)
            .flat_map(|v| (0..100).map(move |u| (u, v)))
            .filter(|&(u, v)| at(u, v)[0] > 150)
            .count();
        assert!(bright > 20, "{bright} bright pixels of text");
        let empty = RgbImage::new(0, 0);
        assert!(draw_tracking_image(&mut empty.clone(), &view, "").is_err());
    }
}
