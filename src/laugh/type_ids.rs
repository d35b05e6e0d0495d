//! The ids of the thirteen laugh and smile types (seed 004, after Faigin), the one place
//! `facslab curves fit --type` checks against.
//!
//! In: a type id from the command line. Out: whether it names one of the thirteen.
//! Invariant: this list and the type table (`stimuli/laughs/types.toml`, made on the
//! `laugh-face` branch, checked equal at its commit 9fef146) name the same types; when the table
//! is merged, [`is_laugh_type`] becomes `LaughTable::built_in().get(id).is_some()` and this list
//! goes.

/// The thirteen types, in the seed's taxonomy order (Fig. 1, 1-13).
pub const LAUGH_TYPES: [&str; 13] = [
    "uproarious_laughter",
    "laughter",
    "open_mouthed_smile",
    "closed_mouth_smile",
    "stifled_smile",
    "melancholy_smile",
    "eager_smile",
    "ingratiating_smile",
    "sly_smile",
    "debauched_smile",
    "abashed_smile",
    "false_smile",
    "false_laughter",
];

/// Whether `id` is one of [`LAUGH_TYPES`].
pub fn is_laugh_type(id: &str) -> bool {
    LAUGH_TYPES.contains(&id)
}
