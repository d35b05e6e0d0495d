//! Test-only helpers: the one tolerance, the reference JSON, and the reference inputs.
//!
//! Expected values: `tests/fixtures/stats/stats_reference.expected.json`, computed by
//! scipy 1.17.1, statsmodels 0.15.0, pingouin 0.6.1, scikit-learn 1.9.1, scikit-posthocs 0.17.1,
//! dtaidistance 2.5.1, tslearn 0.10.0 and kmedoids 0.5.5 (see the generating script
//! `stats_reference.py` in the shared reference folder). The inputs below are copied verbatim
//! from that script.

use std::sync::OnceLock;

/// The one relative tolerance for values checked against the reference libraries.
pub const REL_TOL: f64 = 1e-6;

/// Absolute tolerance for published tables rounded to 3 decimals (half a unit in the last place).
pub const TABLE_3DP_TOL: f64 = 5e-4;

/// Absolute tolerance for published tables rounded to 2 decimals.
pub const TABLE_2DP_TOL: f64 = 5e-3;

/// Tolerance for identities that hold exactly in exact arithmetic (only rounding differs).
pub const IDENTITY_TOL: f64 = 1e-9;

/// Asserts `|got - expected| <= tol * |expected|` (relative); absolute `tol` when expected is 0.
#[track_caller]
pub fn assert_close_tol(what: &str, got: f64, expected: f64, tol: f64) {
    let bound = if expected == 0.0 {
        tol
    } else {
        tol * expected.abs()
    };
    assert!(
        (got - expected).abs() <= bound,
        "{what}: expected {expected:e}, got {got:e} (diff {:e}, bound {bound:e})",
        (got - expected).abs()
    );
}

/// Asserts agreement within [`REL_TOL`], relative to the expected value.
#[track_caller]
pub fn assert_close(what: &str, got: f64, expected: f64) {
    assert_close_tol(what, got, expected, REL_TOL);
}

/// Asserts agreement within an absolute tolerance (for rounded published tables).
#[track_caller]
pub fn assert_abs(what: &str, got: f64, expected: f64, tol: f64) {
    assert!(
        (got - expected).abs() <= tol,
        "{what}: expected {expected}, got {got} (tol {tol})"
    );
}

/// The reference JSON, parsed once.
pub fn reference() -> &'static serde_json::Value {
    static REF: OnceLock<serde_json::Value> = OnceLock::new();
    REF.get_or_init(|| {
        let text = include_str!("../../../tests/fixtures/stats/stats_reference.expected.json");
        serde_json::from_str(text).expect("reference JSON parses")
    })
}

/// A number from the reference JSON by slash-separated path, e.g. `"anova_oneway/F"`.
#[track_caller]
pub fn r(path: &str) -> f64 {
    let ptr = format!("/{path}");
    reference()
        .pointer(&ptr)
        .and_then(serde_json::Value::as_f64)
        .unwrap_or_else(|| panic!("reference value {path} missing or not a number"))
}

/// A JSON value from the reference by slash-separated path.
#[track_caller]
pub fn rv(path: &str) -> &'static serde_json::Value {
    let ptr = format!("/{path}");
    reference()
        .pointer(&ptr)
        .unwrap_or_else(|| panic!("reference value {path} missing"))
}

// ---------------------------------------------------------------- inputs (from stats_reference.py)

/// Likert items, rows = participants, columns = items (`ITEMS`).
pub fn items() -> Vec<Vec<f64>> {
    [
        [4, 5, 4, 3],
        [3, 4, 3, 3],
        [5, 5, 4, 4],
        [2, 3, 2, 3],
        [4, 4, 5, 4],
        [3, 2, 3, 2],
        [5, 4, 5, 5],
        [1, 2, 2, 1],
    ]
    .iter()
    .map(|row| row.iter().map(|&v| f64::from(v)).collect())
    .collect()
}

