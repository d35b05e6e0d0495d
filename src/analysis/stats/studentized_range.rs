//! The studentized range distribution (needed for Tukey's HSD; `statrs` does not have it).
//!
//! Written from the definition. For k independent N(0, 1) variables, the range R has
//!
//! ```text
//! P(R ≤ w) = k ∫ φ(z) [Φ(z) − Φ(z − w)]^(k−1) dz            (z over ℝ)
//! ```
//!
//! and the studentized range Q = R / S, with ν·S² ~ χ²_ν independent of R, has
//!
//! ```text
//! P(Q ≤ q) = ∫₀^∞ g_ν(s) P(R ≤ q s) ds,
//! g_ν(s) = ν^(ν/2) s^(ν−1) e^(−ν s²/2) / (Γ(ν/2) 2^(ν/2 − 1))   (density of S = √(χ²_ν/ν)).
//! ```
//!
//! Both integrals use composite Gauss–Legendre quadrature (16 nodes per panel). The inner one
//! runs over z ∈ [−8.5, 8.5] (φ is below 1e−15 outside); the outer one over S's mean ± 12
//! standard deviations (clipped at 0). With ν = ∞ the outer integral is skipped.
//! The upper tail is integrated directly, not as 1 − CDF: with a = Φ(z), b = Φ(z − w),
//! P(R > w) = k ∫ φ(z) [a^(k−1) − (a − b)^(k−1)] dz (because k ∫ φ Φ^(k−1) = 1), and the bracket
//! is evaluated as b · Σᵢ aⁱ (a − b)^(k−2−i) without cancellation, so small p-values keep their
//! relative accuracy.

use super::{Result, StatsError};
use statrs::function::erf::erfc;
use statrs::function::gamma::ln_gamma;
use std::f64::consts::{FRAC_1_SQRT_2, PI};
use std::sync::OnceLock;

/// Nodes per Gauss–Legendre panel.
const GL_NODES: usize = 16;
/// Panels for the inner (normal range) integral over [−8.5, 8.5].
const INNER_PANELS: usize = 24;
/// Panels for the outer (chi) integral.
const OUTER_PANELS: usize = 32;
/// Half-width of the inner integration range.
const Z_MAX: f64 = 8.5;

/// Gauss–Legendre nodes and weights on [−1, 1], by Newton iteration on Pₙ.
fn gauss_legendre() -> &'static (Vec<f64>, Vec<f64>) {
    static GL: OnceLock<(Vec<f64>, Vec<f64>)> = OnceLock::new();
    GL.get_or_init(|| {
        let n = GL_NODES;
        let (mut xs, mut ws) = (Vec::with_capacity(n), Vec::with_capacity(n));
        for i in 0..n {
            let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, x);
                for j in 2..=n {
                    let jf = j as f64;
                    let p2 = ((2.0 * jf - 1.0) * x * p1 - (jf - 1.0) * p0) / jf;
                    p0 = p1;
                    p1 = p2;
                }
                dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-15 {
                    break;
                }
            }
            xs.push(x);
            ws.push(2.0 / ((1.0 - x * x) * dp * dp));
        }
        (xs, ws)
    })
}

/// ∫ₐᵇ f with `panels` Gauss–Legendre panels.
fn integrate(f: impl Fn(f64) -> f64, a: f64, b: f64, panels: usize) -> f64 {
    let (xs, ws) = gauss_legendre();
    let h = (b - a) / panels as f64;
    (0..panels)
        .map(|p| {
            let mid = a + (p as f64 + 0.5) * h;
            xs.iter()
                .zip(ws)
                .map(|(x, w)| w * f(mid + 0.5 * h * x))
                .sum::<f64>()
                * 0.5
                * h
        })
        .sum()
}

/// Standard normal CDF Φ.
fn phi_cdf(x: f64) -> f64 {
    0.5 * erfc(-x * FRAC_1_SQRT_2)
}

/// Standard normal density φ.
fn phi_pdf(x: f64) -> f64 {
    (-0.5 * x * x).exp() / (2.0 * PI).sqrt()
}

/// P(R ≤ w) for the range of k standard normals.
fn range_cdf(w: f64, k: f64) -> f64 {
    if w <= 0.0 {
        return 0.0;
    }
    let f = |z: f64| phi_pdf(z) * (phi_cdf(z) - phi_cdf(z - w)).max(0.0).powf(k - 1.0);
    (k * integrate(f, -Z_MAX, Z_MAX, INNER_PANELS)).clamp(0.0, 1.0)
}

