//! Range and relation checks of the tables the front-end crates do not check
//! themselves (`[camera]` focal lengths, `[depth]`, `[lines.grid]`,
//! `[lines.homogenise]`, `[lines.lbd]`, `[lines.lines3d]`, `[pipeline]`), plus the
//! odometry's, run when a config is read: a value that would make every frame fail is
//! an error naming its field, not a run of predicted poses.

use crate::config::Config;
use gfs_core::fields::{FieldError, Table};

impl Config {
    /// Checks every table not checked by its own crate.
    ///
    /// # Errors
    /// [`FieldError`] naming the first field out of range.
    pub(crate) fn validate_tables(&self) -> Result<(), FieldError> {
        self.validate_camera_and_depth()?;
        self.validate_lines()?;
        self.validate_pipeline()?;
        self.odometry().validate()
    }

    fn validate_camera_and_depth(&self) -> Result<(), FieldError> {
        let c = &self.camera;
        let t = Table("camera");
        // Focal lengths of 0.05..50 image widths: fields of view of 1 to 170 degrees.
        let width = c.width.max(1) as f64;
        let focal = |name, value: f64| {
            t.require(
                name,
                value,
                value.is_finite() && value >= 0.05 * width && value <= 50.0 * width,
                "between 0.05 and 50 image widths, pixels",
            )
        };
        focal("fx", c.fx)?;
        focal("fy", c.fy)?;
        t.require(
            "fy",
            c.fy,
            (0.5..=2.0).contains(&(c.fy / c.fx)),
            "within a factor 2 of camera.fx",
        )?;
        let d = Table("depth");
        d.positive("scale", self.depth.scale)?;
        let (min, max) = (f64::from(self.depth.min_m), f64::from(self.depth.max_m));
        d.not_below("min_m", min, 0.0)?;
        d.require(
            "max_m",
            max,
            max.is_finite() && max > min,
            "finite, above depth.min_m",
        )?;
        d.positive("baseline_m", self.depth.baseline_m)?;
        d.positive("disparity_sigma_px", self.depth.disparity_sigma_px)
    }

    fn validate_lines(&self) -> Result<(), FieldError> {
        let g = Table("lines.grid");
        g.at_least("cell_size", self.lines.grid.cell_size as u64, 1)?;
        let h = &self.lines.homogenise;
        let t = Table("lines.homogenise");
        t.at_least("fixed_target", h.fixed_target as u64, 1)?;
        t.positive("occupancy_scale", h.occupancy_scale.into())?;
        t.at_least("min_lines", h.min_lines as u64, 1)?;
        t.require(
            "min_lines",
            h.min_lines,
            h.min_lines <= h.max_lines,
            "at most lines.homogenise.max_lines",
        )?;
        t.positive("length_spread", h.length_spread.into())?;
        let b = Table("lines.lbd");
        b.at_least("band_width", self.lines.lbd.band_width as u64, 1)?;
        b.positive("step", self.lines.lbd.step.into())?;
        b.at_least("max_samples", self.lines.lbd.max_samples as u64, 2)?;
        let l = &self.lines.lines3d;
        let t = Table("lines.lines3d");
        t.positive("sample_step", l.sample_step.into())?;
        let (min, max) = (f64::from(l.min_depth), f64::from(l.max_depth));
        t.not_below("min_depth", min, 0.0)?;
        t.require(
            "max_depth",
            max,
            max.is_finite() && max > min,
            "above lines.lines3d.min_depth",
        )?;
        t.positive("noise_coefficient", l.noise_coefficient.into())?;
        t.positive("inlier_sigmas", l.inlier_sigmas.into())?;
        t.at_least("ransac_iterations", l.ransac_iterations as u64, 1)?;
        t.at_least("min_inliers", l.min_inliers as u64, 2)?;
        t.fraction("min_inlier_ratio", l.min_inlier_ratio.into())?;
        t.fraction("min_coverage", l.min_coverage.into())
    }

    fn validate_pipeline(&self) -> Result<(), FieldError> {
        let p = &self.pipeline;
        let t = Table("pipeline");
        t.at_least(
            "lockstep_feature_deadline_ms",
            p.lockstep_feature_deadline_ms,
            1,
        )?;
        t.at_least(
            "realtime_feature_deadline_ms",
            p.realtime_feature_deadline_ms,
            1,
        )?;
        t.at_least("resend_after_ms", p.resend_after_ms, 1)?;
        t.at_least("restart_window_s", p.restart_window_s, 1)?;
        t.at_least("realtime_ba_budget_ms", p.realtime_ba_budget_ms, 1)?;
        let deadline = p
            .lockstep_feature_deadline_ms
            .max(p.realtime_feature_deadline_ms);
        t.require(
            "hang_timeout_ms",
            p.hang_timeout_ms,
            p.hang_timeout_ms > deadline,
            "above both feature deadlines",
        )
    }
}

#[cfg(test)]
mod tests {
    use crate::config::Config;

    const CAMERA: &str =
        "[camera]\nfx=500.0\nfy=500.0\ncx=320.0\ncy=240.0\nwidth=640\nheight=480\n";

    fn error_of(tables: &str) -> String {
        Config::from_toml(&format!("{CAMERA}{tables}"), "t.toml")
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn nonsense_values_are_errors_naming_their_field_once() {
        assert!(Config::from_toml(CAMERA, "t.toml").is_ok());
        let cases = [
            ("[depth]\nscale = 0.0\n", "depth.scale = 0"),
            ("[depth]\nmin_m = 5.0\nmax_m = 1.0\n", "depth.max_m = 1"),
            ("[lines.grid]\ncell_size = 0\n", "lines.grid.cell_size = 0"),
            (
                "[lines.homogenise]\nmin_lines = 200\nmax_lines = 100\n",
                "lines.homogenise.min_lines = 200",
            ),
            (
                "[pipeline]\nlockstep_feature_deadline_ms = 0\n",
                "pipeline.lockstep_feature_deadline_ms = 0",
            ),
            (
                "[pipeline]\nrealtime_feature_deadline_ms = 0\n",
                "pipeline.realtime_feature_deadline_ms = 0",
            ),
            ("[tracking]\nmin_inliers = 0\n", "tracking.min_inliers = 0"),
            ("[keyframes]\nmax_frames = 0\n", "keyframes.max_frames = 0"),
            ("[mapping]\nba_keyframes = 0\n", "mapping.ba_keyframes = 0"),
            ("[mapping.ba]\nbf = -1.0\n", "mapping.ba.bf = -1"),
            (
                "[lines.detect]\nscan_interval = 0\n",
                "t.toml: lines.detect.scan_interval = 0",
            ),
        ];
        for (tables, want) in cases {
            let e = error_of(tables);
            assert!(e.contains(want), "{tables:?}: {e}");
            assert!(e.contains("t.toml"), "{e}");
            assert_eq!(e.matches("lines.detect.lines").count(), 0, "{e}");
        }
        let tiny = CAMERA.replace("fy=500.0", "fy=1e-9");
        let e = Config::from_toml(&tiny, "t.toml").unwrap_err().to_string();
        assert!(e.contains("camera.fy"), "{e}");
    }
}
