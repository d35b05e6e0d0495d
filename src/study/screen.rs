//! Screens: which trials one trial page shows and answers together.
//!
//! In: a participant's plan as [`Slot`]s (position, kind, the stimulus's label), a position and
//! whether the design shows a label's stimuli side by side (`[rating] side_by_side`, seed 004's
//! study 1: the real and the generated video of a type, each with its own score). Out: the
//! positions of the screen that starts there ([`screen_at`]), and a screen's submission cut into
//! one [`Submission`] per trial ([`split`]).
//!
//! Invariants: a screen is a run of main trials of one label, in plan order, at most
//! [`MAX_SIDE_BY_SIDE`] long, and starts where the previous trial is not of that run (a practice
//! trial or an attention check is a screen of its own); a screen of several trials names each
//! answer field `<measure>@<position>`, and every field must name a trial of the screen; each
//! trial's answer is stored under its own key, derived from the screen's key and its position,
//! so a repeated save of the screen is recognised trial by trial.

use super::assign::TrialKind;
use super::task::{AnswerError, Submission, fail};

/// Most stimuli one screen shows side by side (a label with more is refused when the study is
/// made: `db::studies::set_stimuli`).
pub const MAX_SIDE_BY_SIDE: usize = 4;

/// A planned trial, as the screens see it.
#[derive(Debug, Clone, Copy)]
pub struct Slot<'a> {
    pub position: i64,
    pub kind: TrialKind,
    /// The stimulus's label (the manifest's `emotion`).
    pub label: &'a str,
}

/// Why a position starts no screen.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ScreenError {
    #[error("there is no trial {0}")]
    NoTrial(i64),
    #[error("trial {position} is shown beside trial {first}; its answer is saved with that trial's screen")]
    NotFirst { position: i64, first: i64 },
}

