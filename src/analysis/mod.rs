//! Analysis: responses + ground truth in, statistics out.
//!
//! **What comes in:** plain Rust data — slices of observations, group vectors, label sequences,
//! confusion counts, time series — already extracted from the long-format responses and the
//! stimulus manifest by the caller.
//!
//! **What goes out:** plain result structs (t, df, p, effect sizes, confidence intervals, ANOVA
//! tables, agreement coefficients, classification metrics, DTW distances and paths, cluster
//! assignments) that the report serialises.
//!
//! **Architecture invariants:**
//! - knows nothing of HTTP or SQLite: the CLI (`facslab analyze`) and the server both call it;
//! - never panics on data: bad input (empty groups, mismatched lengths, zero variance, non-finite
//!   values, unknown labels) comes back as a typed [`stats::StatsError`];
//! - every public function documents its convention (sample vs population variance, which
//!   Cohen's d, SS type and contrasts, averaging, zero-division, DTW cost and band shape …),
//!   because the same name means different numbers in different libraries;
//! - distributions (t, F, χ², normal, binomial) come from `statrs`; everything built on top of
//!   them (tests, effect sizes, ANOVA, the studentized range) lives here and is checked against
//!   the reference values in `tests/fixtures/stats/` (scipy, statsmodels, pingouin,
//!   scikit-learn, dtaidistance, tslearn, kmedoids).

mod input;
pub mod coding;
pub mod demographics;
pub mod manifest;
pub mod outcome;
pub mod power;
mod published;
#[cfg(feature = "polars")]
pub mod parquet;
#[cfg(not(feature = "polars"))]
#[path = "parquet_off.rs"]
pub mod parquet;
pub mod rating;
pub mod simulate;
pub mod styles;
pub mod responses;
pub mod stats;

pub use input::{InputError, is_parquet};

use coding::{CodingOptions, CodingReport};
use rating::RatingReport;

/// Every section of an analysis of one study.
#[derive(Debug, Clone)]
pub struct Analysis {
    /// Exp. 1–2: coders against the ground truth (Tables 1–4); absent without `aus` answers.
    pub coding: Option<CodingReport>,
    /// Exp. 3–4: lay raters (Tables 7–14); absent without emotion answers or ratings.
    pub rating: Option<RatingReport>,
    /// Table 6; absent when nobody stated demographics.
    pub demographics: Option<demographics::Demographics>,
    /// Seed 004: ratings by label × style; empty unless the stimuli cross two styles and labels.
    pub styles: Vec<styles::StyleScale>,
}

/// The whole analysis of validated responses against their manifest. No I/O: the responses come
/// from a file ([`responses::Responses::read`]) or straight from a study's database
/// ([`responses::Responses::from_rows`]), and the report renders the result.
pub fn analyze(manifest: &manifest::Manifest, responses: &responses::Responses, options: &CodingOptions) -> Analysis {
    let catalog = crate::facs::Catalog::built_in();
    Analysis {
        coding: coding::analyze(manifest, responses, catalog, *options),
        rating: rating::analyze(manifest, responses),
        demographics: demographics::analyze(manifest, responses),
        styles: styles::analyze(manifest, responses),
    }
}

/// Test inputs written inline: manifest and response rows under their standard headers.
#[cfg(test)]
pub(crate) fn fixture(manifest_rows: &str, response_rows: &str) -> (manifest::Manifest, responses::Responses) {
    use crate::facs::{Catalog, EmotionTable};
    let (catalog, emotions) = (Catalog::built_in(), EmotionTable::built_in());
    let manifest = manifest::Manifest::from_csv(
        "m.csv",
        &format!("stimulus_id,media,identity,expression,emotion,intensity\n{manifest_rows}"),
        catalog,
    )
    .expect("a valid test manifest");
    let responses = responses::Responses::from_csv(
        "r.csv",
        &format!("participant_id,group,stimulus_id,trial,measure,value,rt_ms\n{response_rows}"),
        &manifest,
        catalog,
        &emotions,
    )
    .expect("valid test responses");
    (manifest, responses)
}
