//! The FACS vocabulary: Action Units, intensities, sides, the notation coders write, and the
//! emotion tables built from them.
//!
//! In: the catalog, the AU appearance specification and the emotion tables as TOML data (built-in copies of `stimuli/facs/*.toml`, or
//! user files). Out: validated [`Expression`]s, which are the only way an expression enters the
//! engine, the stimulus sets or the analysis.
//!
//! Invariant: an [`Expression`] built by [`Catalog::parse`] names only catalog AUs, uses a side
//! only where the AU allows one, and keeps every intensity in [0, 1].

mod appearance;
mod catalog;
mod emotions;
mod intensity;
mod notation;

pub use appearance::{Appearance, AppearanceError, AppearanceSpec, Levels};
pub use catalog::{ActionUnit, AuCode, AuKind, Catalog, CatalogError, Region};
pub use emotions::{AppraisalCheck, AppraisalTable, Emotion, EmotionError, EmotionTable};
pub use intensity::{Intensity, IntensityLevel};
pub use notation::{Activation, Expression, Laterality, MAX_NOTATION_LEN, NotationError, NotationErrorKind};