/// P(R > w) for the range of k standard normals, without cancellation (see the module doc).
fn range_sf(w: f64, k: usize) -> f64 {
    if w <= 0.0 {
        return 1.0;
    }
    let m = k - 1;
    let f = |z: f64| {
        let (a, b) = (phi_cdf(z), phi_cdf(z - w));
        let c = (a - b).max(0.0);
        // a^m − c^m = (a − c) Σ_{i<m} a^i c^(m−1−i), with a − c = b.
        let sum: f64 = (0..m)
            .map(|i| a.powi(i as i32) * c.powi((m - 1 - i) as i32))
            .sum();
        phi_pdf(z) * b * sum
    };
    (k as f64 * integrate(f, -Z_MAX, Z_MAX, INNER_PANELS)).clamp(0.0, 1.0)
}

/// ∫ g_ν(s) h(s) ds over S's effective support (mean ± 12 SD, clipped at 0).
fn integrate_over_chi(df: f64, h: impl Fn(f64) -> f64) -> f64 {
    let spread = 12.0 / (2.0 * df).sqrt();
    let (lo, hi) = ((1.0 - spread).max(0.0), 1.0 + spread);
    let f = |s: f64| {
        if s <= 0.0 {
            0.0
        } else {
            ln_chi_density(s, df).exp() * h(s)
        }
    };
    integrate(f, lo, hi, OUTER_PANELS)
}

/// ln g_ν(s), the log density of S = √(χ²_ν/ν).
fn ln_chi_density(s: f64, nu: f64) -> f64 {
    0.5 * nu * nu.ln() - ln_gamma(0.5 * nu) - (0.5 * nu - 1.0) * 2f64.ln() + (nu - 1.0) * s.ln()
        - 0.5 * nu * s * s
}

fn check_params(k: usize, df: f64) -> Result<()> {
    if k < 2 {
        return Err(StatsError::InvalidParameter {
            what: "studentized range",
            detail: format!("k = {k} < 2"),
        });
    }
    if df.is_nan() || df < 1.0 {
        return Err(StatsError::InvalidParameter {
            what: "studentized range",
            detail: format!("df = {df} < 1"),
        });
    }
    Ok(())
}

/// P(Q ≤ q) for the studentized range with `k` means and `df` error degrees of freedom
/// (`df = f64::INFINITY` for the normal-range limit). Needs k ≥ 2, df ≥ 1.
pub fn cdf(q: f64, k: usize, df: f64) -> Result<f64> {
    check_params(k, df)?;
    if q.is_nan() {
        return Err(StatsError::NonFinite {
            what: "studentized range q",
            index: 0,
        });
    }
    if q <= 0.0 {
        return Ok(0.0);
    }
    let kf = k as f64;
    if df.is_infinite() {
        return Ok(range_cdf(q, kf));
    }
    Ok(integrate_over_chi(df, |s| range_cdf(q * s, kf)).clamp(0.0, 1.0))
}

/// Upper-tail probability P(Q > q): the p-value of an observed range statistic. Integrated
/// directly (not as 1 − CDF), so small p-values are accurate in relative terms.
pub fn sf(q: f64, k: usize, df: f64) -> Result<f64> {
    check_params(k, df)?;
    if q.is_nan() {
        return Err(StatsError::NonFinite {
            what: "studentized range q",
            index: 0,
        });
    }
    if df.is_infinite() {
        return Ok(range_sf(q, k));
    }
    Ok(integrate_over_chi(df, |s| range_sf(q * s, k)).clamp(0.0, 1.0))
}

