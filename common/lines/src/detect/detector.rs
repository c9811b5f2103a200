//! [`LineDetector`]: the reusable EDLines detector that owns every per-frame buffer.

use gfs_core::{Image, ImageView};

use super::anchors::find_anchors;
use super::config::DetectConfig;
use super::drawing::{Chains, draw_edges};
use super::fit::Fitter;
use super::gradient::Gradients;
use super::nfa::{NfaTable, validate};
use super::smooth::gaussian_5x5;
use crate::join::{GradientField, JoinScratch, join_lines};
use crate::{DetectedLine, Segment};

/// EDLines detector plus ELSED-style joining, with all scratch reused frame after frame
/// (buffers only grow when a larger frame arrives; that changes allocation, not results).
///
/// ```
/// use gfs_core::Image;
/// use gfs_lines::{DetectConfig, LineDetector};
/// // A bright square on a dark background: four edges of 40 px.
/// let mut img = Image::new(80, 80);
/// for v in 20..60 {
///     for u in 20..60 {
///         img.set(u, v, 200u8);
///     }
/// }
/// let mut detector = LineDetector::new(DetectConfig::default());
/// let mut lines = Vec::new();
/// detector.detect(&img.view(), &mut lines);
/// detector.join(&mut lines);
/// assert_eq!(lines.len(), 4);
/// assert!(lines.iter().all(|l| l.segment.length() > 34.0));
/// ```
#[derive(Debug)]
pub struct LineDetector {
    config: DetectConfig,
    blur_scratch: Image<u16>,
    smooth: Image<u8>,
    gradients: Gradients,
    anchors: Vec<u64>,
    anchor_flags: Vec<u8>,
    chains: Chains,
    fitter: Fitter,
    fitted: Vec<[f32; 4]>,
    nfa: NfaTable,
    join: JoinScratch,
}

impl LineDetector {
    /// A detector with the given parameters; buffers are allocated on the first frame.
    /// Out-of-range values (see [`DetectConfig::validate`]) never panic: they are
    /// clamped to the nearest usable value when used.
    pub fn new(config: DetectConfig) -> Self {
        Self {
            config,
            blur_scratch: Image::new(0, 0),
            smooth: Image::new(0, 0),
            gradients: Gradients::new(),
            anchors: Vec::new(),
            anchor_flags: Vec::new(),
            chains: Chains::default(),
            fitter: Fitter::default(),
            fitted: Vec::new(),
            nfa: NfaTable::default(),
            join: JoinScratch::default(),
        }
    }

    /// The parameters.
    pub fn config(&self) -> &DetectConfig {
        &self.config
    }

    /// EDLines on `gray`: clears `out` and fills it with the validated segments, each
    /// oriented with the brighter side on the positive side of
    /// [`Segment::line_coefficients`], and with its mean Sobel magnitude `|gx| + |gy|` of
    /// the smoothed image. Images smaller than 3x3 (or too small for any segment to
    /// pass the NFA test) give no segment.
    pub fn detect(&mut self, gray: &ImageView<'_, u8>, out: &mut Vec<DetectedLine>) {
        out.clear();
        let cfg = &self.config;
        let (w, h) = (gray.width(), gray.height());
        gaussian_5x5(gray, &mut self.blur_scratch, &mut self.smooth);
        self.gradients.compute(&self.smooth, cfg.gradient_threshold);
        if w < 3 || h < 3 {
            return;
        }
        let tolerance = f64::from(super::clamped(cfg.aligned_angle_deg, 0.1, 90.0)).to_radians();
        self.nfa
            .prepare(w, h, tolerance / std::f64::consts::PI, cfg.max_nfa);
        let min_length = self.nfa.min_length();
        if min_length > w.max(h) {
            return;
        }
        find_anchors(
            &self.gradients.magnitude,
            &self.gradients.state,
            cfg.anchor_threshold,
            cfg.scan_interval,
            &mut self.anchor_flags,
            &mut self.anchors,
        );
        draw_edges(
            &self.gradients.magnitude,
            &mut self.gradients.state,
            &self.anchors,
            min_length,
            &mut self.chains,
        );
        self.fitted.clear();
        let max_error = f64::from(cfg.max_fit_error.max(0.1));
        for chain in self.chains.iter() {
            self.fitter.fit_chain(
                chain,
                &self.gradients.magnitude,
                &self.gradients.state,
                min_length,
                max_error,
                &mut self.fitted,
            );
        }
        let cos_tolerance = tolerance.cos() as f32;
        for &[u0, v0, u1, v1] in &self.fitted {
            let evidence = validate(gray, [u0, v0, u1, v1], cos_tolerance, &mut self.nfa);
            if !evidence.valid {
                continue;
            }
            let segment = if evidence.bright_on_normal_side {
                Segment::new(u0, v0, u1, v1)
            } else {
                Segment::new(u1, v1, u0, v0)
            };
            out.push(DetectedLine {
                segment,
                mean_gradient: self.field().mean_magnitude(&segment),
            });
        }
    }

    /// ELSED-style joining of `lines` in place (see [`crate::join`]), using the gradients
    /// of the last [`Self::detect`] call: segments are extended along their direction
    /// while the gradient supports them, then collinear pieces across small gaps are
    /// merged. The lines come out longest first.
    pub fn join(&mut self, lines: &mut Vec<DetectedLine>) {
        let field = GradientField {
            gx: self.gradients.gx.view(),
            gy: self.gradients.gy.view(),
            magnitude: self.gradients.magnitude.view(),
            threshold: self.config.gradient_threshold,
        };
        join_lines(&self.config.join, &field, lines, &mut self.join);
    }

    /// Sobel derivative along u of the smoothed image of the last [`Self::detect`] call:
    /// 8 times the derivative in 0..255 gray levels per pixel (a step of 100 gives 400 on
    /// the two columns beside it), positive when brighter to the right, zero on the
    /// border; the frame size.
    pub fn gradient_x(&self) -> ImageView<'_, i16> {
        self.gradients.gx.view()
    }

    /// Sobel derivative along v of the smoothed image of the last [`Self::detect`] call,
    /// positive when brighter below; units as [`Self::gradient_x`].
    pub fn gradient_y(&self) -> ImageView<'_, i16> {
        self.gradients.gy.view()
    }

    fn field(&self) -> GradientField<'_> {
        GradientField {
            gx: self.gradients.gx.view(),
            gy: self.gradients.gy.view(),
            magnitude: self.gradients.magnitude.view(),
            threshold: self.config.gradient_threshold,
        }
    }
}
