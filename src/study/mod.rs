//! Studies: what a participant is asked, in which order, and how stimuli are shared out.
//!
//! Pure logic, no I/O: [`design`] reads a study design (TOML) into a [`StudyDesign`];
//! [`assign`] picks each participant's stimuli so that counts stay balanced and orders them
//! with the participant's seed; [`session`] is the participation state machine; [`measure`]
//! declares every measure and label set once; [`task`] turns a submitted answer into typed
//! judgements of those measures (the long response format, design.md §3); [`entry`] groups a
//! set's stimuli into entries for trials that show them together; [`screen`] says which trials
//! one page shows and answers together (a label's stimuli side by side); [`viewing`] declares the
//! trial data on how media were viewed (replays, frame steps, speeds, time on task). The web layer (`crate::web`) and the database (`crate::db`) call
//! these; nothing here knows about HTTP or SQL.

pub mod arm;
pub mod assign;
pub mod design;
pub mod entry;
pub mod labels;
pub mod measure;
pub mod session;
pub mod task;
pub mod recruitment;
pub mod screen;
pub mod templates;
pub mod viewing;
pub mod worker;

pub use design::{DesignError, Platform, StudyDesign, TaskKind};

/// At most `max` characters of `text` for a message, with `…` when cut (messages quote only a
/// short excerpt of what was sent).
pub fn excerpt(text: &str, max: usize) -> String {
    let mut cut: String = text.chars().take(max).collect();
    if cut.len() < text.len() {
        cut.push('…');
    }
    cut
}
pub use session::SessionState;
pub use task::{Answer, AnswerError, Submission};
