//! Reliability and agreement.
//!
//! Conventions:
//! - [`cronbach_alpha`]: rows = participants, columns = items; α = k/(k−1)·(1 − Σ s²ᵢ / s²_total)
//!   with sample variances; CI by Feldt's F method as pingouin computes it
//!   (df₁ = n − 1, df₂ = (n − 1)(k − 1)). Missing-data policy: **complete cases only** — a NaN is
//!   an error (drop incomplete participants first and report how many).
//! - [`cohen_kappa`]: two raters' nominal labels over a declared label set (unweighted κ).
//! - [`fleiss_kappa`]: rows = subjects, columns = categories, cell = number of raters choosing
//!   that category; every row must have the same number of raters (Fleiss 1971).
//! - [`dice`]: Dice agreement between two coders' sets (e.g. the AUs each marked):
//!   2|A ∩ B| / (|A| + |B|); two empty sets agree perfectly (1).
//! - [`icc`]: rows = targets, columns = raters, complete data; the six Shrout & Fleiss (1979)
//!   forms (pingouin's ICC1, ICC2, ICC3, ICC1k, ICC2k, ICC3k) from the two-way ANOVA mean squares.

use super::classification::ConfusionMatrix;
use super::error::{check_finite, check_level, check_same_len};
use super::{Result, StatsError};
use statrs::distribution::{ContinuousCDF, FisherSnedecor};
use std::collections::BTreeSet;

/// Cronbach's α with its Feldt confidence interval.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct CronbachAlpha {
    pub alpha: f64,
    /// Participants (rows).
    pub n: usize,
    /// Items (columns).
    pub k: usize,
    pub ci_level: f64,
    /// Feldt CI (not rounded; pingouin rounds to 3 decimals).
    pub ci: (f64, f64),
}

/// Checks rectangular complete data with at least `min_rows` × `min_cols`.
fn check_matrix(
    what: &'static str,
    data: &[Vec<f64>],
    min_rows: usize,
    min_cols: usize,
) -> Result<(usize, usize)> {
    let n = data.len();
    if n < min_rows {
        return Err(StatsError::TooFewObservations {
            what,
            needed: min_rows,
            got: n,
        });
    }
    let k = data[0].len();
    if k < min_cols {
        return Err(StatsError::TooFewObservations {
            what,
            needed: min_cols,
            got: k,
        });
    }
    for row in data {
        check_same_len(what, row.len(), k)?;
        check_finite(what, row)?;
    }
    Ok((n, k))
}

/// Sample variance of a column of values.
fn var(x: impl Iterator<Item = f64> + Clone) -> f64 {
    let n = x.clone().count() as f64;
    let m = x.clone().sum::<f64>() / n;
    x.map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0)
}

/// Cronbach's α of `rows` (participants × items) with a Feldt CI at `ci_level`.
pub fn cronbach_alpha(rows: &[Vec<f64>], ci_level: f64) -> Result<CronbachAlpha> {
    check_level("cronbach_alpha", ci_level)?;
    let (n, k) = check_matrix("Cronbach's alpha", rows, 2, 2)?;
    let item_vars: f64 = (0..k).map(|j| var(rows.iter().map(move |r| r[j]))).sum();
    let total_var = var(rows.iter().map(|r| r.iter().sum::<f64>()));
    if total_var == 0.0 {
        return Err(StatsError::ZeroVariance {
            what: "Cronbach's alpha (total score)",
        });
    }
    let kf = k as f64;
    let alpha = kf / (kf - 1.0) * (1.0 - item_vars / total_var);
    let (df1, df2) = ((n - 1) as f64, ((n - 1) * (k - 1)) as f64);
    let f = FisherSnedecor::new(df1, df2).map_err(|e| StatsError::InvalidParameter {
        what: "F distribution",
        detail: e.to_string(),
    })?;
    let tail = (1.0 - ci_level) / 2.0;
    let lower = 1.0 - (1.0 - alpha) * f.inverse_cdf(1.0 - tail);
    let upper = 1.0 - (1.0 - alpha) * f.inverse_cdf(tail);
    Ok(CronbachAlpha {
        alpha,
        n,
        k,
        ci_level,
        ci: (lower, upper),
    })
}

/// Cohen's κ between two raters' labels over `labels` (see [`ConfusionMatrix::cohen_kappa`]).
pub fn cohen_kappa<S: AsRef<str>, T: AsRef<str>, U: AsRef<str>>(
    labels: &[S],
    rater1: &[T],
    rater2: &[U],
) -> Result<f64> {
    ConfusionMatrix::from_labels(labels, rater1, rater2)?.cohen_kappa()
}

