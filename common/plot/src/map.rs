//! The map figure: a top view (left) and a perspective view (right) of the map points
//! coloured by height, the lines and plane patches coloured by Manhattan axis, and the
//! keyframe path against the ground truth when there is one.

use crate::canvas::{
    Area, FONT, INK, LABEL_SIZE, MIN_SIDE, PlotConfig, PlotError, chart, draw_legend, draw_mesh,
    plot_size, polyline, render, rgb, save_png, swatch, titled, widened,
};
use gfs_core::scene::Scene;
use image::RgbImage;
use nalgebra::{Matrix3, Point3, Vector3};
use plotters::prelude::*;
use std::path::Path;

/// Colours of the Manhattan axes 0, 1, 2 (red, green, blue as in RViz) and of lines
/// and planes without one.
const AXIS_COLORS: [[u8; 3]; 3] = [[215, 40, 40], [30, 150, 60], [40, 80, 220]];
const NO_AXIS_COLOR: [u8; 3] = [120, 120, 120];
const PATH_COLOR: [u8; 3] = [20, 20, 20];
const GT_COLOR: [u8; 3] = [235, 110, 20];
/// Largest angle between the first camera's up and a Manhattan axis taken as up.
const SNAP_UP_DEG: f64 = 30.0;
/// Quantiles of the points kept in the view (the rest are strays far off the map).
const VIEW_QUANTILES: (f64, f64) = (0.02, 0.98);

/// What the map figure shows.
#[derive(Clone, Copy, Debug)]
pub struct MapFigure<'a> {
    /// The map.
    pub scene: &'a Scene,
    /// Ground-truth camera positions in the map's world frame (empty without).
    pub ground_truth: &'a [Point3<f64>],
}

fn axis_color(axis: Option<u8>) -> RGBColor {
    rgb(axis.map_or(NO_AXIS_COLOR, |k| AXIS_COLORS[usize::from(k % 3)]))
}

/// The view frame: right, up and forward of the first keyframe. With Manhattan axes,
/// up snaps to the axis nearest to it when within [`SNAP_UP_DEG`] (a level floor; a
/// camera pitched further keeps its own up), and right then to the nearest other axis,
/// so that walls are drawn upright and square to the page.
fn view_frame(scene: &Scene) -> Matrix3<f64> {
    let rotation = scene
        .keyframes
        .first()
        .map_or_else(Matrix3::identity, |kf| {
            kf.rotation.to_rotation_matrix().into_inner()
        });
    // Camera optical frame: x right, y down, z forward.
    let (mut right, mut up) = (
        rotation.column(0).into_owned(),
        -rotation.column(1).into_owned(),
    );
    let nearest = |axes: &[Vector3<f64>; 3], to: &Vector3<f64>| {
        let best = axes
            .iter()
            .max_by(|a, b| a.dot(to).abs().total_cmp(&b.dot(to).abs()))
            .copied()
            .unwrap_or(*to);
        best * best.dot(to).signum()
    };
    if let Some(axes) = &scene.axes {
        let snapped = nearest(axes, &up);
        if snapped.dot(&up) >= SNAP_UP_DEG.to_radians().cos() {
            up = snapped;
            let others: Vec<Vector3<f64>> = axes
                .iter()
                .filter(|a| a.dot(&up).abs() < 0.5)
                .copied()
                .collect();
            if let [a, b] = others[..] {
                right = nearest(&[a, b, a], &right);
            }
        }
    }
    let right = (right - right.dot(&up) * up)
        .try_normalize(1e-9)
        .unwrap_or_else(|| up.cross(&Vector3::z()).normalize());
    let forward = up.cross(&right);
    Matrix3::from_rows(&[right.transpose(), up.transpose(), forward.transpose()])
}

/// `p` in the view frame: (right, up, forward).
fn to_view(frame: &Matrix3<f64>, p: &Point3<f64>) -> (f64, f64, f64) {
    let v = frame * p.coords;
    (v.x, v.y, v.z)
}

/// The `q` quantile of `values` (sorted here); 0 when empty.
fn quantile(values: &mut [f64], q: f64) -> f64 {
    values.sort_unstable_by(f64::total_cmp);
    match values.len() {
        0 => 0.0,
        n => values[((q * (n - 1) as f64).round() as usize).min(n - 1)],
    }
}

/// Everything in the view frame, with the box that holds the path and most points.
struct View {
    points: Vec<(f64, f64, f64)>,
    path: Vec<(f64, f64, f64)>,
    ground_truth: Vec<(f64, f64, f64)>,
    lo: [f64; 3],
    hi: [f64; 3],
    /// Height range of the colour map.
    heights: (f64, f64),
}

