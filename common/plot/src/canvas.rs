//! What every figure shares: size settings, errors, the font, colours, the RGB buffer
//! `plotters` draws into and its PNG encoding.

use image::RgbImage;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::{FontStyle, register_font};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use thiserror::Error;

/// Family name under which the embedded font is registered with `plotters`.
pub(crate) const FONT: &str = "sans-serif";
/// Text sizes in pixels: titles, axis descriptions and tick labels, legends.
pub(crate) const TITLE_SIZE: u32 = 24;
pub(crate) const LABEL_SIZE: u32 = 18;
pub(crate) const LEGEND_SIZE: u32 = 17;
/// Colour of text and the frame.
pub(crate) const INK: RGBColor = RGBColor(20, 20, 20);

/// Series colours in order (a qualitative palette that stays apart on white); the
/// ninth series reuses the first colour.
pub const SERIES_COLORS: [[u8; 3]; 8] = [
    [31, 100, 200],
    [235, 110, 20],
    [40, 160, 60],
    [200, 30, 30],
    [140, 80, 190],
    [120, 90, 60],
    [0, 150, 160],
    [110, 110, 110],
];

/// The colour of series `index`.
pub fn series_color(index: usize) -> [u8; 3] {
    SERIES_COLORS[index % SERIES_COLORS.len()]
}

pub(crate) fn rgb(c: [u8; 3]) -> RGBColor {
    RGBColor(c[0], c[1], c[2])
}

/// Size of a figure.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlotConfig {
    /// Image width in pixels. Default 1400 (two 700-pixel panels).
    pub width: usize,
    /// Image height in pixels. Default 640.
    pub height: usize,
    /// Line width of trajectories and series in pixels. Default 2.
    pub line_width: usize,
}

impl Default for PlotConfig {
    fn default() -> Self {
        Self {
            width: 1400,
            height: 640,
            line_width: 2,
        }
    }
}

/// Smallest side of a panel that leaves room for its labels.
pub(crate) const MIN_SIDE: usize = 200;

/// The figure could not be made or written.
#[derive(Debug, Error)]
pub enum PlotError {
    /// The configured size leaves no room for the panels.
    #[error("plot size {width}x{height} is too small (at least {min_width}x{MIN_SIDE})")]
    TooSmall {
        /// Configured width.
        width: usize,
        /// Configured height.
        height: usize,
        /// Smallest width of this figure.
        min_width: usize,
    },
    /// Drawing failed (the plotting library's message).
    #[error("cannot draw the plot: {0}")]
    Draw(String),
    /// The PNG could not be encoded or written.
    #[error("{path}: cannot write the plot: {message}", path = path.display())]
    Write {
        /// The output file.
        path: PathBuf,
        /// The encoder's or file system's message.
        message: String,
    },
}

impl<E: std::error::Error + Send + Sync> From<DrawingAreaErrorKind<E>> for PlotError {
    fn from(e: DrawingAreaErrorKind<E>) -> Self {
        PlotError::Draw(e.to_string())
    }
}

/// Registers the embedded font once per process (plotters keeps a global table).
pub(crate) fn register_fonts() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        register_font(
            FONT,
            FontStyle::Normal,
            include_bytes!("../fonts/DejaVuSans.ttf"),
        )
        .is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(PlotError::Draw(
            "the embedded font DejaVuSans.ttf cannot be read".into(),
        ))
    }
}

/// The drawing area of a white `width` x `height` figure.
pub(crate) type Area<'a> = DrawingArea<BitMapBackend<'a>, plotters::coord::Shift>;

/// Draws a white figure of `config`'s size with `draw` and returns its pixels.
///
/// # Errors
/// [`PlotError::TooSmall`] below `min_width` x [`MIN_SIDE`], or what `draw` returns.
pub(crate) fn render(
    config: &PlotConfig,
    min_width: usize,
    draw: impl FnOnce(&Area) -> Result<(), PlotError>,
) -> Result<RgbImage, PlotError> {
    let (w, h) = (config.width, config.height);
    if w < min_width || h < MIN_SIDE {
        return Err(PlotError::TooSmall {
            width: w,
            height: h,
            min_width,
        });
    }
    register_fonts()?;
    let (wu, hu) = (
        u32::try_from(w).map_err(|e| PlotError::Draw(e.to_string()))?,
        u32::try_from(h).map_err(|e| PlotError::Draw(e.to_string()))?,
    );
    let mut buffer = vec![255u8; w * h * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buffer, (wu, hu)).into_drawing_area();
        draw(&root)?;
        root.present()?;
    }
    RgbImage::from_raw(wu, hu, buffer).ok_or_else(|| PlotError::Draw("buffer size".into()))
}

/// Writes `image` as a PNG to `path`.
///
/// # Errors
/// [`PlotError::Write`] naming the file that could not be encoded or written.
pub(crate) fn save_png(image: &RgbImage, path: &Path) -> Result<(), PlotError> {
    image
        .save_with_format(path, image::ImageFormat::Png)
        .map_err(|e| PlotError::Write {
            path: path.to_path_buf(),
            message: e.to_string(),
        })
}

