//! Robust kernel (Huber), chi-square thresholds and the per-level information of
//! keypoints: the weighting shared by the pose optimiser and local BA.

/// 95 % quantile of the chi-square distribution with 1 degree of freedom.
pub const CHI2_1DOF_95: f64 = 3.841;
/// 95 % quantile of the chi-square distribution with 2 degrees of freedom (ORB-SLAM2's
/// monocular threshold).
pub const CHI2_2DOF_95: f64 = 5.991;

/// 95 % quantile of the chi-square distribution with 3 degrees of freedom (ORB-SLAM2's
/// stereo / RGB-D threshold).
pub const CHI2_3DOF_95: f64 = 7.815;

/// Virtual stereo baseline times focal length of an RGB-D camera, metres x pixels
/// (ORB-SLAM2 `Camera.bf: 40.0` for the TUM configs: 8 cm x ~500 px).
pub const DEFAULT_RGBD_BF: f64 = 40.0;

/// Scale factor between pyramid levels (ORB-SLAM2 default 1.2).
pub const PYRAMID_SCALE_FACTOR: f64 = 1.2;

/// Information `1 / sigma^2` of a pixel measurement made at pyramid `level`, with
/// `sigma = 1.2^level` pixels (ORB-SLAM2).
pub fn inv_sigma2_for_level(level: u32) -> f64 {
    PYRAMID_SCALE_FACTOR.powi(-2 * level.min(64) as i32)
}

/// Huber kernel on a squared whitened error `s = e^T Omega e` (g2o convention):
/// `rho(s) = s` for `s <= delta^2`, else `2 delta sqrt(s) - delta^2`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Huber {
    /// Threshold on the whitened error norm, same units as `sqrt(s)`.
    pub delta: f64,
}

impl Huber {
    /// The kernel whose threshold is the square root of a chi-square quantile (ORB-SLAM2
    /// uses `sqrt(5.991)` for pixel reprojection errors).
    pub fn from_chi2(chi2: f64) -> Self {
        Self {
            delta: chi2.max(0.0).sqrt(),
        }
    }

    /// Robust cost `rho(s)`.
    #[inline]
    pub fn cost(&self, s: f64) -> f64 {
        let d2 = self.delta * self.delta;
        if s <= d2 {
            s
        } else {
            2.0 * self.delta * s.sqrt() - d2
        }
    }

    /// IRLS weight `rho'(s)`: 1 inside the threshold, `delta / sqrt(s)` outside. The
    /// normal equations use `J^T (w Omega) J` and `J^T (w Omega) e`.
    #[inline]
    pub fn weight(&self, s: f64) -> f64 {
        if s <= self.delta * self.delta {
            1.0
        } else {
            self.delta / s.sqrt()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn huber_is_quadratic_inside_and_linear_outside() {
        let h = Huber::from_chi2(CHI2_2DOF_95);
        assert!((h.delta - 2.4477).abs() < 1e-4);
        assert_eq!(h.cost(4.0), 4.0);
        assert_eq!(h.weight(4.0), 1.0);
        // At e = 10 (s = 100): 2 * 2.4477 * 10 - 5.991.
        assert!((h.cost(100.0) - (20.0 * h.delta - 5.991)).abs() < 1e-9);
        assert!((h.weight(100.0) - h.delta / 10.0).abs() < 1e-12);
        // The weight is the derivative of the cost.
        let s = 37.0;
        let numeric = (h.cost(s + 1e-6) - h.cost(s - 1e-6)) / 2e-6;
        assert!((numeric - h.weight(s)).abs() < 1e-6);
    }

    #[test]
    fn level_information_follows_orb_slam2() {
        assert_eq!(inv_sigma2_for_level(0), 1.0);
        assert!((inv_sigma2_for_level(2) - 1.0 / 1.2f64.powi(4)).abs() < 1e-12);
    }
}