/// Condition A (`A`).
pub const A: [f64; 8] = [0.82, 0.75, 0.91, 0.68, 0.79, 0.88, 0.73, 0.85];
/// Condition B, unequal n (`B`).
pub const B: [f64; 10] = [0.71, 0.64, 0.80, 0.59, 0.77, 0.66, 0.70, 0.62, 0.75, 0.69];
/// Paired pre scores (`PRE`).
pub const PRE: [f64; 8] = [3.1, 2.8, 3.5, 4.0, 2.9, 3.3, 3.8, 3.0];
/// Paired post scores (`POST`).
pub const POST: [f64; 8] = [3.6, 3.0, 3.9, 4.1, 3.5, 3.2, 4.4, 3.7];
/// One-way groups (`G1`, `G2`, `G3`).
pub const G1: [f64; 5] = [5.1, 4.8, 6.0, 5.5, 5.2];
pub const G2: [f64; 6] = [6.2, 6.8, 5.9, 7.1, 6.5, 6.6];
pub const G3: [f64; 4] = [4.1, 4.9, 4.4, 3.8];

/// Two-way unbalanced 2×3 design (`TW`): factor A, factor B, response y.
pub const TW_A: [&str; 21] = [
    "a1", "a1", "a1", "a1", "a1", "a1", "a1", "a1", "a1", "a1", //
    "a2", "a2", "a2", "a2", "a2", "a2", "a2", "a2", "a2", "a2", "a2",
];
pub const TW_B: [&str; 21] = [
    "b1", "b1", "b1", "b2", "b2", "b2", "b2", "b3", "b3", "b3", //
    "b1", "b1", "b2", "b2", "b2", "b3", "b3", "b3", "b3", "b3", "b1",
];
pub const TW_Y: [f64; 21] = [
    12.1, 11.4, 13.0, 14.2, 15.1, 13.8, 14.9, 10.2, 9.8, 11.0, //
    13.5, 12.9, 17.8, 16.9, 18.2, 12.0, 11.5, 12.8, 11.9, 12.2, 14.1,
];

/// Repeated measures (`RM`), wide: rows = subjects 1–6, columns = conditions c1–c3.
pub fn rm_wide() -> Vec<Vec<f64>> {
    vec![
        vec![10.0, 12.0, 15.0],
        vec![8.0, 9.0, 13.0],
        vec![11.0, 14.0, 14.0],
        vec![9.0, 11.0, 12.0],
        vec![12.0, 12.0, 16.0],
        vec![7.0, 10.0, 11.0],
    ]
}

/// Emotion label set (`EMO`).
pub const EMO: [&str; 7] = [
    "anger", "disgust", "fear", "happy", "neutral", "sad", "surprise",
];
/// True labels (`Y_TRUE`).
pub const Y_TRUE: [&str; 20] = [
    "happy", "happy", "sad", "anger", "fear", "surprise", "neutral", "disgust", "sad",
    "happy", //
    "fear", "surprise", "anger", "neutral", "disgust", "sad", "happy", "fear", "surprise",
    "neutral",
];
/// Predicted labels (`Y_PRED`).
pub const Y_PRED: [&str; 20] = [
    "happy", "neutral", "sad", "disgust", "surprise", "surprise", "neutral", "anger", "fear",
    "happy", //
    "fear", "fear", "anger", "neutral", "disgust", "sad", "happy", "surprise", "surprise", "sad",
];

/// DTW series (`S1`, `S2`, `S4` = S1 delayed by 2 frames, `S5` = longer).
pub const S1: [f64; 9] = [0.0, 0.1, 0.4, 0.9, 1.0, 0.8, 0.3, 0.1, 0.0];
pub const S2: [f64; 10] = [0.0, 0.0, 0.1, 0.5, 0.95, 1.0, 0.7, 0.2, 0.05, 0.0];
pub const S4: [f64; 9] = [0.0, 0.0, 0.0, 0.1, 0.4, 0.9, 1.0, 0.8, 0.3];
pub const S5: [f64; 11] = [0.0, 0.0, 0.0, 0.0, 0.1, 0.4, 0.9, 1.0, 0.8, 0.3, 0.1];

/// Points for clustering (`PTS`); initial rows 0, 4, 8 (`INIT`).
pub fn pts() -> Vec<Vec<f64>> {
    [
        [1.0, 1.1],
        [1.2, 0.9],
        [0.8, 1.0],
        [1.1, 1.3],
        [5.0, 5.2],
        [5.3, 4.9],
        [4.8, 5.1],
        [5.1, 5.4],
        [9.0, 1.0],
        [9.2, 1.3],
        [8.7, 0.8],
        [9.1, 0.9],
        [3.0, 3.0],
    ]
    .iter()
    .map(|p| p.to_vec())
    .collect()
}