/// The positions shown on the screen that starts at `position`: that trial alone, or with
/// `side_by_side`, the run of main trials of its label that starts there.
pub fn screen_at(slots: &[Slot<'_>], position: i64, side_by_side: bool) -> Result<Vec<i64>, ScreenError> {
    let at = slots.iter().position(|s| s.position == position).ok_or(ScreenError::NoTrial(position))?;
    let slot = slots[at];
    if !side_by_side || slot.kind != TrialKind::Trial {
        return Ok(vec![position]);
    }
    let same_run = |other: &Slot<'_>| other.kind == TrialKind::Trial && other.label == slot.label;
    let first = slots[..at].iter().rev().take_while(|s| same_run(s)).last();
    if let Some(first) = first {
        return Err(ScreenError::NotFirst { position, first: first.position });
    }
    Ok(slots[at..].iter().take_while(|s| same_run(s)).take(MAX_SIDE_BY_SIDE).map(|s| s.position).collect())
}

/// The key a trial of a screen of several is stored under: the screen's key (cut to leave room)
/// and the trial's position, within the 64 characters a key may have.
fn part_key(key: &str, position: i64) -> String {
    let kept: String = key.chars().take(58).collect();
    format!("{kept}-{position}")
}

/// One submission per trial of the screen `positions` (in that order). A screen of one trial
/// keeps the submission as it came; a screen of several takes each answer field `name@position`
/// to its trial and shares the response time, load failure and viewing counts (its videos play
/// together) and whether the videos played to their end.
pub fn split(submission: &Submission, positions: &[i64]) -> Result<Vec<(i64, Submission)>, AnswerError> {
    if let [only] = positions {
        return Ok(vec![(*only, submission.clone())]);
    }
    submission.check_envelope()?;
    let mut parts: Vec<(i64, Submission)> = positions
        .iter()
        .map(|&p| (p, Submission { idempotency_key: part_key(&submission.idempotency_key, p), fields: Vec::new(), ..submission.clone() }))
        .collect();
    for (name, value) in &submission.fields {
        let (measure, trial) = name.rsplit_once('@').ok_or_else(|| fail(name.as_str(), format!("this page shows {} videos: name the answer's trial as {name}@<position>", positions.len())))?;
        let part = trial.parse::<i64>().ok().and_then(|p| parts.iter_mut().find(|(q, _)| *q == p));
        let (_, part) = part.ok_or_else(|| fail(name.as_str(), format!("\"{trial}\" is not a trial of this page (its trials: {positions:?})")))?;
        part.fields.push((measure.to_string(), value.clone()));
    }
    Ok(parts)
}

/// An answer error of one trial of a screen of `shown` trials, naming the field as the page
/// does (`<measure>@<position>`).
pub fn named_for(e: AnswerError, position: i64, shown: usize) -> AnswerError {
    if shown > 1 { AnswerError { field: super::excerpt(&format!("{}@{position}", e.field), 64), ..e } } else { e }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan() -> Vec<Slot<'static>> {
        let slot = |position, kind, label| Slot { position, kind, label };
        vec![
            slot(0, TrialKind::Practice, "laughs:sly_smile"),
            slot(1, TrialKind::Trial, "laughs:sly_smile"),
            slot(2, TrialKind::Trial, "laughs:sly_smile"),
            slot(3, TrialKind::Attention, "laughs:sly_smile"),
            slot(4, TrialKind::Trial, "laughs:laughter"),
            slot(5, TrialKind::Trial, "laughs:laughter"),
            slot(6, TrialKind::Trial, "laughs:eager_smile"),
        ]
    }

    #[test]
    fn a_screen_is_the_run_of_a_labels_main_trials() {
        let plan = plan();
        assert_eq!(screen_at(&plan, 0, true), Ok(vec![0]), "a practice trial is a screen of its own");
        assert_eq!(screen_at(&plan, 1, true), Ok(vec![1, 2]));
        assert_eq!(screen_at(&plan, 3, true), Ok(vec![3]), "an attention check is a screen of its own");
        assert_eq!(screen_at(&plan, 4, true), Ok(vec![4, 5]), "the check splits nothing: the next label starts its own run");
        assert_eq!(screen_at(&plan, 6, true), Ok(vec![6]));
        assert_eq!(screen_at(&plan, 2, true), Err(ScreenError::NotFirst { position: 2, first: 1 }));
        assert_eq!(screen_at(&plan, 5, true), Err(ScreenError::NotFirst { position: 5, first: 4 }));
        assert_eq!(screen_at(&plan, 7, true), Err(ScreenError::NoTrial(7)));
        for p in 0..7 {
            assert_eq!(screen_at(&plan, p, false), Ok(vec![p]), "without side_by_side every trial is a screen");
        }
    }

    #[test]
    fn a_screen_shows_at_most_four() {
        let plan: Vec<Slot<'_>> = (0..6).map(|position| Slot { position, kind: TrialKind::Trial, label: "x" }).collect();
        assert_eq!(screen_at(&plan, 0, true), Ok(vec![0, 1, 2, 3]));
    }

    fn submission(fields: &[(&str, &str)]) -> Submission {
        let key = "k".repeat(64);
        let mut pairs = vec![("idempotency_key".to_string(), key), ("rt_ms".into(), "1234".into())];
        pairs.extend(fields.iter().map(|(n, v)| (n.to_string(), v.to_string())));
        Submission::from_form(pairs).expect("a form")
    }

    #[test]
    fn a_screens_answers_go_to_their_trials_each_under_its_own_key() {
        let parts = split(&submission(&[("q1@4", "3"), ("q1@5", "0"), ("q2@5", "5")]), &[4, 5]).expect("split");
        assert_eq!(parts.len(), 2);
        assert_eq!((parts[0].0, parts[0].1.fields.clone()), (4, vec![("q1".to_string(), "3".to_string())]));
        assert_eq!(parts[1].1.fields, vec![("q1".to_string(), "0".to_string()), ("q2".to_string(), "5".to_string())]);
        assert_eq!(parts[0].1.rt_ms, Some(1234.0), "the screen's response time goes with each trial");
        let keys: Vec<&str> = parts.iter().map(|(_, s)| s.idempotency_key.as_str()).collect();
        assert_eq!(keys, [format!("{}-4", "k".repeat(58)), format!("{}-5", "k".repeat(58))]);
        assert!(parts.iter().all(|(_, s)| s.check_envelope().is_ok()), "derived keys are valid keys");
        let one = submission(&[("q1", "3")]);
        assert_eq!(split(&one, &[9]), Ok(vec![(9, one.clone())]), "a screen of one is kept as it came");
    }

    #[test]
    fn fields_of_no_trial_on_the_screen_are_named() {
        let plain = split(&submission(&[("q1", "3")]), &[4, 5]).expect_err("a field without its trial");
        assert_eq!(plain.field, "q1");
        assert!(plain.message.contains("q1@<position>"), "{}", plain.message);
        let other = split(&submission(&[("q1@4", "3"), ("q1@6", "2")]), &[4, 5]).expect_err("a trial of another screen");
        assert_eq!(other.field, "q1@6");
        assert!(other.message.contains("\"6\" is not a trial of this page"), "{}", other.message);
        let junk = split(&submission(&[("q1@x", "3")]), &[4, 5]).expect_err("not a position");
        assert_eq!(junk.field, "q1@x");
    }
}
