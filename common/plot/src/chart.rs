//! A line chart of several series over a shared x axis, with a legend (e.g. the
//! processing time of every pipeline stage over the frame index).

use crate::canvas::{
    Area, FONT, INK, LEGEND_SIZE, MIN_SIDE, PlotConfig, PlotError, chart, draw_mesh, polyline,
    range_of, render, rgb, save_png, series_color, titled,
};
use image::RgbImage;
use plotters::prelude::*;
use std::path::Path;

/// Height of the legend row between the title and the panel, in pixels.
const LEGEND_ROW: u32 = 28;

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
    /// The series, drawn in order with [`crate::SERIES_COLORS`].
    pub series: Vec<Series>,
}

/// Renders `chart` at the size and line width of `config`.
///
/// # Errors
/// [`PlotError::TooSmall`] when the configured size has no room for the panel.
pub fn render_line_chart(
    line_chart: &LineChart,
    config: &PlotConfig,
) -> Result<RgbImage, PlotError> {
    let lw = config.line_width.max(1) as u32;
    render(config, MIN_SIDE, |root| {
        let area = titled(root, &line_chart.title)?;
        let (legend, area) = area.split_vertically(LEGEND_ROW);
        let all = || line_chart.series.iter().flat_map(|s| s.points.iter());
        let x = range_of(all().map(|p| p.0), 1.0, 0.0).unwrap_or((0.0, 1.0));
        let y_max = range_of(all().map(|p| p.1), 0.0, 0.0).map_or(1.0, |r| r.1.max(1e-9));
        let mut chart = chart(&area, x, (0.0, 1.1 * y_max))?;
        draw_mesh(&mut chart, &line_chart.x_title, &line_chart.y_title)?;
        for (i, series) in line_chart.series.iter().enumerate() {
            polyline(
                &mut chart,
                &series.points,
                rgb(series_color(i)).stroke_width(lw),
            )?;
        }
        draw_legend_row(&legend, line_chart)
    })
}

/// The legend as one row above the panel, right-aligned (outside the data, so it never
/// hides a peak): a colour swatch and the label of each series.
fn draw_legend_row(area: &Area, chart: &LineChart) -> Result<(), PlotError> {
    const SWATCH: i32 = 24;
    const GAP: i32 = 8;
    const SPACING: i32 = 24;
    let font = (FONT, LEGEND_SIZE).into_font().color(&INK);
    let mut widths = Vec::with_capacity(chart.series.len());
    for series in &chart.series {
        let (w, _) = area.estimate_text_size(&series.label, &font)?;
        widths.push(SWATCH + GAP + i32::try_from(w).unwrap_or(0));
    }
    let total: i32 = widths.iter().map(|w| w + SPACING).sum::<i32>() - SPACING;
    let (width, height) = area.dim_in_pixel();
    let right = i32::try_from(width).unwrap_or(0) - crate::canvas::MARGIN as i32;
    let mid = i32::try_from(height).unwrap_or(0) / 2;
    let mut x = right - total;
    for (i, (series, w)) in chart.series.iter().zip(&widths).enumerate() {
        let color = rgb(series_color(i));
        area.draw(&PathElement::new(
            vec![(x, mid), (x + SWATCH, mid)],
            color.stroke_width(4),
        ))?;
        area.draw(&Text::new(
            series.label.as_str(),
            (x + SWATCH + GAP, mid - LEGEND_SIZE as i32 / 2 - 1),
            font.clone(),
        ))?;
        x += w + SPACING;
    }
    Ok(())
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

    fn count_in(image: &RgbImage, color: [u8; 3], x_from: u32, x_to: u32) -> usize {
        image
            .enumerate_pixels()
            .filter(|(x, _, p)| (x_from..x_to).contains(x) && p.0 == color)
            .count()
    }

    fn two_series() -> LineChart {
        LineChart {
            title: "Processing time per stage".into(),
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

    /// Columns of the plotting area: where the colour of the full series is on its row.
    fn plot_columns(image: &RgbImage, row: u32, color: [u8; 3]) -> (u32, u32) {
        let xs: Vec<u32> = (0..image.width())
            .filter(|&x| image.get_pixel(x, row).0 == color)
            .collect();
        (xs[0], *xs.last().unwrap())
    }

    #[test]
    fn each_series_is_drawn_where_its_frames_are() {
        let config = PlotConfig {
            width: 800,
            height: 400,
            line_width: 2,
        };
        let image = render_line_chart(&two_series(), &config).unwrap();
        assert_eq!(image.dimensions(), (800, 400));
        let (c0, c1) = (series_color(0), series_color(1));
        // The first series is flat at 10 ms, the top of the y range 11 ms: one row
        // (2 px wide) across the plotting area, about 1/11 of the height from its top.
        let row = (0..image.height())
            .find(|&y| (300..400).all(|x| image.get_pixel(x, y).0 == c0))
            .expect("a row of the first series");
        let (left, right) = plot_columns(&image, row, c0);
        assert!(right - left > 550, "{left}..{right}");
        // The second series, 2 ms, starts at frame 50: half-way across.
        let row1 = (row + 5..image.height())
            .find(|&y| image.get_pixel(right - 5, y).0 == c1)
            .expect("a row of the second series");
        let (start, end) = plot_columns(&image, row1, c1);
        let middle = f64::from(left + right) / 2.0;
        assert!(
            (f64::from(start) - middle).abs() < 6.0,
            "{start} vs {middle}"
        );
        assert!(end + 2 >= right, "{end} vs {right}");
        // The y axis runs from 0 to 1.1 x 10 ms: row(y) = top + (11 - y) / 11 x height,
        // so the 10 ms and 2 ms rows are 8/11 of the height apart and 10 ms is 1/11 of it
        // below the top; the panel fills what the title and legend leave (~300 px).
        let height = f64::from(row1 - row) * 11.0 / 8.0;
        let top = f64::from(row) - height / 11.0;
        assert!((250.0..320.0).contains(&height), "{height}");
        assert!((40.0..110.0).contains(&top), "{top}");
        // Left of frame 50 the second colour appears only in the legend (above the row).
        let stray = (row..image.height())
            .flat_map(|y| (0..start.saturating_sub(3)).map(move |x| (x, y)))
            .filter(|&(x, y)| image.get_pixel(x, y).0 == c1)
            .count();
        assert_eq!(stray, 0);
        assert!(count_in(&image, c1, 0, 800) > 600);
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
