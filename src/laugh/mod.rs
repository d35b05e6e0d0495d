//! Laughs and smiles (seed 004): the thirteen laugh and smile types, the curves that animate
//! them, and the pipeline that fits those curves to landmark tracks.
//!
//! In: a laugh type's table entry or a [`Curves`] file fitted from tracked landmarks.
//! Out: an engine [`crate::engine::timeline::Timeline`] that any identity can play.
//! Invariant: a curve set is per-frame AU intensities in [0, 1] at one frame rate; every
//! consumer (render, `.anim` export, timeline export) reads it through [`Curves`].
//!
//! The fitting pipeline: [`landmarks`] (CSV tracks in four layouts) → [`params`] (FP1-FP15,
//! Eq. 1 controllers, the AU mapping) → [`fit`] (DTW Table 3, k-medoids prototype) → [`Curves`].
//! [`types`] reads the table (`stimuli/laughs/types.toml`); [`perform`] turns a type and a
//! seeded [`Take`] into curves; [`anim`] writes and reads them as Maya ASCII `.anim` files;
//! [`strip`] lays a few frames of a take side by side.

pub mod anim;
pub mod curves;
pub mod fit;
pub mod landmarks;
pub mod params;
pub mod perform;
pub mod strip;
pub mod types;

pub use curves::{CurveTrack, Curves, CurvesError};
pub use perform::{perform, PerformError, Take};
pub use types::{Kind, LaughTable, LaughType, TypesError};
