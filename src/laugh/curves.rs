//! Curves: per-frame AU intensities that animate one laugh or smile.
//!
//! In: `curves.json` (written by `facslab curves fit` or by hand). Out: a checked [`Curves`]
//! and, through [`Curves::to_timeline`], the engine's [`Timeline`] for any identity and size.
//!
//! Invariants: every track has one value per frame, all tracks the same number of frames,
//! every value finite and in [0, 1]; a channel (AU and side) appears once. The timeline keeps
//! every sample exactly: it joins consecutive frames with linear tracks and merges runs that
//! lie on one line (within [`crate::engine::timeline::RAMP_STEP`]), so frame `f` of the
//! timeline shows the value of sample `f`.

use serde::{Deserialize, Serialize};

use crate::engine::timeline::{Ramp, Timeline, Track, RAMP_STEP};
use crate::facs::{AuCode, Catalog, Laterality};

/// The `format` field every curves file carries.
pub const FORMAT: &str = "facslab-curves/1";
/// Longest curve set, in frames (60 s at 120 fps).
pub const MAX_FRAMES: usize = 7200;
/// Most tracks in one curve set.
pub const MAX_TRACKS: usize = 64;

/// One AU on one side, one intensity per frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CurveTrack {
    pub au: AuCode,
    #[serde(default = "both")]
    pub side: Laterality,
    pub values: Vec<f64>,
}

fn both() -> Laterality {
    Laterality::Both
}

/// A laugh or smile as curves: what `facslab curves fit` writes and `facslab laugh --curves`
/// plays.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Curves {
    /// Always [`FORMAT`].
    pub format: String,
    /// The laugh type's id (`laughter`, `false_smile`, …).
    #[serde(rename = "type")]
    pub laugh_type: String,
    pub fps: u32,
    /// Where the curves came from (the take chosen as prototype, a file name, a table entry).
    #[serde(default)]
    pub source: String,
    pub tracks: Vec<CurveTrack>,
    /// How `facslab curves fit` made these curves (takes, conventions, Table 3); absent in
    /// curves written by hand or from the type table.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fit: Option<crate::laugh::fit::FitReport>,
    /// The body's part, one value per frame: how far the shoulders are raised (0 at rest, 1 a
    /// full shrug; laughs pulse them and heave the chest). Empty when the body stays at rest
    /// (fitted curves: face landmarks do not see the shoulders).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub shoulders: Vec<f64>,
}

/// What is wrong with a curves file; each message names the track (1-based) or field.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CurvesError {
    #[error("the curves are not valid JSON: {0}")]
    Json(String),
    #[error("format is {0:?}; expected {FORMAT:?}")]
    Format(String),
    #[error("the frame rate must be 1..=120 fps, not {0}")]
    Fps(u32),
    #[error("a curve set has 1..={MAX_TRACKS} tracks, not {0}")]
    Tracks(usize),
    #[error("track {track} (AU {au}) has {frames} frames; a curve set has 2..={MAX_FRAMES} frames, all tracks alike (track 1 has {first})")]
    Frames { track: usize, au: u16, frames: usize, first: usize },
    #[error("track {track} (AU {au}): AU {au} is not in the catalog")]
    UnknownAu { track: usize, au: u16 },
    #[error("track {track} (AU {au}): AU {au} cannot be shown on one side only")]
    NotUnilateral { track: usize, au: u16 },
    #[error("track {track} (AU {au}), frame {frame}: value {value} is not a number in [0, 1]")]
    Value { track: usize, au: u16, frame: usize, value: f64 },
    #[error("tracks {first} and {second} both drive AU {au} on overlapping sides")]
    Duplicate { first: usize, second: usize, au: u16 },
    #[error("shoulders: {0}")]
    Shoulders(String),
}

impl Curves {
    /// Reads and checks a curves file.
    pub fn from_json(text: &str, catalog: &Catalog) -> Result<Curves, CurvesError> {
        let curves: Curves = serde_json::from_str(text).map_err(|e| CurvesError::Json(e.to_string()))?;
        curves.validate(catalog)?;
        Ok(curves)
    }

