//! facslab: FACS-controlled facial-expression stimuli, the studies that validate them, and the
//! validation report.
//!
//! The modules follow the pipeline (see `ARCHITECTURE.md`):
//! [`facs`] (catalog and notation) → [`engine`] (expression → pixels) → … → [`analysis`]
//! (responses + ground truth → statistics). [`cli`] wires them to the command line.

pub mod analysis;
pub mod cli;
pub mod db;
pub mod engine;
pub mod facs;
pub mod laugh;
pub mod progress;
pub mod report;
pub mod seeded;
pub mod speech;
pub mod stimuli;
pub mod study;
pub mod studio;
pub mod tabular;
pub mod web;
