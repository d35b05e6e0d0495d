//! Classification metrics for emotion-recognition responses.
//!
//! Conventions (scikit-learn's, with `zero_division=0`):
//! - the confusion matrix is over an explicit, ordered **label set**; rows = true, columns =
//!   predicted; a label outside the set is an error (decide beforehand how `none`/`neutral`
//!   answers are labelled);
//! - per class: precision = TP/(TP+FP), recall = TP/(TP+FN), F1 = 2TP/(2TP+FP+FN) (the harmonic
//!   mean of P and R when both are defined); any 0/0 is reported as **0**;
//! - **macro** = unweighted mean of the per-class values (macro F1 is the mean of per-class F1,
//!   not the F1 of macro P and R); **weighted** = mean weighted by support; **micro** = computed
//!   from TP/FP/FN summed over classes (equals accuracy for single-label data over the full set).
//! - [`f1_ci`]: Jeffreys interval of one binary F1, conditional on the design's positives
//!   P = TP + FN and negatives N = FP + TN (fixed by what was shown): recall ~ Beta(TP + ½,
//!   FN + ½) and false-positive rate ~ Beta(FP + ½, TN + ½), independent (each the Jeffreys
//!   posterior of a binomial proportion); F1 = 2P·recall / (P·recall + P + N·fpr); the interval is
//!   the equal-tailed percentiles of [`F1_CI_DRAWS`] draws from a generator seeded by the four
//!   counts (same counts, same interval), widened to contain the observed F1 (as the Jeffreys
//!   binomial interval takes 1 as its upper limit when every trial succeeds). Unlike the delta
//!   method's Wald interval it has width when every positive is found and nothing else marked;
//!   measured on simulated Exp. 1 studies (`docs/power.md`) its width matches the spread of
//!   repeated studies and its coverage is 95 % from 3 coders on.

use super::descriptive::quantile_sorted;
use crate::seeded::SplitMix64;

use super::{Result, StatsError};

/// Draws from the posterior behind one [`f1_ci`]: the endpoints' Monte Carlo error is about
/// 0.01 on the F1 scale (2000 draws keep a power analysis of hundreds of simulated studies quick).
pub const F1_CI_DRAWS: usize = 2000;

/// Jeffreys CI of F1 = 2TP / (2TP + FP + FN) at `level` (see the module doc).
pub fn f1_ci(tp: u64, fp: u64, fn_: u64, tn: u64, level: f64) -> Result<(f64, f64)> {
    super::error::check_level("f1_ci", level)?;
    if tp + fn_ == 0 {
        return Err(StatsError::TooFewObservations { what: "F1 CI (positives)", needed: 1, got: 0 });
    }
    let mut rng = SplitMix64([tp, fp, fn_, tn].iter().fold(0x5EED_F1C1, |h, &c| SplitMix64(h ^ c).next_u64()));
    let (positives, negatives) = ((tp + fn_) as f64, (fp + tn) as f64);
    let mut draws: Vec<f64> = (0..F1_CI_DRAWS)
        .map(|_| {
            let recall = rng.beta(tp as f64 + 0.5, fn_ as f64 + 0.5);
            let fp_rate = if negatives > 0.0 { rng.beta(fp as f64 + 0.5, tn as f64 + 0.5) } else { 0.0 };
            2.0 * positives * recall / (positives * recall + positives + negatives * fp_rate)
        })
        .collect();
    draws.sort_by(f64::total_cmp);
    let tail = (1.0 - level) / 2.0;
    let f1 = 2.0 * tp as f64 / (2 * tp + fp + fn_) as f64;
    Ok((quantile_sorted(&draws, tail).min(f1), quantile_sorted(&draws, 1.0 - tail).max(f1)))
}

/// Confusion counts over an ordered label set; `counts[true][predicted]`.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct ConfusionMatrix {
    pub labels: Vec<String>,
    pub counts: Vec<Vec<u64>>,
}

/// Precision, recall, F1 and support of one class.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ClassMetrics {
    pub label: String,
    pub precision: f64,
    pub recall: f64,
    pub f1: f64,
    /// Number of true instances of the class (row sum).
    pub support: u64,
}

/// How per-class metrics are averaged.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum Averaging {
    Macro,
    Micro,
    Weighted,
}

