//! Statistics on top of `statrs` distributions.
//!
//! One module per family; all return [`Result`] with [`StatsError`].
//! - [`descriptive`]: mean, sample variance (n − 1), standard deviation, standard error.
//! - [`ttest`]: Student, Welch and paired t-tests with Cohen's d and the CI of the mean difference.
//! - [`anova`]: one-way (η²), two-way between-subjects (Type I/II/III, sum-to-zero contrasts),
//!   repeated-measures one-way (Mauchly's W, Greenhouse–Geisser).
//! - [`posthoc`]: Scheffé and Tukey HSD pairwise comparisons; [`studentized_range`] CDF/quantile.
//! - [`reliability`]: Cronbach's α (Feldt CI), Cohen's κ, Fleiss' κ, Dice agreement, ICC.
//! - [`classification`]: confusion matrix, accuracy, precision/recall/F1 with averaging.
//! - [`hit_rate`]: Wagner's (1993) unbiased hit rate Hu.
//! - [`binomial`]: exact binomial test against chance (scipy's `binomtest`).
//! - [`dtw`]: dynamic time warping (both cost conventions, Sakoe–Chiba band, path).
//! - [`cluster`]: k-means (Lloyd, given initial centres) and k-medoids (PAM swap).

pub mod anova;
pub mod binomial;
pub mod classification;
pub mod cluster;
pub mod descriptive;
pub mod dtw;
mod error;
pub mod hit_rate;
mod linalg;
pub mod posthoc;
pub mod reliability;
pub mod studentized_range;
pub mod ttest;

#[cfg(test)]
pub(crate) mod test_support;

pub use error::StatsError;

/// Result type of every statistic in this module.
pub type Result<T> = std::result::Result<T, StatsError>;