/// The q with P(Q ≤ q) = p (e.g. p = 0.95 for the Tukey critical value), by bisection to 1e−10.
pub fn quantile(p: f64, k: usize, df: f64) -> Result<f64> {
    check_params(k, df)?;
    if !(p > 0.0 && p < 1.0) {
        return Err(StatsError::InvalidParameter {
            what: "studentized range quantile",
            detail: format!("p = {p}"),
        });
    }
    let (mut lo, mut hi) = (0.0, 8.0);
    while cdf(hi, k, df)? < p {
        lo = hi;
        hi *= 2.0;
        if hi > 1e6 {
            return Err(StatsError::InvalidParameter {
                what: "studentized range quantile",
                detail: "no bracket".into(),
            });
        }
    }
    while hi - lo > 1e-10 * hi {
        let mid = 0.5 * (lo + hi);
        if cdf(mid, k, df)? < p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok(0.5 * (lo + hi))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::stats::test_support::*;
    use statrs::distribution::{ContinuousCDF, StudentsT};

    #[test]
    fn quantiles_match_published_tables() {
        // Upper 5 % / 1 % points of the studentized range as printed (3 decimals) in the standard
        // tables (Harter 1960, Ann. Math. Statist. 31, "Tables of range and studentized range").
        assert_abs(
            "q(0.95; 3, 10)",
            quantile(0.95, 3, 10.0).unwrap(),
            3.877,
            TABLE_3DP_TOL,
        );
        assert_abs(
            "q(0.95; 4, 20)",
            quantile(0.95, 4, 20.0).unwrap(),
            3.958,
            TABLE_3DP_TOL,
        );
        assert_abs(
            "q(0.99; 3, 12)",
            quantile(0.99, 3, 12.0).unwrap(),
            5.046,
            TABLE_3DP_TOL,
        );
        // ν = ∞ row of the same tables: q(0.95; 3, ∞) = 3.314.
        assert_abs(
            "q(0.95; 3, inf)",
            quantile(0.95, 3, f64::INFINITY).unwrap(),
            3.314,
            TABLE_3DP_TOL,
        );
    }

    #[test]
    fn matches_scipy_studentized_range() {
        // scipy.stats.studentized_range.cdf / .sf / .ppf (scipy 1.17.1)
        let cases = scipy_extra()["studentized_range"]["cdf"]
            .as_array()
            .unwrap();
        for (i, c) in cases.iter().enumerate() {
            let (q, k, df) = (
                c["q"].as_f64().unwrap(),
                c["k"].as_u64().unwrap() as usize,
                c["df"].as_f64().unwrap(),
            );
            assert_close(
                &format!("cdf {q} {k} {df}"),
                cdf(q, k, df).unwrap(),
                sx(&format!("studentized_range/cdf/{i}/cdf")),
            );
            assert_close(
                &format!("sf {q} {k} {df}"),
                sf(q, k, df).unwrap(),
                sx(&format!("studentized_range/cdf/{i}/sf")),
            );
        }
        let cases = scipy_extra()["studentized_range"]["ppf"]
            .as_array()
            .unwrap();
        for (i, c) in cases.iter().enumerate() {
            let (p, k, df) = (
                c["p"].as_f64().unwrap(),
                c["k"].as_u64().unwrap() as usize,
                c["df"].as_f64().unwrap(),
            );
            assert_close(
                &format!("ppf {p} {k} {df}"),
                quantile(p, k, df).unwrap(),
                sx(&format!("studentized_range/ppf/{i}/q")),
            );
        }
    }

    #[test]
    fn cdf_plus_sf_is_one() {
        for &(q, k, df) in &[
            (0.5, 3, 5.0),
            (3.0, 4, 12.0),
            (6.0, 8, 30.0),
            (2.0, 3, f64::INFINITY),
        ] {
            let total = cdf(q, k, df).unwrap() + sf(q, k, df).unwrap();
            assert_close_tol(&format!("{q} {k} {df}"), total, 1.0, IDENTITY_TOL);
        }
    }

    #[test]
    fn two_means_reduce_to_students_t() {
        // Identity: for k = 2, Q = |X₁ − X₂|/S = √2 |T| with T ~ t_ν, so P(Q ≤ q) = 2 F_t(q/√2) − 1.
        for &(q, df) in &[
            (1.0, 3.0),
            (2.5, 10.0),
            (3.6, 25.0),
            (5.0, 1.0),
            (0.3, 60.0),
        ] {
            let t = StudentsT::new(0.0, 1.0, df).unwrap();
            let expected = 2.0 * t.cdf(q / 2f64.sqrt()) - 1.0;
            assert_close_tol(
                &format!("k=2 q={q} df={df}"),
                cdf(q, 2, df).unwrap(),
                expected,
                IDENTITY_TOL,
            );
        }
        // and with ν = ∞: 2Φ(q/√2) − 1.
        let expected = 2.0 * phi_cdf(2.0_f64 / 2f64.sqrt()) - 1.0;
        assert_close_tol(
            "k=2 df=inf",
            cdf(2.0, 2, f64::INFINITY).unwrap(),
            expected,
            IDENTITY_TOL,
        );
    }

    #[test]
    fn quadrature_is_converged() {
        // Doubling the panels must not change the CDF: compare against a finer direct integration.
        let (q, k, df) = (3.5_f64, 5usize, 7.0_f64);
        let fine_inner = |w: f64| {
            let f = |z: f64| phi_pdf(z) * (phi_cdf(z) - phi_cdf(z - w)).powf(k as f64 - 1.0);
            k as f64 * integrate(f, -Z_MAX, Z_MAX, 4 * INNER_PANELS)
        };
        let spread = 12.0 / (2.0 * df).sqrt();
        let fine = integrate(
            |s| {
                if s <= 0.0 {
                    0.0
                } else {
                    ln_chi_density(s, df).exp() * fine_inner(q * s)
                }
            },
            0.0,
            1.0 + spread,
            4 * OUTER_PANELS,
        );
        assert_close_tol("converged", cdf(q, k, df).unwrap(), fine, IDENTITY_TOL);
    }

    #[test]
    fn monotone_and_bounded() {
        let mut last = 0.0;
        for i in 0..40 {
            let c = cdf(i as f64 * 0.25, 4, 12.0).unwrap();
            assert!((0.0..=1.0).contains(&c) && c >= last - 1e-12);
            last = c;
        }
        assert!(cdf(1.0, 1, 10.0).is_err());
        assert!(cdf(1.0, 3, 0.5).is_err());
    }
}