impl View {
    fn new(figure: &MapFigure) -> Self {
        let frame = view_frame(figure.scene);
        let points: Vec<_> = figure
            .scene
            .points
            .iter()
            .map(|p| to_view(&frame, p))
            .collect();
        let path: Vec<_> = figure
            .scene
            .keyframes
            .iter()
            .map(|kf| to_view(&frame, &Point3::from(kf.translation.vector)))
            .collect();
        let ground_truth: Vec<_> = figure
            .ground_truth
            .iter()
            .map(|p| to_view(&frame, p))
            .collect();
        let coordinate = |k: usize, p: &(f64, f64, f64)| [p.0, p.1, p.2][k];
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for k in 0..3 {
            let mut values: Vec<f64> = points.iter().map(|p| coordinate(k, p)).collect();
            if !values.is_empty() {
                lo[k] = quantile(&mut values, VIEW_QUANTILES.0);
                hi[k] = quantile(&mut values, VIEW_QUANTILES.1);
            }
            for p in path.iter().chain(&ground_truth) {
                lo[k] = lo[k].min(coordinate(k, p));
                hi[k] = hi[k].max(coordinate(k, p));
            }
            if lo[k] > hi[k] {
                (lo[k], hi[k]) = (-1.0, 1.0);
            }
            let pad = 0.05 * (hi[k] - lo[k]).max(0.2);
            (lo[k], hi[k]) = (lo[k] - pad, hi[k] + pad);
        }
        let mut heights: Vec<f64> = points.iter().map(|p| p.1).collect();
        let heights = (
            quantile(&mut heights, VIEW_QUANTILES.0),
            quantile(&mut heights, VIEW_QUANTILES.1)
                .max(heights.first().copied().unwrap_or(0.0) + 1e-3),
        );
        Self {
            points,
            path,
            ground_truth,
            lo,
            hi,
            heights,
        }
    }

    fn inside(&self, p: &(f64, f64, f64)) -> bool {
        let c = [p.0, p.1, p.2];
        (0..3).all(|k| (self.lo[k]..=self.hi[k]).contains(&c[k]))
    }

    fn height_color(&self, height: f64) -> RGBColor {
        ViridisRGB.get_color_normalized(height, self.heights.0, self.heights.1)
    }
}

/// Renders the map figure.
///
/// # Errors
/// [`PlotError::TooSmall`] when the configured size has no room for the panels.
pub fn render_map(figure: &MapFigure, config: &PlotConfig) -> Result<RgbImage, PlotError> {
    let half = u32::try_from(config.width / 2).unwrap_or(u32::MAX);
    let lw = config.line_width.max(1) as u32;
    let view = View::new(figure);
    let frame = view_frame(figure.scene);
    render(config, 2 * MIN_SIDE, |root| {
        let (left, right) = root.split_horizontally(half);
        top_view(&left, figure, &view, &frame, lw)?;
        perspective(&right, figure, &view, &frame, lw)
    })
}

/// Looking down along "up": right across, forward up the page, equal scales.
fn top_view(
    area: &Area,
    figure: &MapFigure,
    view: &View,
    frame: &Matrix3<f64>,
    lw: u32,
) -> Result<(), PlotError> {
    let scene = figure.scene;
    let area = titled(
        area,
        &format!(
            "Map from above: {} points, {} lines, {} planes",
            scene.points.len(),
            scene.lines.len(),
            scene.planes.len()
        ),
    )?;
    let (pw, ph) = plot_size(&area);
    let (x, y) = ((view.lo[0], view.hi[0]), (view.lo[2], view.hi[2]));
    let metres_per_px = ((x.1 - x.0) / pw).max((y.1 - y.0) / ph);
    let mut chart = chart(
        &area,
        widened(x, metres_per_px * pw),
        widened(y, metres_per_px * ph),
    )?;
    draw_mesh(&mut chart, "right (m)", "forward (m)")?;
    let top = |p: &Point3<f64>| {
        let v = to_view(frame, p);
        (v.0, v.2)
    };
    chart.draw_series(scene.planes.iter().map(|plane| {
        Polygon::new(
            plane.corners.iter().map(top).collect::<Vec<_>>(),
            axis_color(plane.axis).mix(0.25).filled(),
        )
    }))?;
    chart.draw_series(
        view.points
            .iter()
            .filter(|p| view.inside(p))
            .map(|p| Circle::new((p.0, p.2), 1, view.height_color(p.1).filled())),
    )?;
    chart.draw_series(scene.lines.iter().map(|line| {
        PathElement::new(
            line.ends.iter().map(top).collect::<Vec<_>>(),
            axis_color(line.axis).stroke_width(2),
        )
    }))?;
    let flat =
        |path: &[(f64, f64, f64)]| -> Vec<(f64, f64)> { path.iter().map(|p| (p.0, p.2)).collect() };
    if !view.ground_truth.is_empty() {
        polyline(
            &mut chart,
            &flat(&view.ground_truth),
            rgb(GT_COLOR).stroke_width(lw),
        )?
        .label("ground truth (aligned)")
        .legend(swatch(rgb(GT_COLOR)));
    }
    polyline(
        &mut chart,
        &flat(&view.path),
        rgb(PATH_COLOR).stroke_width(lw),
    )?
    .label(format!("keyframes ({})", view.path.len()))
    .legend(swatch(rgb(PATH_COLOR)));
    for (k, name) in ["x", "y", "z"].iter().enumerate() {
        chart
            .draw_series(std::iter::empty::<Circle<(f64, f64), u32>>())?
            .label(format!("lines, planes along Manhattan {name}"))
            .legend(swatch(rgb(AXIS_COLORS[k])));
    }
    draw_legend(&mut chart)
}

