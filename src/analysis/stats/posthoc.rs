//! Post hoc pairwise comparisons after a one-way ANOVA.
//!
//! Conventions: pairs are (i, j) with i < j in the order the groups were given; the difference
//! is mean_i − mean_j; the error term is the ANOVA's pooled MS_within with N − k df.
//! - Scheffé: F_s = (x̄ᵢ − x̄ⱼ)² / (MS_w (1/nᵢ + 1/nⱼ)) / (k − 1), p = P(F(k − 1, N − k) > F_s)
//!   (scikit-posthocs `posthoc_scheffe`).
//! - Tukey HSD (Tukey–Kramer for unequal n): q = |x̄ᵢ − x̄ⱼ| / √(MS_w/2 · (1/nᵢ + 1/nⱼ)),
//!   p = P(Q(k, N − k) > q); the simultaneous CI is diff ± q_crit √(MS_w/2 · (1/nᵢ + 1/nⱼ))
//!   (as scipy.stats.tukey_hsd).

use super::anova::{f_sf, pool_groups};
use super::error::check_level;
use super::{Result, StatsError, studentized_range};

/// One pairwise comparison.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Pairwise {
    /// Index of the first group.
    pub i: usize,
    /// Index of the second group.
    pub j: usize,
    /// mean_i − mean_j.
    pub mean_diff: f64,
    /// Scheffé F or Tukey q, depending on the test.
    pub statistic: f64,
    pub p: f64,
    /// Simultaneous CI of the difference (Tukey only).
    pub ci: Option<(f64, f64)>,
}

/// All pairs (i < j) of `k` groups.
fn pairs(k: usize) -> impl Iterator<Item = (usize, usize)> {
    (0..k).flat_map(move |i| (i + 1..k).map(move |j| (i, j)))
}

/// Scheffé pairwise tests (see the module doc).
pub fn scheffe(groups: &[&[f64]]) -> Result<Vec<Pairwise>> {
    let pooled = pool_groups(groups)?;
    let msw = nonzero_msw(pooled.ms_within())?;
    let k = groups.len() as f64;
    pairs(groups.len())
        .map(|(i, j)| {
            let diff = pooled.means[i] - pooled.means[j];
            let f = diff * diff
                / (msw * (1.0 / pooled.ns[i] as f64 + 1.0 / pooled.ns[j] as f64))
                / (k - 1.0);
            Ok(Pairwise {
                i,
                j,
                mean_diff: diff,
                statistic: f,
                p: f_sf(f, k - 1.0, pooled.df_within)?,
                ci: None,
            })
        })
        .collect()
}

/// Tukey HSD pairwise tests with simultaneous CIs at `ci_level` (see the module doc).
pub fn tukey_hsd(groups: &[&[f64]], ci_level: f64) -> Result<Vec<Pairwise>> {
    check_level("tukey_hsd", ci_level)?;
    let pooled = pool_groups(groups)?;
    let msw = nonzero_msw(pooled.ms_within())?;
    let k = groups.len();
    let q_crit = studentized_range::quantile(ci_level, k, pooled.df_within)?;
    pairs(k)
        .map(|(i, j)| {
            let diff = pooled.means[i] - pooled.means[j];
            let se = (msw / 2.0 * (1.0 / pooled.ns[i] as f64 + 1.0 / pooled.ns[j] as f64)).sqrt();
            let q = diff.abs() / se;
            let p = studentized_range::sf(q, k, pooled.df_within)?;
            Ok(Pairwise {
                i,
                j,
                mean_diff: diff,
                statistic: q,
                p,
                ci: Some((diff - q_crit * se, diff + q_crit * se)),
            })
        })
        .collect()
}

fn nonzero_msw(msw: f64) -> Result<f64> {
    if msw > 0.0 {
        Ok(msw)
    } else {
        Err(StatsError::ZeroVariance {
            what: "post hoc (MS within)",
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::stats::test_support::*;
    use crate::analysis::stats::ttest::student_t;

    #[test]
    fn scheffe_matches_scikit_posthocs() {
        let res = scheffe(&[&G1, &G2, &G3]).unwrap();
        // scikit-posthocs posthoc_scheffe (p); F from the textbook formula, cross-checked in the script
        for (c, name) in res.iter().zip(["g1-g2", "g1-g3", "g2-g3"]) {
            assert_close(
                &format!("{name} F"),
                c.statistic,
                r(&format!("scheffe/{name}/F_scheffe")),
            );
            assert_close(&format!("{name} p"), c.p, r(&format!("scheffe/{name}/p")));
        }
    }

    #[test]
    fn tukey_matches_scipy() {
        // scipy.stats.tukey_hsd(G1, G2, G3) and .confidence_interval(0.95) (scipy 1.17.1)
        let res = tukey_hsd(&[&G1, &G2, &G3], 0.95).unwrap();
        for (c, name) in res.iter().zip(["g1-g2", "g1-g3", "g2-g3"]) {
            let base = format!("tukey_hsd/{name}");
            assert_close(
                &format!("{name} diff"),
                c.mean_diff,
                sx(&format!("{base}/mean_diff")),
            );
            assert_close(&format!("{name} p"), c.p, sx(&format!("{base}/p")));
            let (lo, hi) = c.ci.unwrap();
            assert_close(&format!("{name} lo"), lo, sx(&format!("{base}/ci95/0")));
            assert_close(&format!("{name} hi"), hi, sx(&format!("{base}/ci95/1")));
        }
    }

    #[test]
    fn tukey_with_two_groups_equals_student_t() {
        // Identity: with k = 2, q = √2 |t| and Tukey's p equals Student's two-sided p.
        let res = tukey_hsd(&[&A, &B], 0.95).unwrap();
        let t = student_t(&A, &B, 0.95).unwrap();
        assert_close_tol(
            "q = √2 |t|",
            res[0].statistic,
            2f64.sqrt() * t.t.abs(),
            IDENTITY_TOL,
        );
        assert_close_tol("p", res[0].p, t.p_two_sided, 1e-8);
        let (lo, hi) = res[0].ci.unwrap();
        assert_close_tol("CI", lo, t.ci.0, 1e-8);
        assert_close_tol("CI", hi, t.ci.1, 1e-8);
    }

    #[test]
    fn tukey_ci_excludes_zero_iff_significant() {
        for c in tukey_hsd(&[&G1, &G2, &G3], 0.95).unwrap() {
            let (lo, hi) = c.ci.unwrap();
            assert_eq!(lo > 0.0 || hi < 0.0, c.p < 0.05, "{c:?}");
        }
    }

    #[test]
    fn tukey_p_is_at_most_scheffe_p() {
        // Scheffé is the more conservative procedure for pairwise contrasts.
        let groups: [&[f64]; 3] = [&G1, &G2, &G3];
        for (t, s) in tukey_hsd(&groups, 0.95)
            .unwrap()
            .iter()
            .zip(scheffe(&groups).unwrap())
        {
            assert!(t.p <= s.p, "tukey {} vs scheffe {}", t.p, s.p);
        }
    }
}
