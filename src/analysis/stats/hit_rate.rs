//! Wagner's (1993) unbiased hit rate, Hu.
//!
//! Convention: from a confusion matrix with rows = stimulus (true) category and columns =
//! response category, Huᵢ = nᵢᵢ² / (rowᵢ · colᵢ) — the hit rate (nᵢᵢ/rowᵢ) times the
//! proportion of uses of response i that were correct (nᵢᵢ/colᵢ). Hu = 0 when the category was
//! never presented or never chosen. The matching chance proportion is
//! pcᵢ = (rowᵢ/N)(colᵢ/N). Wagner recommends comparing arcsine-transformed Hu with pc per
//! participant ([`arcsine`]).
//!
//! Wagner, H. L. (1993). On measuring performance in category judgment studies of nonverbal
//! behavior. *Journal of Nonverbal Behavior*, 17(1), 3–28.

use super::classification::ConfusionMatrix;

/// Hit rates of one category.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct HitRate {
    pub label: String,
    /// Raw hit rate nᵢᵢ / rowᵢ (0 if never presented).
    pub raw: f64,
    /// Unbiased hit rate nᵢᵢ² / (rowᵢ · colᵢ).
    pub hu: f64,
    /// Chance proportion (rowᵢ/N)(colᵢ/N).
    pub chance: f64,
}

/// Hu, raw hit rate and chance proportion for every category, in label order.
pub fn unbiased_hit_rates(cm: &ConfusionMatrix) -> Vec<HitRate> {
    let n = cm.total() as f64;
    (0..cm.labels.len())
        .map(|i| {
            let (hit, row, col) = (
                cm.counts[i][i] as f64,
                cm.row_sum(i) as f64,
                cm.col_sum(i) as f64,
            );
            HitRate {
                label: cm.labels[i].clone(),
                raw: if row > 0.0 { hit / row } else { 0.0 },
                hu: if row * col > 0.0 {
                    hit * hit / (row * col)
                } else {
                    0.0
                },
                chance: if n > 0.0 { row * col / (n * n) } else { 0.0 },
            }
        })
        .collect()
}

/// Arcsine-square-root transform, asin(√p), for proportions in [0, 1] (clamped).
pub fn arcsine(p: f64) -> f64 {
    p.clamp(0.0, 1.0).sqrt().asin()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::stats::test_support::*;

    #[test]
    fn hu_from_the_reference_confusion_matrix() {
        // Wagner (1993) formula applied by hand to the scikit-learn confusion matrix of the
        // reference data (rows true, cols predicted), N = 20:
        // anger 1²/(2·2) = 0.25; fear 1²/(3·3) = 1/9; happy 3²/(4·3) = 0.75;
        // surprise 2²/(3·4) = 1/3; chance for happy = (4/20)(3/20) = 0.03.
        let cm = ConfusionMatrix::from_labels(&EMO, &Y_TRUE, &Y_PRED).unwrap();
        let hu = unbiased_hit_rates(&cm);
        assert_close("anger", hu[0].hu, 0.25);
        assert_close("fear", hu[2].hu, 1.0 / 9.0);
        assert_close("happy", hu[3].hu, 0.75);
        assert_close("surprise", hu[6].hu, 1.0 / 3.0);
        assert_close("happy chance", hu[3].chance, 0.03);
        assert_close("happy raw", hu[3].raw, 0.75);
    }

    #[test]
    fn hu_is_recall_times_precision() {
        // Identity: Hu = recall · precision of the same class.
        let cm = ConfusionMatrix::from_labels(&EMO, &Y_TRUE, &Y_PRED).unwrap();
        for (h, c) in unbiased_hit_rates(&cm).iter().zip(cm.per_class()) {
            assert_close_tol(&h.label, h.hu, c.recall * c.precision, IDENTITY_TOL);
        }
        // Hu ≤ raw hit rate, and a perfect judge gets Hu = 1.
        let perfect = ConfusionMatrix::from_labels(&EMO, &EMO, &EMO).unwrap();
        assert!(unbiased_hit_rates(&perfect).iter().all(|h| h.hu == 1.0));
        assert_close_tol(
            "asin(1)",
            arcsine(1.0),
            std::f64::consts::FRAC_PI_2,
            IDENTITY_TOL,
        );
    }
}