/// Averaged precision, recall and F1.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Averaged {
    pub averaging: Averaging,
    pub precision: f64,
    pub recall: f64,
    pub f1: f64,
}

/// a / b, or 0 when b = 0 (the zero-division convention).
fn ratio(a: f64, b: f64) -> f64 {
    if b == 0.0 { 0.0 } else { a / b }
}

impl ConfusionMatrix {
    /// Counts (true, predicted) pairs over `labels`. Errors on unknown labels, duplicate labels,
    /// or different lengths.
    pub fn from_labels<S: AsRef<str>, T: AsRef<str>, U: AsRef<str>>(
        labels: &[S],
        y_true: &[T],
        y_pred: &[U],
    ) -> Result<Self> {
        super::error::check_same_len(
            "confusion matrix (y_true vs y_pred)",
            y_true.len(),
            y_pred.len(),
        )?;
        let labels: Vec<String> = labels.iter().map(|l| l.as_ref().to_owned()).collect();
        let mut seen = labels.clone();
        seen.sort();
        seen.dedup();
        if seen.len() != labels.len() || labels.is_empty() {
            return Err(StatsError::InvalidParameter {
                what: "confusion matrix",
                detail: "label set empty or has duplicates".into(),
            });
        }
        let index = |l: &str| {
            labels
                .iter()
                .position(|x| x == l)
                .ok_or_else(|| StatsError::UnknownLabel {
                    label: l.to_owned(),
                })
        };
        let mut counts = vec![vec![0u64; labels.len()]; labels.len()];
        for (t, p) in y_true.iter().zip(y_pred) {
            counts[index(t.as_ref())?][index(p.as_ref())?] += 1;
        }
        Ok(Self { labels, counts })
    }

    /// Wraps existing counts (square, one row per label).
    pub fn from_counts(labels: Vec<String>, counts: Vec<Vec<u64>>) -> Result<Self> {
        super::error::check_same_len("confusion matrix rows", counts.len(), labels.len())?;
        for row in &counts {
            super::error::check_same_len("confusion matrix columns", row.len(), labels.len())?;
        }
        Ok(Self { labels, counts })
    }

    /// Total number of judgements.
    pub fn total(&self) -> u64 {
        self.counts.iter().flatten().sum()
    }

    /// Row sum (true instances) of class `i`.
    pub fn row_sum(&self, i: usize) -> u64 {
        self.counts[i].iter().sum()
    }

    /// Column sum (predictions) of class `i`.
    pub fn col_sum(&self, i: usize) -> u64 {
        self.counts.iter().map(|r| r[i]).sum()
    }

    fn diag(&self) -> u64 {
        (0..self.labels.len()).map(|i| self.counts[i][i]).sum()
    }

    fn check_nonempty(&self) -> Result<f64> {
        match self.total() {
            0 => Err(StatsError::TooFewObservations {
                what: "confusion matrix",
                needed: 1,
                got: 0,
            }),
            n => Ok(n as f64),
        }
    }

    /// Proportion of correct judgements (trace / total).
    pub fn accuracy(&self) -> Result<f64> {
        Ok(self.diag() as f64 / self.check_nonempty()?)
    }

    /// Per-class precision, recall, F1 and support, in label order.
    pub fn per_class(&self) -> Vec<ClassMetrics> {
        (0..self.labels.len())
            .map(|i| {
                let tp = self.counts[i][i] as f64;
                let (row, col) = (self.row_sum(i) as f64, self.col_sum(i) as f64);
                ClassMetrics {
                    label: self.labels[i].clone(),
                    precision: ratio(tp, col),
                    recall: ratio(tp, row),
                    f1: ratio(2.0 * tp, row + col),
                    support: self.row_sum(i),
                }
            })
            .collect()
    }