/// From behind and above the start, the map in a cube of equal scales.
fn perspective(
    area: &Area,
    figure: &MapFigure,
    view: &View,
    frame: &Matrix3<f64>,
    lw: u32,
) -> Result<(), PlotError> {
    let scene = figure.scene;
    let area = titled(
        area,
        &format!(
            "Perspective (height {:.2} .. {:.2} m, colour of points)",
            view.heights.0, view.heights.1
        ),
    )?;
    let half = (0..3)
        .map(|k| 0.5 * (view.hi[k] - view.lo[k]))
        .fold(0.1, f64::max);
    let centre: [f64; 3] = std::array::from_fn(|k| 0.5 * (view.lo[k] + view.hi[k]));
    let range = |k: usize| centre[k] - half..centre[k] + half;
    let mut chart = ChartBuilder::on(&area)
        .margin(crate::canvas::MARGIN)
        .build_cartesian_3d(range(0), range(1), range(2))?;
    chart.with_projection(|mut projection| {
        projection.yaw = 0.55;
        projection.pitch = 0.35;
        projection.scale = 0.8;
        projection.into_matrix()
    });
    chart
        .configure_axes()
        .label_style((FONT, LABEL_SIZE - 4).into_font().color(&INK))
        .light_grid_style(WHITE)
        .bold_grid_style(RGBColor(225, 225, 225))
        .max_light_lines(0)
        .draw()?;
    let in_cube = |p: &(f64, f64, f64)| {
        let c = [p.0, p.1, p.2];
        (0..3).all(|k| range(k).contains(&c[k]))
    };
    let at = |p: &Point3<f64>| to_view(frame, p);
    let planes = scene
        .planes
        .iter()
        .filter(|plane| plane.corners.iter().map(at).all(|p| in_cube(&p)));
    chart.draw_series(planes.map(|plane| {
        Polygon::new(
            plane.corners.iter().map(at).collect::<Vec<_>>(),
            axis_color(plane.axis).mix(0.25).filled(),
        )
    }))?;
    chart.draw_series(
        view.points
            .iter()
            .filter(|p| view.inside(p) && in_cube(p))
            .map(|p| Circle::new(*p, 1, view.height_color(p.1).filled())),
    )?;
    chart.draw_series(
        scene
            .lines
            .iter()
            .filter(|l| l.ends.iter().map(at).all(|p| in_cube(&p)))
            .map(|line| {
                PathElement::new(
                    line.ends.iter().map(at).collect::<Vec<_>>(),
                    axis_color(line.axis).stroke_width(2),
                )
            }),
    )?;
    for (path, color) in [(&view.ground_truth, GT_COLOR), (&view.path, PATH_COLOR)] {
        chart.draw_series(
            path.windows(2)
                .map(|w| PathElement::new(vec![w[0], w[1]], rgb(color).stroke_width(lw))),
        )?;
    }
    Ok(())
}

/// Renders the map figure and writes it as a PNG.
///
/// # Errors
/// [`PlotError::TooSmall`], or [`PlotError::Write`] naming the file that could not be
/// encoded or written.
pub fn write_map_png(
    figure: &MapFigure,
    path: &Path,
    config: &PlotConfig,
) -> Result<(), PlotError> {
    save_png(&render_map(figure, config)?, path)
}