    /// Pretty JSON, the bytes `facslab curves fit` writes.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("curves serialize") + "\n"
    }

    /// Number of frames (every track has this many values).
    pub fn frame_count(&self) -> usize {
        self.tracks.first().map_or(0, |t| t.values.len())
    }

    /// Checks the invariants in the module doc.
    pub fn validate(&self, catalog: &Catalog) -> Result<(), CurvesError> {
        if self.format != FORMAT {
            return Err(CurvesError::Format(self.format.chars().take(40).collect()));
        }
        if !(1..=120).contains(&self.fps) {
            return Err(CurvesError::Fps(self.fps));
        }
        if self.tracks.is_empty() || self.tracks.len() > MAX_TRACKS {
            return Err(CurvesError::Tracks(self.tracks.len()));
        }
        let first = self.frame_count();
        for (i, track) in self.tracks.iter().enumerate() {
            let (n, au) = (i + 1, track.au.0);
            let frames = track.values.len();
            if frames != first || !(2..=MAX_FRAMES).contains(&frames) {
                return Err(CurvesError::Frames { track: n, au, frames, first });
            }
            let unit = catalog.get(track.au).ok_or(CurvesError::UnknownAu { track: n, au })?;
            if track.side != Laterality::Both && !unit.unilateral {
                return Err(CurvesError::NotUnilateral { track: n, au });
            }
            if let Some((frame, &value)) = track.values.iter().enumerate().find(|(_, v)| !(v.is_finite() && (0.0..=1.0).contains(*v))) {
                return Err(CurvesError::Value { track: n, au, frame, value });
            }
            let clash = self.tracks[..i].iter().position(|e| e.au == track.au && (e.side == track.side || e.side == Laterality::Both || track.side == Laterality::Both));
            if let Some(j) = clash {
                return Err(CurvesError::Duplicate { first: j + 1, second: n, au });
            }
        }
        self.validate_shoulders(first)
    }

    fn validate_shoulders(&self, frames: usize) -> Result<(), CurvesError> {
        if !self.shoulders.is_empty() && self.shoulders.len() != frames {
            return Err(CurvesError::Shoulders(format!("{} values; one per frame ({frames}) or none", self.shoulders.len())));
        }
        match self.shoulders.iter().enumerate().find(|(_, v)| !(v.is_finite() && (0.0..=1.0).contains(*v))) {
            Some((frame, value)) => Err(CurvesError::Shoulders(format!("frame {frame}: value {value} is not a number in [0, 1]"))),
            None => Ok(()),
        }
    }

    /// Every AU the curves move, at its highest value (rounded to a thousandth), in track
    /// order: what the take shows at its peak, for a manifest.
    pub fn peak_expression(&self, catalog: &Catalog) -> Result<crate::facs::Expression, crate::facs::NotationError> {
        let parts: Vec<String> = self
            .tracks
            .iter()
            .filter_map(|t| {
                let peak = (t.values.iter().copied().fold(0.0, f64::max) * 1000.0).round() / 1000.0;
                let side = match t.side {
                    Laterality::Both => "",
                    Laterality::Left => "L",
                    Laterality::Right => "R",
                };
                (peak > 0.0).then(|| format!("{side}{}@{peak}", t.au))
            })
            .collect();
        catalog.parse(&if parts.is_empty() { "0".to_string() } else { parts.join("+") })
    }

    /// The engine timeline that plays these curves on `identity` at `size`: frame `f` shows
    /// sample `f` of every track (the curves must be valid).
    pub fn to_timeline(&self, identity: &str, size: (u32, u32)) -> Timeline {
        let fps = self.fps as f64;
        let mut tracks = Vec::new();
        for curve in &self.tracks {
            for (a, b) in line_runs(&curve.values) {
                let (start, end) = (curve.values[a], curve.values[b]);
                if start == 0.0 && end == 0.0 {
                    continue;
                }
                tracks.push(Track {
                    au: curve.au,
                    side: curve.side,
                    start_intensity: start,
                    end_intensity: end,
                    start_s: a as f64 / fps,
                    end_s: b as f64 / fps,
                    ramp: Ramp::Linear,
                });
            }
        }
        let duration_s = self.frame_count() as f64 / fps;
        let shoulders = if self.shoulders.iter().all(|&v| v == 0.0) {
            Vec::new()
        } else {
            let mut keys: Vec<[f64; 2]> = line_runs(&self.shoulders).into_iter().map(|(a, _)| [a as f64 / fps, self.shoulders[a]]).collect();
            let last = self.shoulders.len() - 1;
            keys.push([last as f64 / fps, self.shoulders[last]]);
            keys
        };
        Timeline { fps: self.fps, duration_s, identity: identity.to_string(), size: [size.0, size.1], tracks, shoulders }
    }
}

/// Splits samples into maximal runs `[a, b]` (sharing their end frames) along which linear
/// interpolation between the run's ends reproduces every sample within half a ramp step.
fn line_runs(values: &[f64]) -> Vec<(usize, usize)> {
    let mut runs = Vec::new();
    let mut a = 0;
    while a + 1 < values.len() {
        let mut b = a + 1;
        while b + 1 < values.len() && on_line(values, a, b + 1) {
            b += 1;
        }
        runs.push((a, b));
        a = b;
    }
    runs
}

