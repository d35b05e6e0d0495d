//! Descriptive statistics.
//!
//! Convention: variances and standard deviations are **sample** estimates with n − 1 in the
//! denominator (numpy `ddof=1`, R `var`), unless a name says `population`.

use super::error::{check_finite, check_len};
use super::{Result, StatsError};
use statrs::distribution::{ContinuousCDF, StudentsT};

/// Arithmetic mean. Errors on an empty sample or non-finite values.
pub fn mean(x: &[f64]) -> Result<f64> {
    check_len("mean", x, 1)?;
    check_finite("mean", x)?;
    Ok(x.iter().sum::<f64>() / x.len() as f64)
}

/// Sum of squared deviations from the mean, Σ(xᵢ − x̄)².
pub fn sum_sq_dev(x: &[f64]) -> Result<f64> {
    let m = mean(x)?;
    Ok(x.iter().map(|v| (v - m).powi(2)).sum())
}

/// Sample variance, Σ(xᵢ − x̄)² / (n − 1). Needs n ≥ 2.
pub fn variance(x: &[f64]) -> Result<f64> {
    check_len("variance", x, 2)?;
    Ok(sum_sq_dev(x)? / (x.len() - 1) as f64)
}

/// Sample standard deviation, √variance (n − 1 denominator).
pub fn std_dev(x: &[f64]) -> Result<f64> {
    Ok(variance(x)?.sqrt())
}

/// Standard error of the mean, s / √n.
pub fn sem(x: &[f64]) -> Result<f64> {
    Ok(std_dev(x)? / (x.len() as f64).sqrt())
}

/// The `q`-quantile of sorted, non-empty values, interpolating linearly between order
/// statistics (numpy's default, R type 7).
pub fn quantile_sorted(sorted: &[f64], q: f64) -> f64 {
    let h = (sorted.len() - 1) as f64 * q;
    let (lo, hi) = (h.floor() as usize, h.ceil() as usize);
    sorted[lo] + (h - lo as f64) * (sorted[hi] - sorted[lo])
}

/// Summary of one sample: n, mean, sample SD, SEM and the t-based CI of the mean.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Summary {
    pub n: usize,
    pub mean: f64,
    pub sd: f64,
    pub sem: f64,
    /// Confidence level of `ci` (e.g. 0.95).
    pub ci_level: f64,
    /// x̄ ± t(1 − (1 − level)/2; n − 1) · SEM.
    pub ci: (f64, f64),
}

/// Summarises a sample; the CI of the mean uses Student's t with n − 1 df.
pub fn summary(x: &[f64], ci_level: f64) -> Result<Summary> {
    super::error::check_level("summary", ci_level)?;
    let (m, sd, se) = (mean(x)?, std_dev(x)?, sem(x)?);
    let half = t_critical(ci_level, (x.len() - 1) as f64)? * se;
    Ok(Summary {
        n: x.len(),
        mean: m,
        sd,
        sem: se,
        ci_level,
        ci: (m - half, m + half),
    })
}

/// Two-sided critical value t(1 − (1 − level)/2; df).
pub(crate) fn t_critical(level: f64, df: f64) -> Result<f64> {
    let t = StudentsT::new(0.0, 1.0, df).map_err(|e| StatsError::InvalidParameter {
        what: "t distribution",
        detail: e.to_string(),
    })?;
    Ok(t.inverse_cdf(1.0 - (1.0 - level) / 2.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::stats::test_support::*;

    #[test]
    fn quantiles_interpolate_as_numpy() {
        // numpy.percentile([1, 2, 3, 4, 10], [2.5, 97.5]) = [1.1, 9.4].
        let v = [1.0, 2.0, 3.0, 4.0, 10.0];
        assert!((quantile_sorted(&v, 0.025) - 1.1).abs() < 1e-12 && (quantile_sorted(&v, 0.975) - 9.4).abs() < 1e-12);
    }

    #[test]
    fn variance_uses_n_minus_1() {
        // Textbook: [2, 4, 4, 4, 5, 5, 7, 9] has mean 5, Σ(x − x̄)² = 32, sample variance 32/7.
        let x = [2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0];
        assert_close("mean", mean(&x).unwrap(), 5.0);
        assert_close("variance", variance(&x).unwrap(), 32.0 / 7.0);
    }

    #[test]
    fn summary_ci_contains_mean_and_is_symmetric() {
        let s = summary(&A, 0.95).unwrap();
        assert_close_tol("symmetry", s.mean - s.ci.0, s.ci.1 - s.mean, IDENTITY_TOL);
        // t(0.975; 7) = 2.364624 (every t table).
        assert_abs("half width", (s.ci.1 - s.mean) / s.sem, 2.364624, 1e-6);
    }

    #[test]
    fn errors_instead_of_panics() {
        assert!(matches!(
            mean(&[]),
            Err(StatsError::TooFewObservations { .. })
        ));
        assert!(matches!(
            variance(&[1.0]),
            Err(StatsError::TooFewObservations { .. })
        ));
        assert!(matches!(
            mean(&[1.0, f64::NAN]),
            Err(StatsError::NonFinite { index: 1, .. })
        ));
    }
}