    /// Averaged precision, recall and F1 (see the module doc for the conventions).
    pub fn average(&self, averaging: Averaging) -> Result<Averaged> {
        let n = self.check_nonempty()?;
        let pc = self.per_class();
        let (precision, recall, f1) = match averaging {
            Averaging::Macro => {
                let k = pc.len() as f64;
                (
                    pc.iter().map(|c| c.precision).sum::<f64>() / k,
                    pc.iter().map(|c| c.recall).sum::<f64>() / k,
                    pc.iter().map(|c| c.f1).sum::<f64>() / k,
                )
            }
            Averaging::Weighted => {
                let w = |f: fn(&ClassMetrics) -> f64| {
                    pc.iter().map(|c| f(c) * c.support as f64).sum::<f64>() / n
                };
                (w(|c| c.precision), w(|c| c.recall), w(|c| c.f1))
            }
            Averaging::Micro => {
                let tp = self.diag() as f64;
                let pred: f64 = (0..pc.len()).map(|i| self.col_sum(i) as f64).sum();
                let (p, r) = (ratio(tp, pred), ratio(tp, n));
                (p, r, ratio(2.0 * p * r, p + r))
            }
        };
        Ok(Averaged {
            averaging,
            precision,
            recall,
            f1,
        })
    }

    /// Cohen's κ between the row and column classifications: (p_o − p_e)/(1 − p_e) with
    /// p_e = Σ rowᵢ colᵢ / N². Errors when p_e = 1 (both raters used a single category).
    pub fn cohen_kappa(&self) -> Result<f64> {
        let n = self.check_nonempty()?;
        let po = self.diag() as f64 / n;
        let pe: f64 = (0..self.labels.len())
            .map(|i| self.row_sum(i) as f64 * self.col_sum(i) as f64)
            .sum::<f64>()
            / (n * n);
        if pe >= 1.0 {
            return Err(StatsError::ZeroVariance {
                what: "Cohen's kappa (chance agreement is 1)",
            });
        }
        Ok((po - pe) / (1.0 - pe))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The F1 posterior's `q`-quantile by quadrature, independent of the Monte Carlo in `f1_ci`:
    /// P(F1 ≤ t) = E over recall of P(fpr ≥ P(recall(2 − t) − t) / (tN)), the expectation taken
    /// at 2000 recall quantiles, then bisection on t.
    fn f1_posterior_quantile(tp: u64, fp: u64, fn_: u64, tn: u64, q: f64) -> f64 {
        use statrs::distribution::{Beta, ContinuousCDF};
        let (p, n) = ((tp + fn_) as f64, (fp + tn) as f64);
        let recall = Beta::new(tp as f64 + 0.5, fn_ as f64 + 0.5).unwrap();
        let fp_rate = Beta::new(fp as f64 + 0.5, tn as f64 + 0.5).unwrap();
        let r: Vec<f64> = (0..2000).map(|i| recall.inverse_cdf((i as f64 + 0.5) / 2000.0)).collect();
        let cdf = |t: f64| r.iter().map(|&r| 1.0 - fp_rate.cdf((p * (r * (2.0 - t) - t) / (t * n)).clamp(0.0, 1.0))).sum::<f64>() / r.len() as f64;
        let (mut low, mut high) = (1e-9, 1.0 - 1e-9);
        for _ in 0..50 {
            let mid = (low + high) / 2.0;
            if cdf(mid) < q { low = mid } else { high = mid }
        }
        (low + high) / 2.0
    }

    #[test]
    fn f1_ci_is_the_jeffreys_posterior_interval() {
        // Exp. 1 at 3 coders, an AU every coder found and nobody added (F1 = 1, N = 3 × 48), and a
        // mixed case; the Monte Carlo endpoints agree with quadrature within their error.
        for (tp, fp, fn_, tn) in [(3, 0, 0, 144), (8, 1, 2, 39), (14, 3, 6, 977)] {
            let (low, high) = f1_ci(tp, fp, fn_, tn, 0.95).unwrap();
            let f1 = 2.0 * tp as f64 / (2 * tp + fp + fn_) as f64;
            let expected_low = f1_posterior_quantile(tp, fp, fn_, tn, 0.025).min(f1);
            let expected_high = f1_posterior_quantile(tp, fp, fn_, tn, 0.975).max(f1);
            assert!((low - expected_low).abs() < 0.012 && (high - expected_high).abs() < 0.012, "{tp} {fp} {fn_} {tn}: got ({low:.4}, {high:.4}), quadrature ({expected_low:.4}, {expected_high:.4})");
            assert!(low <= f1 && f1 <= high);
            assert_eq!(f1_ci(tp, fp, fn_, tn, 0.95).unwrap(), (low, high), "same counts, same interval");
        }
        // Every positive found and no false positive: an interval with width (the Wald one had none).
        let (low, high) = f1_ci(3, 0, 0, 144, 0.95).unwrap();
        assert!(high == 1.0 && low < 0.8, "({low}, {high})");
        assert!(f1_ci(0, 3, 0, 10, 0.95).is_err(), "no positives");
    }
    use crate::analysis::stats::test_support::*;

    fn cm() -> ConfusionMatrix {
        ConfusionMatrix::from_labels(&EMO, &Y_TRUE, &Y_PRED).unwrap()
    }

    #[test]
    fn confusion_matrix_matches_sklearn() {
        // sklearn.metrics.confusion_matrix(labels=EMO)
        let expected: Vec<Vec<u64>> =
            serde_json::from_value(rv("classification/confusion_rows_true_cols_pred").clone())
                .unwrap();
        assert_eq!(cm().counts, expected);
        // sklearn.metrics.accuracy_score
        assert_close(
            "accuracy",
            cm().accuracy().unwrap(),
            r("classification/accuracy"),
        );
    }

    #[test]
    fn per_class_matches_sklearn() {
        // sklearn precision_recall_fscore_support(average=None, zero_division=0)
        for c in cm().per_class() {
            let base = format!("classification/per_class/{}", c.label);
            assert_close(
                &format!("{base} P"),
                c.precision,
                r(&format!("{base}/precision")),
            );
            assert_close(&format!("{base} R"), c.recall, r(&format!("{base}/recall")));
            assert_close(&format!("{base} F1"), c.f1, r(&format!("{base}/f1")));
            assert_eq!(c.support as f64, r(&format!("{base}/support")));
        }
    }

    #[test]
    fn averages_match_sklearn() {
        // sklearn precision_recall_fscore_support(average=macro|micro|weighted, zero_division=0)
        for (avg, key) in [
            (Averaging::Macro, "macro"),
            (Averaging::Micro, "micro"),
            (Averaging::Weighted, "weighted"),
        ] {
            let a = cm().average(avg).unwrap();
            assert_close(
                &format!("{key} P"),
                a.precision,
                r(&format!("classification/{key}/precision")),
            );
            assert_close(
                &format!("{key} R"),
                a.recall,
                r(&format!("classification/{key}/recall")),
            );
            assert_close(
                &format!("{key} F1"),
                a.f1,
                r(&format!("classification/{key}/f1")),
            );
        }
    }

    #[test]
    fn cohen_kappa_matches_sklearn() {
        // sklearn.metrics.cohen_kappa_score
        assert_close(
            "kappa",
            cm().cohen_kappa().unwrap(),
            r("classification/cohen_kappa"),
        );
    }

    #[test]
    fn identities() {
        let m = cm();
        // F1 is the harmonic mean of P and R.
        for c in m.per_class() {
            let h = if c.precision + c.recall == 0.0 {
                0.0
            } else {
                2.0 * c.precision * c.recall / (c.precision + c.recall)
            };
            assert_close_tol(&c.label, c.f1, h, IDENTITY_TOL);
        }
        // Micro P = R = F1 = accuracy for single-label data over the full label set.
        let micro = m.average(Averaging::Micro).unwrap();
        assert_close_tol(
            "micro f1 = accuracy",
            micro.f1,
            m.accuracy().unwrap(),
            IDENTITY_TOL,
        );
        // Weighted recall = accuracy.
        assert_close_tol(
            "weighted R",
            m.average(Averaging::Weighted).unwrap().recall,
            m.accuracy().unwrap(),
            IDENTITY_TOL,
        );
    }

    #[test]
    fn zero_division_is_zero_and_unknown_labels_error() {
        // A class never predicted and never true: P = R = F1 = 0.
        let m = ConfusionMatrix::from_labels(&["a", "b", "c"], &["a", "b"], &["a", "a"]).unwrap();
        let c = &m.per_class()[2];
        assert_eq!((c.precision, c.recall, c.f1, c.support), (0.0, 0.0, 0.0, 0));
        assert!(matches!(
            ConfusionMatrix::from_labels(&["a"], &["a"], &["z"]),
            Err(StatsError::UnknownLabel { .. })
        ));
        assert!(
            ConfusionMatrix::from_labels(&["a"], &["a"], &["a"])
                .unwrap()
                .cohen_kappa()
                .is_err()
        );
    }
}
