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
//! - [`f1_ci`]: Wald interval of one binary F1 by the delta method, conditional on the design's
//!   positives P = TP + FN and negatives N = FP + TN (fixed by what was shown):
//!   TP ~ Binomial(P, recall), FP ~ Binomial(N, false-positive rate), independent;
//!   Var(F1) = 4[(P + FP)² Var(TP) + TP² Var(FP)] / (2TP + FP + FN)⁴ with the plug-in variances
//!   TP·FN/P and FP·TN/N; F1 ± z·SD, clipped to [0, 1]. Zero width when both plug-in variances
//!   are 0 (every positive found and no false positive, or no positive found).

use statrs::distribution::{ContinuousCDF, Normal};

use super::{Result, StatsError};

/// Delta-method Wald CI of F1 = 2TP / (2TP + FP + FN) at `level` (see the module doc).
pub fn f1_ci(tp: u64, fp: u64, fn_: u64, tn: u64, level: f64) -> Result<(f64, f64)> {
    super::error::check_level("f1_ci", level)?;
    let (tp, fp, fn_, tn) = (tp as f64, fp as f64, fn_ as f64, tn as f64);
    let (positives, negatives, d) = (tp + fn_, fp + tn, 2.0 * tp + fp + fn_);
    if positives == 0.0 || d == 0.0 {
        return Err(StatsError::TooFewObservations { what: "F1 CI (positives)", needed: 1, got: 0 });
    }
    let var_tp = tp * fn_ / positives;
    let var_fp = if negatives > 0.0 { fp * tn / negatives } else { 0.0 };
    let var = 4.0 * ((positives + fp).powi(2) * var_tp + tp * tp * var_fp) / d.powi(4);
    let z = Normal::new(0.0, 1.0)
        .map_err(|e| StatsError::InvalidParameter { what: "normal distribution", detail: e.to_string() })?
        .inverse_cdf(1.0 - (1.0 - level) / 2.0);
    let f1 = 2.0 * tp / d;
    Ok(((f1 - z * var.sqrt()).max(0.0), (f1 + z * var.sqrt()).min(1.0)))
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

    #[test]
    fn f1_ci_by_the_delta_method_by_hand() {
        // TP 8, FN 2 (P = 10), FP 1, TN 39 (N = 40): F1 = 16/19; Var(TP) = 1.6, Var(FP) = 0.975;
        // Var(F1) = 4 (11² · 1.6 + 8² · 0.975) / 19⁴ = 1024 / 130321; z(0.975) = 1.959963984540054.
        let (low, high) = f1_ci(8, 1, 2, 39, 0.95).unwrap();
        let half = 1.959963984540054 * (1024f64 / 130321.0).sqrt();
        assert!((low - (16.0 / 19.0 - half)).abs() < 1e-12 && (high - (16.0 / 19.0 + half).min(1.0)).abs() < 1e-12, "{low} {high}");
        // Perfect recall and no false positive: no sampling variance in the plug-in, zero width.
        assert_eq!(f1_ci(5, 0, 0, 10, 0.95).unwrap(), (1.0, 1.0));
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