/// Fleiss' κ from a subjects × categories table of rater counts.
pub fn fleiss_kappa(table: &[Vec<u64>]) -> Result<f64> {
    let n_subj = table.len();
    if n_subj == 0 {
        return Err(StatsError::TooFewObservations {
            what: "Fleiss' kappa subjects",
            needed: 1,
            got: 0,
        });
    }
    let n_raters: u64 = table[0].iter().sum();
    if n_raters < 2 {
        return Err(StatsError::TooFewObservations {
            what: "Fleiss' kappa raters",
            needed: 2,
            got: n_raters as usize,
        });
    }
    let n_cat = table[0].len();
    for row in table {
        check_same_len("Fleiss' kappa categories", row.len(), n_cat)?;
        check_same_len(
            "Fleiss' kappa raters per subject",
            row.iter().sum::<u64>() as usize,
            n_raters as usize,
        )?;
    }
    let (nr, total) = (n_raters as f64, (n_subj as u64 * n_raters) as f64);
    let p_bar = table
        .iter()
        .map(|row| (row.iter().map(|&c| (c * c) as f64).sum::<f64>() - nr) / (nr * (nr - 1.0)))
        .sum::<f64>()
        / n_subj as f64;
    let p_e: f64 = (0..n_cat)
        .map(|j| (table.iter().map(|r| r[j]).sum::<u64>() as f64 / total).powi(2))
        .sum();
    if p_e >= 1.0 {
        return Err(StatsError::ZeroVariance {
            what: "Fleiss' kappa (all ratings in one category)",
        });
    }
    Ok((p_bar - p_e) / (1.0 - p_e))
}

/// Dice agreement 2|A ∩ B| / (|A| + |B|) between two sets (duplicates ignored); 1 for two empty sets.
pub fn dice<T: Ord>(a: &[T], b: &[T]) -> f64 {
    let (a, b): (BTreeSet<&T>, BTreeSet<&T>) = (a.iter().collect(), b.iter().collect());
    if a.is_empty() && b.is_empty() {
        return 1.0;
    }
    2.0 * a.intersection(&b).count() as f64 / (a.len() + b.len()) as f64
}

/// The six Shrout & Fleiss intraclass correlations.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Icc {
    /// ICC(1,1): one-way random, single rater.
    pub icc1: f64,
    /// ICC(2,1): two-way random, absolute agreement, single rater.
    pub icc2: f64,
    /// ICC(3,1): two-way mixed, consistency, single rater.
    pub icc3: f64,
    /// ICC(1,k): mean of k raters.
    pub icc1k: f64,
    /// ICC(2,k).
    pub icc2k: f64,
    /// ICC(3,k).
    pub icc3k: f64,
}

