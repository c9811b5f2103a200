//! A line chart of several series over a shared x axis, with a legend (e.g. the
//! processing time of every pipeline stage over the frame index).

use super::axes::{Panel, Range, TEXT_SCALE};
use super::canvas::{Canvas, Rgb};
use super::figure::{MIN_SIDE, PlotConfig, PlotError, save_png};
use gfs_core::RgbImage;
use std::path::Path;

const BACKGROUND: Rgb = [255, 255, 255];
const TEXT_COLOR: Rgb = [20, 20, 20];
/// Series colours in order (a qualitative palette that stays apart on white); the
/// seventh series reuses the first colour.
pub const SERIES_COLORS: [Rgb; 6] = [
    [31, 100, 200],
    [235, 110, 20],
    [40, 160, 60],
    [200, 30, 30],
    [140, 80, 190],
    [120, 90, 60],
];

/// One named polyline of a [`LineChart`].
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// Legend label.
    pub label: String,
    /// Data points `(x, y)` in drawing order; non-finite ones are skipped by the range.
    pub points: Vec<(f64, f64)>,
}

/// Titles and series of a line chart. The y axis starts at 0 (durations, counts).
#[derive(Clone, Debug, PartialEq)]
pub struct LineChart {
    /// Title above the panel.
    pub title: String,
    /// Label of the x axis.
    pub x_title: String,
    /// Label of the y axis.
    pub y_title: String,
    /// The series, drawn in order with [`SERIES_COLORS`].
    pub series: Vec<Series>,
}

/// The colour of series `index`.
pub fn series_color(index: usize) -> Rgb {
    SERIES_COLORS[index % SERIES_COLORS.len()]
}

/// Renders `chart` at the size and line width of `config`.
///
/// # Errors
/// [`PlotError::TooSmall`] when the configured size has no room for the panel.
pub fn render_line_chart(chart: &LineChart, config: &PlotConfig) -> Result<RgbImage, PlotError> {
    let (w, h) = (config.width, config.height);
    if w < MIN_SIDE || h < MIN_SIDE {
        return Err(PlotError::TooSmall {
            width: w,
            height: h,
        });
    }
    let mut canvas = Canvas::new(w, h, BACKGROUND);
    let all = || chart.series.iter().flat_map(|s| s.points.iter());
    let x = Range::of(all().map(|p| p.0), 1.0, 0.0).unwrap_or(Range { lo: 0.0, hi: 1.0 });
    let y_max = Range::of(all().map(|p| p.1), 0.0, 0.0).map_or(1.0, |r| r.hi.max(1e-9));
    let panel = Panel {
        left: 110.0,
        top: 80.0,
        right: w as f64 - 30.0,
        bottom: h as f64 - 70.0,
        x,
        y: Range {
            lo: 0.0,
            hi: 1.1 * y_max,
        },
    };
    panel.draw_axes(&mut canvas, &chart.title, &chart.x_title, &chart.y_title);
    let lw = config.line_width.max(1);
    for (i, series) in chart.series.iter().enumerate() {
        panel.polyline(&mut canvas, &series.points, lw, series_color(i));
    }
    draw_legend(&mut canvas, &panel, chart);
    Ok(canvas.into_image())
}

/// The legend as one row above the panel's right end (outside the data, so it never
/// hides a peak): a colour swatch and the label of each series.
fn draw_legend(canvas: &mut Canvas, panel: &Panel, chart: &LineChart) {
    const SWATCH: i64 = 24;
    const GAP: i64 = 8;
    const SPACING: i64 = 24;
    let item_w = |s: &Series| SWATCH + GAP + Canvas::text_width(&s.label, TEXT_SCALE);
    let total: i64 = chart
        .series
        .iter()
        .map(|s| item_w(s) + SPACING)
        .sum::<i64>()
        - SPACING;
    let th = Canvas::text_height(TEXT_SCALE);
    let y = panel.top as i64 - th - 8;
    let mut x = panel.right as i64 - total;
    for (i, series) in chart.series.iter().enumerate() {
        canvas.fill_rect(
            x,
            y + th / 2 - 2,
            x + SWATCH,
            y + th / 2 + 2,
            series_color(i),
        );
        canvas.text(x + SWATCH + GAP, y, &series.label, TEXT_SCALE, TEXT_COLOR);
        x += item_w(series) + SPACING;
    }
}

/// Renders `chart` and writes it as a PNG.
///
/// # Errors
/// [`PlotError::TooSmall`], or [`PlotError::Write`] naming the file that could not be
/// encoded or written.
pub fn write_line_chart_png(
    chart: &LineChart,
    path: &Path,
    config: &PlotConfig,
) -> Result<(), PlotError> {
    save_png(&render_line_chart(chart, config)?, path)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn count_in(image: &RgbImage, color: Rgb, x_from: usize, x_to: usize) -> usize {
        (0..image.height())
            .flat_map(|y| image.row(y)[x_from..x_to].iter())
            .filter(|&&p| p == color)
            .count()
    }

    fn two_series() -> LineChart {
        LineChart {
            title: "PROCESSING TIME PER STAGE".into(),
            x_title: "frame".into(),
            y_title: "ms".into(),
            series: vec![
                Series {
                    label: "points".into(),
                    points: (0..100).map(|k| (f64::from(k), 10.0)).collect(),
                },
                // Only in the second half of the frames.
                Series {
                    label: "tracker".into(),
                    points: (50..100).map(|k| (f64::from(k), 2.0)).collect(),
                },
            ],
        }
    }

    #[test]
    fn each_series_is_drawn_where_its_frames_are() {
        let config = PlotConfig {
            width: 800,
            height: 400,
            line_width: 2,
        };
        let image = render_line_chart(&two_series(), &config).unwrap();
        assert_eq!((image.width(), image.height()), (800, 400));
        // Panel x from 110 to 770 px over frames 0..99: frame 50 is at ~443 px. The
        // first series spans the panel (660 px x 2 px wide), the second its right half.
        let (c0, c1) = (series_color(0), series_color(1));
        assert!(
            count_in(&image, c0, 110, 771) > 1200,
            "{}",
            count_in(&image, c0, 110, 771)
        );
        assert!(count_in(&image, c1, 450, 771) > 600);
        // Left of frame 50 the second colour appears only in the legend swatch (right).
        assert_eq!(count_in(&image, c1, 0, 440), 0);
        // y = 10 ms maps to bottom 330 - 10/11 x 250 px = row 103 (2 px wide: 102..103).
        let row_of = |color| (0..image.height()).find(|&y| image.row(y)[300] == color);
        let (r0, r1) = (row_of(c0).unwrap(), row_of(c1));
        assert!((102..=103).contains(&r0), "{r0}");
        assert_eq!(r1, None);
    }

    #[test]
    fn empty_charts_draw_and_tiny_sizes_fail() {
        let empty = LineChart {
            series: Vec::new(),
            ..two_series()
        };
        let image = render_line_chart(&empty, &PlotConfig::default()).unwrap();
        assert_eq!(image.width(), 1400);
        let tiny = PlotConfig {
            width: 100,
            height: 100,
            line_width: 1,
        };
        assert!(matches!(
            render_line_chart(&empty, &tiny),
            Err(PlotError::TooSmall { .. })
        ));
        let bad = write_line_chart_png(
            &two_series(),
            Path::new("/nonexistent/dir/c.png"),
            &PlotConfig::default(),
        );
        assert!(matches!(bad, Err(PlotError::Write { .. })));
    }
}
