//! Student, Welch and paired t-tests.
//!
//! Conventions:
//! - the difference is always **x − y** (first argument minus second);
//! - p is **two-sided**;
//! - the CI is the CI of the mean difference x̄ − ȳ at the requested level, using the same df as
//!   the test (Welch–Satterthwaite df for Welch);
//! - Cohen's d for independent samples (Student and Welch alike) uses the **pooled** SD,
//!   d = (x̄ − ȳ) / √(((n₁−1)s₁² + (n₂−1)s₂²)/(n₁+n₂−2)), as pingouin's `compute_effsize`;
//! - Cohen's d for paired samples is pingouin's **d_av**, (x̄ − ȳ) / √((s_x² + s_y²)/2);
//!   d_z = t / √n is also reported.

use super::descriptive::{mean, t_critical, variance};
use super::error::{check_finite, check_len, check_level, check_same_len};
use super::{Result, StatsError};
use statrs::distribution::{ContinuousCDF, StudentsT};

/// Which t-test produced a result.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum TTestKind {
    /// Independent samples, equal variances assumed (pooled variance).
    Student,
    /// Independent samples, unequal variances (Welch–Satterthwaite df).
    Welch,
    /// Paired samples (one-sample t on the differences).
    Paired,
}

/// Result of a t-test. See the module doc for conventions.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct TTest {
    pub kind: TTestKind,
    pub t: f64,
    pub df: f64,
    /// Two-sided p-value.
    pub p_two_sided: f64,
    /// x̄ − ȳ (paired: mean of x − y).
    pub mean_diff: f64,
    /// Standard error of `mean_diff`.
    pub se: f64,
    /// Confidence level of `ci`.
    pub ci_level: f64,
    /// CI of `mean_diff`: mean_diff ± t(1 − (1 − level)/2; df) · se.
    pub ci: (f64, f64),
    /// Cohen's d (pooled SD for independent samples, d_av for paired).
    pub cohen_d: f64,
    /// Paired only: d_z = mean difference / SD of differences = t / √n.
    pub cohen_dz: Option<f64>,
}

/// Two-sided p-value of `t` under Student's t with `df` degrees of freedom.
pub(crate) fn t_two_sided_p(t: f64, df: f64) -> Result<f64> {
    let dist = StudentsT::new(0.0, 1.0, df).map_err(|e| StatsError::InvalidParameter {
        what: "t distribution",
        detail: e.to_string(),
    })?;
    Ok((2.0 * dist.sf(t.abs())).min(1.0))
}

/// Checks two independent samples (each finite, n ≥ 2).
fn check_two(x: &[f64], y: &[f64]) -> Result<()> {
    check_len("t-test sample x", x, 2)?;
    check_len("t-test sample y", y, 2)?;
    check_finite("t-test sample x", x)?;
    check_finite("t-test sample y", y)
}

/// Pooled standard deviation of two samples.
fn pooled_sd(x: &[f64], y: &[f64]) -> Result<f64> {
    let (n1, n2) = (x.len() as f64, y.len() as f64);
    Ok((((n1 - 1.0) * variance(x)? + (n2 - 1.0) * variance(y)?) / (n1 + n2 - 2.0)).sqrt())
}

/// Builds the result from the pieces every t-test shares.
fn finish(
    kind: TTestKind,
    diff: f64,
    se: f64,
    df: f64,
    level: f64,
    d: f64,
    dz: Option<f64>,
) -> Result<TTest> {
    if se == 0.0 {
        return Err(StatsError::ZeroVariance { what: "t-test" });
    }
    let t = diff / se;
    let half = t_critical(level, df)? * se;
    Ok(TTest {
        kind,
        t,
        df,
        p_two_sided: t_two_sided_p(t, df)?,
        mean_diff: diff,
        se,
        ci_level: level,
        ci: (diff - half, diff + half),
        cohen_d: d,
        cohen_dz: dz,
    })
}

/// Student's independent-samples t-test (equal variances), df = n₁ + n₂ − 2.
pub fn student_t(x: &[f64], y: &[f64], ci_level: f64) -> Result<TTest> {
    check_two(x, y)?;
    check_level("student_t", ci_level)?;
    let (n1, n2) = (x.len() as f64, y.len() as f64);
    let sp = pooled_sd(x, y)?;
    let diff = mean(x)? - mean(y)?;
    let se = sp * (1.0 / n1 + 1.0 / n2).sqrt();
    finish(
        TTestKind::Student,
        diff,
        se,
        n1 + n2 - 2.0,
        ci_level,
        diff / sp,
        None,
    )
}

/// Welch's t-test (unequal variances), Welch–Satterthwaite df.
pub fn welch_t(x: &[f64], y: &[f64], ci_level: f64) -> Result<TTest> {
    check_two(x, y)?;
    check_level("welch_t", ci_level)?;
    let (a, b) = (variance(x)? / x.len() as f64, variance(y)? / y.len() as f64);
    let df = (a + b).powi(2) / (a * a / (x.len() - 1) as f64 + b * b / (y.len() - 1) as f64);
    let diff = mean(x)? - mean(y)?;
    let sp = pooled_sd(x, y)?;
    finish(
        TTestKind::Welch,
        diff,
        (a + b).sqrt(),
        df,
        ci_level,
        diff / sp,
        None,
    )
}

