//! The participation state machine (design.md §6.1).
//!
//! ```text
//! reserved ──consent──> active ──last save──> completed
//!    │                    │──attention policy──> screened_out
//!    └──────timeout / withdraw──────┴──> abandoned | withdrawn
//! ```
//! A participation is *reserved* when it starts (its trials are assigned and count towards the
//! balance until the reservation expires), *active* once consent is given, and ends in exactly
//! one of the four final states. Every transition is logged by the database layer.

use std::fmt;

/// Where a participation is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SessionState {
    Reserved,
    Active,
    Completed,
    Abandoned,
    Withdrawn,
    ScreenedOut,
}

impl SessionState {
    pub const ALL: [SessionState; 6] = [
        SessionState::Reserved,
        SessionState::Active,
        SessionState::Completed,
        SessionState::Abandoned,
        SessionState::Withdrawn,
        SessionState::ScreenedOut,
    ];

    /// The name stored in the database and shown to admins.
    pub fn as_str(self) -> &'static str {
        match self {
            SessionState::Reserved => "reserved",
            SessionState::Active => "active",
            SessionState::Completed => "completed",
            SessionState::Abandoned => "abandoned",
            SessionState::Withdrawn => "withdrawn",
            SessionState::ScreenedOut => "screened_out",
        }
    }

    pub fn parse(text: &str) -> Option<SessionState> {
        SessionState::ALL.into_iter().find(|s| s.as_str() == text)
    }

    /// True while the participant may still answer.
    pub fn is_open(self) -> bool {
        matches!(self, SessionState::Reserved | SessionState::Active)
    }

    /// Whether `self → to` is a transition of the machine.
    pub fn can_become(self, to: SessionState) -> bool {
        use SessionState::*;
        matches!(
            (self, to),
            (Reserved, Active) | (Reserved | Active, Abandoned | Withdrawn) | (Active, Completed | ScreenedOut)
        )
    }
}

impl fmt::Display for SessionState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::SessionState::{self, *};

    #[test]
    fn names_round_trip() {
        for s in SessionState::ALL {
            assert_eq!(SessionState::parse(s.as_str()), Some(s));
        }
        assert_eq!(SessionState::parse("done"), None);
    }

    #[test]
    fn final_states_are_final() {
        for from in [Completed, Abandoned, Withdrawn, ScreenedOut] {
            assert!(!from.is_open());
            assert!(SessionState::ALL.iter().all(|&to| !from.can_become(to)), "{from} moved on");
        }
        assert!(Reserved.can_become(Active) && Active.can_become(Completed));
        assert!(!Reserved.can_become(Completed), "completion needs consent first");
        assert!(Active.can_become(ScreenedOut) && !Reserved.can_become(ScreenedOut));
    }
}
