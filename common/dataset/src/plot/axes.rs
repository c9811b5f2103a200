//! A plot panel: a pixel rectangle, the data range it shows, grid, ticks and labels.

use super::canvas::{Canvas, Rgb};

const FRAME: Rgb = [40, 40, 40];
const GRID: Rgb = [225, 225, 225];
const LABEL: Rgb = [20, 20, 20];
/// Font scale of tick labels and axis titles.
pub const TEXT_SCALE: usize = 2;
/// Ticks a panel aims at per axis.
const TARGET_TICKS: f64 = 6.0;

/// A data range `[lo, hi]` on one axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range {
    /// Lower end.
    pub lo: f64,
    /// Upper end.
    pub hi: f64,
}

impl Range {
    /// The range of `values` (finite ones), widened to at least `min_span` and padded by
    /// `pad` of its span on both sides. `None` without a finite value.
    pub fn of(values: impl Iterator<Item = f64>, min_span: f64, pad: f64) -> Option<Range> {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for v in values.filter(|v| v.is_finite()) {
            lo = lo.min(v);
            hi = hi.max(v);
        }
        if lo > hi {
            return None;
        }
        let mid = 0.5 * (lo + hi);
        let span = (hi - lo).max(min_span);
        let half = 0.5 * span * (1.0 + 2.0 * pad);
        Some(Range {
            lo: mid - half,
            hi: mid + half,
        })
    }

    /// Width of the range.
    pub fn span(&self) -> f64 {
        self.hi - self.lo
    }

    /// The same range grown about its middle to `span` (never shrunk).
    pub fn widened_to(&self, span: f64) -> Range {
        let extra = 0.5 * (span - self.span()).max(0.0);
        Range {
            lo: self.lo - extra,
            hi: self.hi + extra,
        }
    }
}

/// A "nice" tick step (1, 2 or 5 times a power of ten) giving about `TARGET_TICKS`
/// ticks over `span`.
pub fn nice_step(span: f64) -> f64 {
    let raw = (span / TARGET_TICKS).max(1e-12);
    let magnitude = 10f64.powf(raw.log10().floor());
    let base = raw / magnitude;
    let nice = if base < 1.5 {
        1.0
    } else if base < 3.5 {
        2.0
    } else if base < 7.5 {
        5.0
    } else {
        10.0
    };
    nice * magnitude
}

/// A tick value printed with as many decimals as the step needs.
pub fn tick_label(value: f64, step: f64) -> String {
    let decimals = (-step.log10().floor()).clamp(0.0, 6.0) as usize;
    let text = format!("{value:.decimals$}");
    // "-0.0" reads as noise on an axis.
    if text.starts_with('-') && text[1..].chars().all(|c| c == '0' || c == '.') {
        text[1..].to_owned()
    } else {
        text
    }
}

/// A panel mapping data `(x, y)` into the pixel rectangle `[left, right] x [top, bottom]`.
pub struct Panel {
    /// Left pixel column of the plotting area.
    pub left: f64,
    /// Top pixel row of the plotting area.
    pub top: f64,
    /// Right pixel column.
    pub right: f64,
    /// Bottom pixel row.
    pub bottom: f64,
    /// Data range along x.
    pub x: Range,
    /// Data range along y (drawn upwards).
    pub y: Range,
}

impl Panel {
    /// Pixel position of the data point (`x`, `y`).
    pub fn to_px(&self, x: f64, y: f64) -> (f64, f64) {
        let u = self.left + (x - self.x.lo) / self.x.span() * (self.right - self.left);
        let v = self.bottom - (y - self.y.lo) / self.y.span() * (self.bottom - self.top);
        (u, v)
    }

    /// Draws a polyline of data points.
    pub fn polyline(&self, canvas: &mut Canvas, points: &[(f64, f64)], width: usize, color: Rgb) {
        for w in points.windows(2) {
            let (a, b) = (self.to_px(w[0].0, w[0].1), self.to_px(w[1].0, w[1].1));
            canvas.line(a.0, a.1, b.0, b.1, width, color);
        }
        if let [only] = points {
            let p = self.to_px(only.0, only.1);
            canvas.dot(p.0, p.1, width + 2, color);
        }
    }

    /// Grid, frame, tick labels, axis titles and the panel title.
    pub fn draw_axes(&self, canvas: &mut Canvas, title: &str, x_title: &str, y_title: &str) {
        let (l, t, r, b) = (
            self.left.round() as i64,
            self.top.round() as i64,
            self.right.round() as i64,
            self.bottom.round() as i64,
        );
        let th = Canvas::text_height(TEXT_SCALE);
        for (range, vertical) in [(self.x, true), (self.y, false)] {
            let step = nice_step(range.span());
            let mut k = (range.lo / step).ceil();
            while k * step <= range.hi + 1e-9 * step {
                let value = k * step;
                let label = tick_label(value, step);
                let (px, py) = self.to_px(value, value);
                if vertical {
                    let x = px.round() as i64;
                    canvas.fill_rect(x, t, x + 1, b, GRID);
                    canvas.fill_rect(x, b, x + 1, b + 6, FRAME);
                    let w = Canvas::text_width(&label, TEXT_SCALE);
                    canvas.text(x - w / 2, b + 10, &label, TEXT_SCALE, LABEL);
                } else {
                    let y = py.round() as i64;
                    canvas.fill_rect(l, y, r, y + 1, GRID);
                    canvas.fill_rect(l - 6, y, l, y + 1, FRAME);
                    let w = Canvas::text_width(&label, TEXT_SCALE);
                    canvas.text(l - 10 - w, y - th / 2, &label, TEXT_SCALE, LABEL);
                }
                k += 1.0;
            }
        }
        canvas.rect_outline(l, t, r + 1, b + 1, FRAME);
        let w = Canvas::text_width(x_title, TEXT_SCALE);
        canvas.text((l + r) / 2 - w / 2, b + 22 + th, x_title, TEXT_SCALE, LABEL);
        canvas.text(l - 10, t - th - 8, y_title, TEXT_SCALE, LABEL);
        let w = Canvas::text_width(title, TEXT_SCALE);
        canvas.text(
            (l + r) / 2 - w / 2,
            t - 2 * th - 20,
            title,
            TEXT_SCALE,
            LABEL,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nice_steps_and_labels() {
        assert_eq!(nice_step(6.0), 1.0);
        assert_eq!(nice_step(1.2), 0.2);
        assert_eq!(nice_step(0.03), 0.005);
        assert_eq!(nice_step(500.0), 100.0);
        assert_eq!(tick_label(0.25, 0.05), "0.25");
        assert_eq!(tick_label(-1e-17, 0.2), "0.0");
        assert_eq!(tick_label(40.0, 10.0), "40");
    }

    #[test]
    fn ranges_pad_and_map_to_pixels() {
        let r = Range::of([1.0, 3.0, f64::NAN].into_iter(), 0.0, 0.25).unwrap();
        assert_eq!((r.lo, r.hi), (0.5, 3.5));
        let flat = Range::of([2.0, 2.0].into_iter(), 0.5, 0.0).unwrap();
        assert_eq!((flat.lo, flat.hi), (1.75, 2.25));
        assert!(Range::of([f64::NAN].into_iter(), 1.0, 0.0).is_none());
        let p = Panel {
            left: 10.0,
            top: 0.0,
            right: 110.0,
            bottom: 50.0,
            x: r,
            y: Range { lo: 0.0, hi: 1.0 },
        };
        assert_eq!(p.to_px(2.0, 1.0), (60.0, 0.0));
        assert_eq!(p.to_px(0.5, 0.0), (10.0, 50.0));
    }
}
