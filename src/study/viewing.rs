//! How a participant viewed a trial's media: replays, frame steps, playback speeds and time on
//! task (FACS coders step through a clip frame by frame, replay it and slow it down).
//!
//! In: the `viewing` object of a trial save from the page script (`assets/web/trial.js`, which
//! counts what the participant did); a plain form post has none. Out: a checked [`Viewing`],
//! stored as JSON in `responses.viewing` and written as is by the JSON export. The fields are
//! declared once, in [`FIELDS`], which the codebook reads; the speeds the page offers are
//! [`SPEEDS`], which the trial template reads.
//!
//! Invariant: a stored viewing has counts within bounds, only offered speeds (each once) and a
//! time on task between 0 and one day (`study::viewing::tests`).

use serde::{Deserialize, Serialize};

/// The playback rates the trial page offers (1 = as recorded).
pub const SPEEDS: [f64; 3] = [0.25, 0.5, 1.0];

/// Most replays or frame steps one trial may report.
const MAX_COUNT: u32 = 100_000;

/// What the page reports about how the trial's media were viewed.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Viewing {
    /// Times the video was played again from its start.
    #[serde(default)]
    pub replays: u32,
    /// Single-frame steps, back or forward (the video paused).
    #[serde(default)]
    pub frame_steps: u32,
    /// The playback rates the video played at, in the order first used (empty for stills).
    #[serde(default)]
    pub speeds: Vec<f64>,
    /// Milliseconds the page was in view (not hidden behind another tab or window) from the
    /// media's first painted frame to the answer.
    pub time_on_task_ms: f64,
}

/// One field of the trial data, for the codebook.
#[derive(Debug, Clone, Copy)]
pub struct Field {
    pub name: &'static str,
    pub codebook: &'static str,
}

/// Every field of a [`Viewing`], in the order the JSON export writes them.
pub const FIELDS: [Field; 4] = [
    Field { name: "replays", codebook: "Times the video was played again from its start (button or key r)" },
    Field { name: "frame_steps", codebook: "Single-frame steps back or forward with the video paused (buttons or keys , and .)" },
    Field { name: "speeds", codebook: "Playback rates the video played at, in the order first used (0.25|0.5|1; empty for stills)" },
    Field { name: "time_on_task_ms", codebook: "Milliseconds the page was in view from the first painted frame to the answer (rt_ms also counts time away)" },
];

/// A viewing report that cannot be stored; `field` is one of [`FIELDS`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{field}: {message}")]
pub struct ViewingError {
    pub field: &'static str,
    pub message: String,
}

impl Viewing {
    /// Checks the report's bounds (see the module's invariant).
    pub fn check(&self) -> Result<(), ViewingError> {
        let fail = |field: &'static str, message: String| Err(ViewingError { field, message });
        for (field, count) in [("replays", self.replays), ("frame_steps", self.frame_steps)] {
            if count > MAX_COUNT {
                return fail(field, format!("{count} is over the limit of {MAX_COUNT}"));
            }
        }
        for (i, speed) in self.speeds.iter().enumerate() {
            if !SPEEDS.contains(speed) {
                return fail("speeds", format!("{speed} is not one of the offered speeds 0.25, 0.5, 1"));
            }
            if self.speeds[..i].contains(speed) {
                return fail("speeds", format!("{speed} is listed twice"));
            }
        }
        let t = self.time_on_task_ms;
        if !(t.is_finite() && (0.0..=86_400_000.0).contains(&t)) {
            return fail("time_on_task_ms", format!("{t} is not a time between 0 and one day in milliseconds"));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reports_are_bounded_and_speeds_are_the_offered_ones() {
        let ok = Viewing { replays: 2, frame_steps: 14, speeds: vec![1.0, 0.5], time_on_task_ms: 8123.4 };
        assert_eq!(ok.check(), Ok(()));
        let bad = [
            (Viewing { replays: MAX_COUNT + 1, ..ok.clone() }, "replays"),
            (Viewing { frame_steps: u32::MAX, ..ok.clone() }, "frame_steps"),
            (Viewing { speeds: vec![2.0], ..ok.clone() }, "speeds"),
            (Viewing { speeds: vec![0.5, 0.5], ..ok.clone() }, "speeds"),
            (Viewing { time_on_task_ms: -1.0, ..ok.clone() }, "time_on_task_ms"),
            (Viewing { time_on_task_ms: f64::NAN, ..ok.clone() }, "time_on_task_ms"),
        ];
        for (viewing, field) in bad {
            assert_eq!(viewing.check().unwrap_err().field, field, "{viewing:?}");
        }
    }

    #[test]
    fn the_declared_fields_are_the_serialised_ones() {
        let json = serde_json::to_value(Viewing::default()).unwrap();
        let keys: Vec<&str> = json.as_object().unwrap().keys().map(String::as_str).collect();
        let mut declared: Vec<&str> = FIELDS.iter().map(|f| f.name).collect();
        declared.sort();
        let mut keys = keys;
        keys.sort();
        assert_eq!(keys, declared);
        let unknown = serde_json::from_str::<Viewing>(r#"{"time_on_task_ms": 1, "seeks": 3}"#).unwrap_err();
        assert!(unknown.to_string().contains("seeks"), "{unknown}");
    }
}
