//! Typed errors: every way data can make a statistic undefined.

use thiserror::Error;

/// Why a statistic could not be computed. Functions return these instead of panicking or
/// silently producing NaN.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum StatsError {
    /// A group, sample or table has fewer observations than the statistic needs.
    #[error("{what}: needs at least {needed} observations, got {got}")]
    TooFewObservations {
        what: &'static str,
        needed: usize,
        got: usize,
    },
    /// Two inputs that must be paired element by element have different lengths.
    #[error("{what}: lengths differ ({left} vs {right})")]
    LengthMismatch {
        what: &'static str,
        left: usize,
        right: usize,
    },
    /// The statistic divides by a variance (or a total) that is zero.
    #[error("{what}: zero variance, the statistic is undefined")]
    ZeroVariance { what: &'static str },
    /// An input value is NaN or infinite (missing data must be handled before, by a stated policy).
    #[error("{what}: non-finite value at position {index}")]
    NonFinite { what: &'static str, index: usize },
    /// A parameter is outside its domain (probability outside [0, 1], k = 0, …).
    #[error("{what}: invalid parameter: {detail}")]
    InvalidParameter { what: &'static str, detail: String },
    /// A label is not in the declared label set.
    #[error("label {label:?} is not in the label set")]
    UnknownLabel { label: String },
    /// The design matrix is rank deficient (e.g. an empty cell in a factorial design).
    #[error("{what}: rank-deficient design ({detail})")]
    RankDeficient { what: &'static str, detail: String },
    /// DTW: no warping path lies inside the requested band.
    #[error("DTW: no warping path lies inside the Sakoe–Chiba band of radius {radius}")]
    NoPathInBand { radius: usize },
}

/// Checks that every value is finite.
pub(crate) fn check_finite(what: &'static str, x: &[f64]) -> Result<(), StatsError> {
    match x.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(StatsError::NonFinite { what, index }),
        None => Ok(()),
    }
}

/// Checks that a sample has at least `needed` observations.
pub(crate) fn check_len(what: &'static str, x: &[f64], needed: usize) -> Result<(), StatsError> {
    if x.len() < needed {
        return Err(StatsError::TooFewObservations {
            what,
            needed,
            got: x.len(),
        });
    }
    Ok(())
}

/// Checks that two paired inputs have the same length.
pub(crate) fn check_same_len(
    what: &'static str,
    left: usize,
    right: usize,
) -> Result<(), StatsError> {
    if left != right {
        return Err(StatsError::LengthMismatch { what, left, right });
    }
    Ok(())
}

/// Checks that a probability-like parameter is in the open/closed interval the caller needs.
pub(crate) fn check_level(what: &'static str, level: f64) -> Result<(), StatsError> {
    if !(level > 0.0 && level < 1.0) {
        return Err(StatsError::InvalidParameter {
            what,
            detail: format!("level {level} not in (0, 1)"),
        });
    }
    Ok(())
}