/// Paired t-test on x − y, df = n − 1.
pub fn paired_t(x: &[f64], y: &[f64], ci_level: f64) -> Result<TTest> {
    check_same_len("paired_t", x.len(), y.len())?;
    check_two(x, y)?;
    check_level("paired_t", ci_level)?;
    let d: Vec<f64> = x.iter().zip(y).map(|(a, b)| a - b).collect();
    let n = d.len() as f64;
    let (md, sd_d) = (mean(&d)?, variance(&d)?.sqrt());
    let d_av = md / ((variance(x)? + variance(y)?) / 2.0).sqrt();
    let dz = if sd_d > 0.0 { Some(md / sd_d) } else { None };
    finish(
        TTestKind::Paired,
        md,
        sd_d / n.sqrt(),
        n - 1.0,
        ci_level,
        d_av,
        dz,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::stats::test_support::*;

    #[test]
    fn student_matches_scipy_and_pingouin() {
        let r_ = student_t(&A, &B, 0.95).unwrap();
        // scipy.stats.ttest_ind(equal_var=True)
        assert_close("t", r_.t, r("ttest_ind_student/t"));
        assert_close("df", r_.df, r("ttest_ind_student/df"));
        assert_close("p", r_.p_two_sided, r("ttest_ind_student/p_two_sided"));
        // pingouin.ttest(correction=False) cohen-d
        assert_close("d", r_.cohen_d, r("ttest_ind_student/cohen_d"));
    }

    #[test]
    fn welch_matches_scipy() {
        let r_ = welch_t(&A, &B, 0.95).unwrap();
        // scipy.stats.ttest_ind(equal_var=False)
        assert_close("t", r_.t, r("ttest_ind_welch/t"));
        assert_close("df", r_.df, r("ttest_ind_welch/df"));
        assert_close("p", r_.p_two_sided, r("ttest_ind_welch/p_two_sided"));
    }

    #[test]
    fn paired_matches_scipy() {
        let r_ = paired_t(&PRE, &POST, 0.95).unwrap();
        // scipy.stats.ttest_rel
        assert_close("t", r_.t, r("ttest_rel/t"));
        assert_close("df", r_.df, r("ttest_rel/df"));
        assert_close("p", r_.p_two_sided, r("ttest_rel/p_two_sided"));
        // identity: d_z = t / √n
        assert_close_tol("dz", r_.cohen_dz.unwrap(), r_.t / 8f64.sqrt(), IDENTITY_TOL);
    }

    #[test]
    fn ci_matches_scipy() {
        // scipy.stats.ttest_ind(…).confidence_interval(0.95) / ttest_rel (scipy 1.17.1)
        let cases = [
            (student_t(&A, &B, 0.95).unwrap(), "student"),
            (welch_t(&A, &B, 0.95).unwrap(), "welch"),
            (paired_t(&PRE, &POST, 0.95).unwrap(), "paired"),
        ];
        for (t, key) in cases {
            assert_close(
                &format!("{key} lo"),
                t.ci.0,
                sx(&format!("ttest_ci95/{key}/0")),
            );
            assert_close(
                &format!("{key} hi"),
                t.ci.1,
                sx(&format!("ttest_ci95/{key}/1")),
            );
        }
    }

    #[test]
    fn ci_excludes_zero_iff_p_below_alpha() {
        // Identity: the (1 − α) CI of the difference excludes 0 exactly when p < α.
        for r_ in [
            student_t(&A, &B, 0.95),
            welch_t(&A, &B, 0.95),
            paired_t(&PRE, &POST, 0.95),
        ] {
            let r_ = r_.unwrap();
            let excludes = r_.ci.0 > 0.0 || r_.ci.1 < 0.0;
            assert_eq!(excludes, r_.p_two_sided < 0.05, "{r_:?}");
        }
        // At level 1 − p the CI bound touches 0.
        let s = student_t(&A, &B, 0.95).unwrap();
        let at_p = student_t(&A, &B, 1.0 - s.p_two_sided).unwrap();
        assert_abs("CI bound at level 1 − p", at_p.ci.0, 0.0, 1e-9);
    }

    #[test]
    fn paired_equals_one_sample_on_differences_and_is_antisymmetric() {
        let ab = paired_t(&PRE, &POST, 0.95).unwrap();
        let ba = paired_t(&POST, &PRE, 0.95).unwrap();
        assert_close_tol("t antisymmetric", ab.t, -ba.t, IDENTITY_TOL);
        assert_close_tol("p symmetric", ab.p_two_sided, ba.p_two_sided, IDENTITY_TOL);
    }

    #[test]
    fn typed_errors() {
        assert!(matches!(
            paired_t(&PRE, &A[..3], 0.95),
            Err(StatsError::LengthMismatch { .. })
        ));
        assert!(matches!(
            student_t(&[1.0], &B, 0.95),
            Err(StatsError::TooFewObservations { .. })
        ));
        assert!(matches!(
            student_t(&[1.0, 1.0], &[1.0, 1.0], 0.95),
            Err(StatsError::ZeroVariance { .. })
        ));
        assert!(matches!(
            student_t(&A, &B, 1.5),
            Err(StatsError::InvalidParameter { .. })
        ));
    }
}