/// Data range `[lo, hi]` of the finite `values`, at least `min_span` wide and padded by
/// `pad` of its span on both sides; `None` without a finite value.
pub(crate) fn range_of(
    values: impl Iterator<Item = f64>,
    min_span: f64,
    pad: f64,
) -> Option<(f64, f64)> {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if lo > hi {
        return None;
    }
    let mid = 0.5 * (lo + hi);
    let half = 0.5 * (hi - lo).max(min_span) * (1.0 + 2.0 * pad);
    Some((mid - half, mid + half))
}

/// `range` grown about its middle to `span` (never shrunk).
pub(crate) fn widened(range: (f64, f64), span: f64) -> (f64, f64) {
    let extra = 0.5 * (span - (range.1 - range.0)).max(0.0);
    (range.0 - extra, range.1 + extra)
}

/// Space around a chart, and for its tick labels and axis descriptions, in pixels.
pub(crate) const MARGIN: u32 = 16;
pub(crate) const X_LABEL_AREA: u32 = 50;
pub(crate) const Y_LABEL_AREA: u32 = 80;

/// A chart with linear axes in data units.
pub(crate) type Chart<'a, 'b> =
    ChartContext<'a, BitMapBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// A chart on `area` (its title already drawn) over `x` x `y`.
pub(crate) fn chart<'a, 'b>(
    area: &'a Area<'b>,
    x: (f64, f64),
    y: (f64, f64),
) -> Result<Chart<'a, 'b>, PlotError> {
    Ok(ChartBuilder::on(area)
        .margin(MARGIN)
        .x_label_area_size(X_LABEL_AREA)
        .y_label_area_size(Y_LABEL_AREA)
        .build_cartesian_2d(x.0..x.1, y.0..y.1)?)
}

/// Pixel size of the plotting area that [`chart`] leaves on `area`.
pub(crate) fn plot_size(area: &Area) -> (f64, f64) {
    let (w, h) = area.dim_in_pixel();
    (
        f64::from(w.saturating_sub(2 * MARGIN + Y_LABEL_AREA).max(1)),
        f64::from(h.saturating_sub(2 * MARGIN + X_LABEL_AREA).max(1)),
    )
}

/// `area` below its title.
pub(crate) fn titled<'b>(area: &Area<'b>, title: &str) -> Result<Area<'b>, PlotError> {
    Ok(area
        .margin(8, 0, 0, 0)
        .titled(title, (FONT, TITLE_SIZE).into_font().color(&INK))?)
}

/// A polyline of data points drawn segment by segment: a joined thick path gets long
/// miter spikes at the sharp turns of a noisy trajectory.
pub(crate) fn polyline<'a, 'b: 'a, 'c>(
    chart: &'c mut Chart<'a, 'b>,
    points: &[(f64, f64)],
    style: ShapeStyle,
) -> Result<&'c mut plotters::chart::SeriesAnno<'a, BitMapBackend<'b>>, PlotError> {
    let finite: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|p| p.0.is_finite() && p.1.is_finite())
        .collect();
    Ok(chart.draw_series(
        finite
            .windows(2)
            .map(move |w| PathElement::new(vec![w[0], w[1]], style)),
    )?)
}

/// A tick label with as many decimals as ticks `step` apart need.
fn tick_label(value: f64, step: f64) -> String {
    let decimals = (-(step.abs().max(1e-12)).log10().floor()).clamp(0.0, 6.0) as usize;
    let text = format!("{value:.decimals$}");
    // "-0.0" reads as noise on an axis.
    if text.starts_with('-') && text[1..].chars().all(|c| c == '0' || c == '.') {
        text[1..].to_owned()
    } else {
        text
    }
}

/// Grid, ticks and axis descriptions.
pub(crate) fn draw_mesh(chart: &mut Chart, x_desc: &str, y_desc: &str) -> Result<(), PlotError> {
    let (x, y) = (chart.x_range(), chart.y_range());
    let (x_step, y_step) = ((x.end - x.start) / 8.0, (y.end - y.start) / 8.0);
    let x_label = move |v: &f64| tick_label(*v, x_step);
    let y_label = move |v: &f64| tick_label(*v, y_step);
    chart
        .configure_mesh()
        .x_label_formatter(&x_label)
        .y_label_formatter(&y_label)
        .x_desc(x_desc)
        .y_desc(y_desc)
        .x_labels(8)
        .y_labels(8)
        .label_style((FONT, LABEL_SIZE).into_font().color(&INK))
        .axis_desc_style((FONT, LABEL_SIZE).into_font().color(&INK))
        .bold_line_style(RGBColor(225, 225, 225))
        .light_line_style(WHITE)
        .axis_style(INK)
        .draw()?;
    Ok(())
}

/// The legend box in the upper-left corner of the plotting area.
pub(crate) fn draw_legend<'a, 'b: 'a>(chart: &mut Chart<'a, 'b>) -> Result<(), PlotError> {
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(INK)
        .label_font((FONT, LEGEND_SIZE).into_font().color(&INK))
        .draw()?;
    Ok(())
}

/// A legend swatch: a short thick line in `color`.
pub(crate) fn swatch(color: RGBColor) -> impl Fn((i32, i32)) -> PathElement<(i32, i32)> {
    move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], color.stroke_width(4))
}
