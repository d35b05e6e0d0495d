//! Stimulus sets: specifications (TOML, `stimuli/sets/`), their validation and expansion into
//! entries ([`spec`]), the build that renders them with opaque file names ([`build`]; frames that several entries
//! show are rendered once, [`frames`]), and the
//! manifest and per-frame ground truth written beside them ([`manifest`]); a set split into
//! shards built anywhere and merged back into the same bytes ([`shard`]); the set's secret dither
//! key and the sub-visible dither it puts on every picture a participant sees ([`dither`]); the
//! user's label sets a set's stimuli are labelled with, carried in the set ([`labels`]).
//!
//! In: a spec file. Out: a directory of media files plus `manifest.csv`/`manifest.json`.
//! Invariant: a spec is fully validated before anything renders, and the same spec, seed and
//! dither key give byte-identical manifests and media. Nothing a participant can see (file names,
//! paths, ids) depends on what a stimulus shows, and a dithered set's media differ from a public
//! re-render. Absent: studies, participants, HTTP.

pub mod build;
pub mod dither;
pub mod frames;
pub mod labels;
pub mod manifest;
pub mod shard;
pub mod spec;

pub use build::{BuildError, BuildOptions, BuildSummary, Dithering, ENGINE_VERSION, build, render_video, stimulus_id};
pub use dither::{DitherKey, DitherKeyError};
pub use manifest::{COLUMNS, ManifestRow, Media, StimulusId};
pub use shard::{MergeSummary, Shard, ShardError, build_shard, merge};
pub use spec::{Content, Entry, SetSpec, SpecError};