/// Intraclass correlations of `data` (targets × raters, complete).
pub fn icc(data: &[Vec<f64>]) -> Result<Icc> {
    let (n, k) = check_matrix("ICC", data, 2, 2)?;
    let (nf, kf) = (n as f64, k as f64);
    let grand = data.iter().flatten().sum::<f64>() / (nf * kf);
    let ss_rows: f64 = data
        .iter()
        .map(|r| kf * (r.iter().sum::<f64>() / kf - grand).powi(2))
        .sum();
    let ss_cols: f64 = (0..k)
        .map(|j| nf * (data.iter().map(|r| r[j]).sum::<f64>() / nf - grand).powi(2))
        .sum();
    let ss_total: f64 = data.iter().flatten().map(|v| (v - grand).powi(2)).sum();
    let ss_err = ss_total - ss_rows - ss_cols;
    let msr = ss_rows / (nf - 1.0);
    let msc = ss_cols / (kf - 1.0);
    let mse = ss_err / ((nf - 1.0) * (kf - 1.0));
    let msw = (ss_cols + ss_err) / (nf * (kf - 1.0));
    if msr == 0.0 {
        return Err(StatsError::ZeroVariance {
            what: "ICC (between targets)",
        });
    }
    Ok(Icc {
        icc1: (msr - msw) / (msr + (kf - 1.0) * msw),
        icc2: (msr - mse) / (msr + (kf - 1.0) * mse + kf * (msc - mse) / nf),
        icc3: (msr - mse) / (msr + (kf - 1.0) * mse),
        icc1k: (msr - msw) / msr,
        icc2k: (msr - mse) / (msr + (msc - mse) / nf),
        icc3k: (msr - mse) / msr,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::stats::test_support::*;

    #[test]
    fn cronbach_matches_pingouin() {
        let a = cronbach_alpha(&items(), 0.95).unwrap();
        // pingouin.cronbach_alpha (α exact; CI rounded by pingouin to 3 decimals)
        assert_close("alpha", a.alpha, r("cronbach_alpha/alpha"));
        assert_abs("ci low", a.ci.0, r("cronbach_alpha/ci95/0"), TABLE_3DP_TOL);
        assert_abs("ci high", a.ci.1, r("cronbach_alpha/ci95/1"), TABLE_3DP_TOL);
        assert_eq!(
            (
                (a.ci.0 * 1000.0).round() / 1000.0,
                (a.ci.1 * 1000.0).round() / 1000.0
            ),
            (0.811, 0.986)
        );
    }

    #[test]
    fn feldt_ci_unrounded_matches_scipy() {
        // pingouin's Feldt formula evaluated with scipy.stats.f.isf (scipy 1.17.1), not rounded
        let a = cronbach_alpha(&items(), 0.95).unwrap();
        assert_close("ci low", a.ci.0, sx("cronbach_feldt_ci95_unrounded/0"));
        assert_close("ci high", a.ci.1, sx("cronbach_feldt_ci95_unrounded/1"));
    }

    #[test]
    fn cronbach_two_items_is_spearman_brown_of_covariance() {
        // Identity: for k = 2, α = 4 cov(x, y) / var(x + y).
        let rows: Vec<Vec<f64>> = PRE.iter().zip(&POST).map(|(a, b)| vec![*a, *b]).collect();
        let (mx, my) = (
            PRE.iter().sum::<f64>() / 8.0,
            POST.iter().sum::<f64>() / 8.0,
        );
        let cov = PRE
            .iter()
            .zip(&POST)
            .map(|(a, b)| (a - mx) * (b - my))
            .sum::<f64>()
            / 7.0;
        let vs = var(rows.iter().map(|r| r[0] + r[1]));
        assert_close_tol(
            "k=2",
            cronbach_alpha(&rows, 0.95).unwrap().alpha,
            4.0 * cov / vs,
            IDENTITY_TOL,
        );
    }

    #[test]
    fn cronbach_missing_and_constant_data_are_errors() {
        let mut rows = items();
        rows[3][1] = f64::NAN;
        assert!(matches!(
            cronbach_alpha(&rows, 0.95),
            Err(StatsError::NonFinite { .. })
        ));
        assert!(matches!(
            cronbach_alpha(&[vec![1.0, 1.0], vec![1.0, 1.0]], 0.95),
            Err(StatsError::ZeroVariance { .. })
        ));
    }

    #[test]
    fn cohen_kappa_matches_sklearn() {
        // sklearn.metrics.cohen_kappa_score on the reference labels
        assert_close(
            "kappa",
            cohen_kappa(&EMO, &Y_TRUE, &Y_PRED).unwrap(),
            r("classification/cohen_kappa"),
        );
    }

    #[test]
    fn fleiss_matches_worked_example() {
        // Worked example of Fleiss' κ (10 subjects, 14 raters, 5 categories) from the Wikipedia
        // article "Fleiss' kappa", published κ = 0.210; exact value 0.20993070442195524 from the
        // Fleiss (1971) formula in rational arithmetic (Python fractions).
        let t: Vec<Vec<u64>> = vec![
            vec![0, 0, 0, 0, 14],
            vec![0, 2, 6, 4, 2],
            vec![0, 0, 3, 5, 6],
            vec![0, 3, 9, 2, 0],
            vec![2, 2, 8, 1, 1],
            vec![7, 7, 0, 0, 0],
            vec![3, 2, 6, 3, 0],
            vec![2, 5, 3, 2, 2],
            vec![6, 5, 2, 1, 0],
            vec![0, 2, 2, 3, 7],
        ];
        assert_close("fleiss", fleiss_kappa(&t).unwrap(), 0.20993070442195524);
        assert_abs("published", fleiss_kappa(&t).unwrap(), 0.210, TABLE_3DP_TOL);
        assert!(matches!(
            fleiss_kappa(&[vec![1, 1], vec![2, 1]]),
            Err(StatsError::LengthMismatch { .. })
        ));
    }

    #[test]
    fn dice_conventions() {
        assert_eq!(dice(&[1, 2, 4], &[1, 2, 12]), 2.0 * 2.0 / 6.0);
        assert_eq!(dice::<u32>(&[], &[]), 1.0);
        assert_eq!(dice(&[6, 12], &[]), 0.0);
        assert_eq!(dice(&[6, 12, 12], &[12, 6]), 1.0);
    }

    #[test]
    fn icc_matches_shrout_fleiss() {
        // Shrout & Fleiss (1979), Psychol. Bull. 86(2), Table 2 data (6 targets × 4 judges) and the
        // values they publish (2 decimals): .17 .29 .71 .44 .62 .91. Exact values from the
        // same formulas in Python: 0.16574176840547541, 0.289763779527559, 0.7148407148407147,
        // 0.4427971336792686, 0.620050547598989, 0.9093155423770694.
        let data: Vec<Vec<f64>> = [
            [9, 2, 5, 8],
            [6, 1, 3, 2],
            [8, 4, 6, 8],
            [7, 1, 2, 6],
            [10, 5, 6, 9],
            [6, 2, 4, 7],
        ]
        .iter()
        .map(|r| r.iter().map(|&v| f64::from(v)).collect())
        .collect();
        let i = icc(&data).unwrap();
        let got = [i.icc1, i.icc2, i.icc3, i.icc1k, i.icc2k, i.icc3k];
        let exact = [
            0.16574176840547541,
            0.289763779527559,
            0.7148407148407147,
            0.4427971336792686,
            0.620050547598989,
            0.9093155423770694,
        ];
        let published = [0.17, 0.29, 0.71, 0.44, 0.62, 0.91];
        for ((g, e), p) in got.iter().zip(exact).zip(published) {
            assert_close("icc", *g, e);
            assert_abs("icc published", *g, p, TABLE_2DP_TOL);
        }
    }
}
