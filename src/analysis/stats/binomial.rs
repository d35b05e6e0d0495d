//! Exact binomial test, e.g. of an emotion's recognition rate against chance (1 / number of
//! response options).
//!
//! Convention: as `scipy.stats.binomtest`. Two-sided p sums the probabilities of all outcomes
//! no more likely than the observed one, with scipy's relative tie tolerance 1e−7
//! (p = Σ P(X = i) over i with P(X = i) ≤ P(X = k)·(1 + 1e−7)), capped at 1. `Greater` is
//! P(X ≥ k) (above chance), `Less` is P(X ≤ k).
//! The CI of the proportion is the exact Clopper–Pearson interval (scipy's
//! `proportion_ci(method="exact")`): Beta quantiles, 0 and 1 at the boundaries.

use super::{Result, StatsError};
use statrs::distribution::{Binomial, Discrete};
use statrs::function::beta::inv_beta_reg;

/// scipy's relative tolerance for "as likely as the observed outcome".
const TIE_RTOL: f64 = 1e-7;

/// Alternative hypothesis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum Alternative {
    TwoSided,
    /// True proportion > p0 (e.g. recognition above chance).
    Greater,
    /// True proportion < p0.
    Less,
}

/// Result of an exact binomial test.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct BinomTest {
    pub successes: u64,
    pub trials: u64,
    pub p0: f64,
    pub alternative: Alternative,
    /// k / n.
    pub estimate: f64,
    pub p_value: f64,
    /// Confidence level of `ci`.
    pub ci_level: f64,
    /// Two-sided Clopper–Pearson CI of the proportion.
    pub ci: (f64, f64),
}

/// Exact (Clopper–Pearson) two-sided CI of k/n at `level`.
pub fn clopper_pearson(successes: u64, trials: u64, level: f64) -> Result<(f64, f64)> {
    super::error::check_level("clopper_pearson", level)?;
    if trials == 0 || successes > trials {
        return Err(StatsError::InvalidParameter {
            what: "clopper_pearson",
            detail: format!("{successes} successes out of {trials} trials"),
        });
    }
    let (k, n, tail) = (successes as f64, trials as f64, (1.0 - level) / 2.0);
    let lower = if successes == 0 {
        0.0
    } else {
        inv_beta_reg(k, n - k + 1.0, tail)
    };
    let upper = if successes == trials {
        1.0
    } else {
        inv_beta_reg(k + 1.0, n - k, 1.0 - tail)
    };
    Ok((lower, upper))
}