#[cfg(test)]
mod tests {
    use super::*;
    use gfs_core::scene::{SceneLine, ScenePlane};
    use nalgebra::{Isometry3, Translation3, UnitQuaternion};

    /// A camera 1.5 m above a floor (camera y down), walking 2 m forward; floor points,
    /// a line along the first axis 1.5 m above it and a floor patch.
    fn room() -> Scene {
        let level = UnitQuaternion::identity();
        let keyframes = (0..5)
            .map(|k| Isometry3::from_parts(Translation3::new(0.0, 0.0, 0.5 * f64::from(k)), level))
            .collect();
        let points = (0..40)
            .flat_map(|i| {
                (0..40).map(move |j| {
                    Point3::new(-1.0 + 0.05 * f64::from(i), 1.5, 0.5 + 0.05 * f64::from(j))
                })
            })
            .collect();
        Scene {
            points,
            lines: vec![SceneLine {
                ends: [Point3::new(-0.5, 0.0, 2.0), Point3::new(0.5, 0.0, 2.0)],
                axis: Some(0),
            }],
            planes: vec![ScenePlane {
                corners: [
                    Point3::new(-1.0, 1.5, 0.5),
                    Point3::new(1.0, 1.5, 0.5),
                    Point3::new(1.0, 1.5, 2.5),
                    Point3::new(-1.0, 1.5, 2.5),
                ],
                normal: -Vector3::y(),
                axis: Some(1),
            }],
            keyframes,
            axes: Some([Vector3::x(), Vector3::y(), Vector3::z()]),
        }
    }

    fn count(image: &RgbImage, color: [u8; 3], x_from: u32, x_to: u32) -> usize {
        image
            .enumerate_pixels()
            .filter(|(x, _, p)| (x_from..x_to).contains(x) && p.0 == color)
            .count()
    }

    #[test]
    fn both_views_draw_the_line_the_path_and_the_ground_truth() {
        let scene = room();
        let ground_truth: Vec<Point3<f64>> = (0..5)
            .map(|k| Point3::new(0.1, 0.0, 0.5 * f64::from(k)))
            .collect();
        let figure = MapFigure {
            scene: &scene,
            ground_truth: &ground_truth,
        };
        let image = render_map(&figure, &PlotConfig::default()).unwrap();
        assert_eq!(image.dimensions(), (1400, 640));
        for (from, to) in [(0, 700), (700, 1400)] {
            // The 1 m line, 2 px wide, over a panel of ~2.5 m: > 200 px in either view
            // (the legend's swatch adds ~100 in the top view).
            let line = count(&image, AXIS_COLORS[0], from, to);
            assert!(line > 200, "{line} in {from}..{to}");
            assert!(count(&image, PATH_COLOR, from, to) > 100);
            assert!(count(&image, GT_COLOR, from, to) > 100);
        }
    }

    #[test]
    fn points_are_coloured_by_height_and_the_view_is_level() {
        let scene = room();
        let frame = view_frame(&scene);
        // Camera y down: up is -y, forward is +z, right is +x.
        let (r, u, f) = to_view(&frame, &Point3::new(1.0, 2.0, 3.0));
        assert!((r - 1.0).abs() < 1e-9 && (u + 2.0).abs() < 1e-9 && (f - 3.0).abs() < 1e-9);
        let figure = MapFigure {
            scene: &scene,
            ground_truth: &[],
        };
        let view = View::new(&figure);
        // Every point is at height -1.5: one colour, the low end of the map.
        assert!((view.heights.0 + 1.5).abs() < 1e-9, "{:?}", view.heights);
        assert_eq!(
            view.height_color(-1.5),
            ViridisRGB.get_color_normalized(0.0, 0.0, 1.0)
        );
        // The view box holds the path and the points (x -1..0.95, forward 0..2.45).
        assert!(view.lo[0] < -1.0 && view.hi[0] > 0.95 && view.lo[2] < 0.0 && view.hi[2] > 2.45);
    }

    #[test]
    fn an_empty_map_draws_and_a_bad_path_is_named() {
        let scene = Scene::default();
        let figure = MapFigure {
            scene: &scene,
            ground_truth: &[],
        };
        assert!(render_map(&figure, &PlotConfig::default()).is_ok());
        let bad = write_map_png(
            &figure,
            Path::new("/nonexistent/dir/m.png"),
            &PlotConfig::default(),
        );
        assert!(matches!(bad, Err(PlotError::Write { .. })));
    }
}