fn on_line(values: &[f64], a: usize, b: usize) -> bool {
    let (va, vb) = (values[a], values[b]);
    (a + 1..b).all(|k| {
        let s = (k - a) as f64 / (b - a) as f64;
        (va + (vb - va) * s - values[k]).abs() <= RAMP_STEP / 2.0
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Curves {
        let rise: Vec<f64> = (0..31).map(|f| (f as f64 / 10.0).min(1.0) * 0.8).collect();
        let wobble: Vec<f64> = (0..31).map(|f| 0.5 + 0.3 * (f as f64 * 0.7).sin()).collect();
        Curves {
            format: FORMAT.into(),
            laugh_type: "laughter".into(),
            fps: 30,
            source: "test".into(),
            tracks: vec![
                CurveTrack { au: AuCode(12), side: Laterality::Both, values: rise },
                CurveTrack { au: AuCode(26), side: Laterality::Both, values: wobble },
            ],
            fit: None,
            shoulders: (0..31).map(|f| if f < 5 { 0.0 } else { ((0.3 + 0.2 * (f as f64 * 1.9).sin()) * 1e4).round() / 1e4 }).collect(),
        }
    }

    #[test]
    fn the_timeline_raises_the_shoulders_sample_for_sample() {
        let curves = sample();
        let timeline = curves.to_timeline("wm1", (64, 64));
        timeline.validate(Catalog::built_in()).unwrap();
        for (f, &v) in curves.shoulders.iter().enumerate() {
            let got = timeline.shoulders_at(timeline.time_of(f));
            assert!((got - v).abs() <= RAMP_STEP, "frame {f}: {got} vs {v}");
        }
        let json = Curves::from_json(&curves.to_json(), Catalog::built_in()).unwrap();
        assert_eq!(json.shoulders, curves.shoulders);
        let still = Curves { shoulders: Vec::new(), ..curves.clone() };
        assert!(still.to_timeline("wm1", (64, 64)).shoulders.is_empty() && !still.to_json().contains("shoulders"), "no body motion, no field");
        let bad = Curves { shoulders: vec![0.5; 7], ..curves.clone() };
        assert_eq!(bad.validate(Catalog::built_in()).unwrap_err().to_string(), "shoulders: 7 values; one per frame (31) or none");
        let bad = Curves { shoulders: (0..31).map(|f| if f == 9 { 1.5 } else { 0.0 }).collect(), ..curves };
        assert_eq!(bad.validate(Catalog::built_in()).unwrap_err().to_string(), "shoulders: frame 9: value 1.5 is not a number in [0, 1]");
    }

    #[test]
    fn curves_play_back_sample_for_sample_on_the_timeline() {
        let catalog = Catalog::built_in();
        let curves = sample();
        curves.validate(catalog).unwrap();
        let timeline = curves.to_timeline("wm1", (64, 64));
        timeline.validate(catalog).unwrap();
        assert_eq!(timeline.frame_count(), 31);
        // The straight rise of AU12 (frames 0-10) and its hold (10-30) take one track each.
        assert_eq!(timeline.tracks.iter().filter(|t| t.au == AuCode(12)).count(), 2);
        for frame in 0..31 {
            let values = timeline.values_at(timeline.time_of(frame));
            for curve in &curves.tracks {
                let got = values.iter().find(|(c, _)| c.0 == curve.au).map_or(0.0, |(_, v)| *v);
                assert!((got - curve.values[frame]).abs() <= RAMP_STEP, "AU {} frame {frame}: {got} vs {}", curve.au, curve.values[frame]);
            }
        }
    }

    #[test]
    fn curves_json_round_trips_and_bad_curves_are_named() {
        let catalog = Catalog::built_in();
        let curves = sample();
        assert_eq!(Curves::from_json(&curves.to_json(), catalog).unwrap(), curves);
        let mut bad = sample();
        bad.tracks[1].values[7] = f64::NAN;
        assert_eq!(bad.validate(catalog).unwrap_err().to_string(), "track 2 (AU 26), frame 7: value NaN is not a number in [0, 1]");
        let mut short = sample();
        short.tracks[1].values.pop();
        assert!(matches!(short.validate(catalog), Err(CurvesError::Frames { track: 2, frames: 30, first: 31, .. })));
        let mut twice = sample();
        twice.tracks[1].au = AuCode(12);
        assert!(matches!(twice.validate(catalog), Err(CurvesError::Duplicate { first: 1, second: 2, au: 12 })));
        let mut unknown = sample();
        unknown.tracks[0].au = AuCode(3);
        assert!(matches!(unknown.validate(catalog), Err(CurvesError::UnknownAu { track: 1, au: 3 })));
        assert!(matches!(Curves::from_json("{", catalog), Err(CurvesError::Json(_))));
    }
}