/// Exact test of `successes` out of `trials` against success probability `p0`, with the
/// Clopper–Pearson CI of the proportion at `ci_level`.
pub fn binomial_test(
    successes: u64,
    trials: u64,
    p0: f64,
    alternative: Alternative,
    ci_level: f64,
) -> Result<BinomTest> {
    if trials == 0 || successes > trials {
        return Err(StatsError::InvalidParameter {
            what: "binomial test",
            detail: format!("{successes} successes out of {trials} trials"),
        });
    }
    let dist = Binomial::new(p0, trials).map_err(|e| StatsError::InvalidParameter {
        what: "binomial test p0",
        detail: e.to_string(),
    })?;
    let sum = |range: std::ops::RangeInclusive<u64>| range.map(|i| dist.pmf(i)).sum::<f64>();
    let p_value = match alternative {
        Alternative::Greater => sum(successes..=trials),
        Alternative::Less => sum(0..=successes),
        Alternative::TwoSided => {
            let bound = dist.pmf(successes) * (1.0 + TIE_RTOL);
            (0..=trials)
                .map(|i| dist.pmf(i))
                .filter(|&p| p <= bound)
                .sum::<f64>()
        }
    }
    .min(1.0);
    Ok(BinomTest {
        successes,
        trials,
        p0,
        alternative,
        estimate: successes as f64 / trials as f64,
        p_value,
        ci_level,
        ci: clopper_pearson(successes, trials, ci_level)?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::stats::test_support::*;

    #[test]
    fn matches_exact_enumeration() {
        // Expected values: scipy.stats.binomtest's definition evaluated in exact rational
        // arithmetic (Python `fractions`, binomial pmf summed term by term).
        let cases = [
            // (k, n, p0, two-sided, greater, less)
            (
                7,
                20,
                1.0 / 7.0,
                0.017053144165804498,
                0.017053144165804498,
                0.9956356168770765,
            ),
            (3, 10, 0.5, 0.34375, 0.9453125, 0.171875),
            (
                12,
                20,
                0.5,
                0.5034446716308594,
                0.2517223358154297,
                0.8684120178222656,
            ),
            (0, 10, 0.25, 0.07604122161865234, 1.0, 0.056313514709472656),
            (
                9,
                30,
                1.0 / 6.0,
                0.08005459978538193,
                0.05056555815376996,
                0.9802937162310322,
            ),
        ];
        for (k, n, p0, two, greater, less) in cases {
            let t = |alt| binomial_test(k, n, p0, alt, 0.95).unwrap().p_value;
            assert_close(&format!("{k}/{n} two-sided"), t(Alternative::TwoSided), two);
            assert_close(
                &format!("{k}/{n} greater"),
                t(Alternative::Greater),
                greater,
            );
            assert_close(&format!("{k}/{n} less"), t(Alternative::Less), less);
        }
    }

    #[test]
    fn matches_scipy_binomtest() {
        // scipy.stats.binomtest(k, n, p0, alternative=…).pvalue (scipy 1.17.1)
        for (i, c) in scipy_extra()["binomtest"]
            .as_array()
            .unwrap()
            .iter()
            .enumerate()
        {
            let (k, n, p0) = (
                c["k"].as_u64().unwrap(),
                c["n"].as_u64().unwrap(),
                c["p0"].as_f64().unwrap(),
            );
            for (alt, key) in [
                (Alternative::TwoSided, "two_sided"),
                (Alternative::Greater, "greater"),
                (Alternative::Less, "less"),
            ] {
                let got = binomial_test(k, n, p0, alt, 0.95).unwrap().p_value;
                assert_close(
                    &format!("{k}/{n} {key}"),
                    got,
                    sx(&format!("binomtest/{i}/{key}")),
                );
            }
        }
    }

    #[test]
    fn clopper_pearson_matches_scipy() {
        // scipy.stats.binomtest(k, n, p0).proportion_ci(0.95, method="exact") (scipy 1.17.1)
        for (i, c) in scipy_extra()["binomtest"]
            .as_array()
            .unwrap()
            .iter()
            .enumerate()
        {
            let (k, n) = (c["k"].as_u64().unwrap(), c["n"].as_u64().unwrap());
            let (lo, hi) = clopper_pearson(k, n, 0.95).unwrap();
            assert_close(
                &format!("{k}/{n} lo"),
                lo,
                sx(&format!("binomtest/{i}/ci95_exact/0")),
            );
            assert_close(
                &format!("{k}/{n} hi"),
                hi,
                sx(&format!("binomtest/{i}/ci95_exact/1")),
            );
        }
        assert_eq!(clopper_pearson(10, 10, 0.95).unwrap().1, 1.0);
    }

    #[test]
    fn symmetric_case_and_errors() {
        // Identity: with p0 = 1/2 the two-sided p is twice the smaller tail (capped at 1).
        let two = binomial_test(3, 10, 0.5, Alternative::TwoSided, 0.95)
            .unwrap()
            .p_value;
        let less = binomial_test(3, 10, 0.5, Alternative::Less, 0.95)
            .unwrap()
            .p_value;
        assert_close_tol("2 × tail", two, 2.0 * less, IDENTITY_TOL);
        assert_eq!(
            binomial_test(5, 10, 0.5, Alternative::TwoSided, 0.95)
                .unwrap()
                .p_value,
            1.0
        );
        assert!(binomial_test(11, 10, 0.5, Alternative::TwoSided, 0.95).is_err());
        assert!(binomial_test(1, 10, 1.5, Alternative::TwoSided, 0.95).is_err());
    }
}
