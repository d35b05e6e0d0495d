//! Timelines: how an expression changes over time, one frame at a time.
//!
//! A [`Timeline`] is our answer to HapFACS's exported video files: per-AU tracks (AU, side,
//! start and end intensity, start and end time, ramp shape), a frame rate, a duration, the
//! identity and the frame size. It is plain JSON, so one file reproduces a video exactly.
//!
//! Semantics, fixed so that a frame is always the same expression:
//! - frame `f` is shown at `t = f / fps`; a clip of `duration_s` has `round(duration_s × fps)`
//!   frames (a 3-s clip at 30 fps has 90, at t = 0 … 2.9667 s);
//! - a track acts on the closed interval `[start_s, end_s]` and contributes nothing outside it;
//!   within, its intensity goes from `start_intensity` to `end_intensity` along its [`Ramp`]
//!   (values strictly between the ends rounded to [`RAMP_STEP`]);
//! - tracks of the same AU on overlapping sides may touch but not overlap in time; where two
//!   touch, the later one decides the value;
//! - an AU at intensity 0 is absent from the frame's expression; the others keep the order in
//!   which their first track appears, with the intensity as [`Intensity::Fraction`], so a frame
//!   goes through the ordinary still path ([`crate::engine::render_still`]).
//!
//! [`Timeline::clip`] builds the HapFACS clip (0 → peak over the onset, hold for the apex, back
//! to 0 over the offset) and [`Timeline::sequence`] the CPT appraisal sequences (one clip per
//! step, one after the other).

use serde::{Deserialize, Serialize};

use crate::facs::{Activation, AuCode, Catalog, Expression, Intensity, Laterality};

/// The HapFACS frame rate.
pub const DEFAULT_FPS: u32 = 30;

/// How intensity moves between a track's start and end.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Ramp {
    /// Straight line, as HapFACS.
    #[default]
    Linear,
    /// Hermite ease in and out: `3s² − 2s³`.
    Smoothstep,
    /// Half a cosine: `(1 − cos πs) / 2`.
    Cosine,
}

impl Ramp {
    /// The eased progress for linear progress `s` in [0, 1]; 0 ↦ 0 and 1 ↦ 1 exactly.
    pub fn shape(self, s: f64) -> f64 {
        let s = s.clamp(0.0, 1.0);
        match self {
            Ramp::Linear => s,
            Ramp::Smoothstep => s * s * (3.0 - 2.0 * s),
            Ramp::Cosine => (1.0 - (std::f64::consts::PI * s).cos()) / 2.0,
        }
    }
}

fn both() -> Laterality {
    Laterality::Both
}

/// One AU moving from one intensity to another over a time span.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Track {
    pub au: AuCode,
    #[serde(default = "both")]
    pub side: Laterality,
    pub start_intensity: f64,
    pub end_intensity: f64,
    pub start_s: f64,
    pub end_s: f64,
    #[serde(default)]
    pub ramp: Ramp,
}

impl Track {
    /// The intensity at `t`, or `None` outside `[start_s, end_s]`.
    pub fn value_at(&self, t: f64) -> Option<f64> {
        if t < self.start_s || t > self.end_s {
            return None;
        }
        let span = self.end_s - self.start_s;
        let s = if span > 0.0 { (t - self.start_s) / span } else { 1.0 };
        let eased = self.ramp.shape(s);
        let (a, b) = (self.start_intensity, self.end_intensity);
        let value = if eased >= 1.0 || a == b {
            b
        } else if eased <= 0.0 {
            a
        } else {
            quantize(a + (b - a) * eased)
        };
        Some(value.clamp(0.0, 1.0))
    }
}

/// Intensities strictly inside a ramp are rounded to this step (far below anything visible).
/// The rounding makes a falling ramp pass through exactly the values of the mirrored rising
/// one (`peak·k/30` and `peak·(1 − (30−k)/30)` differ in the last bits otherwise), so a renderer
/// can reuse those frames; ramp ends and held values stay exact.
pub const RAMP_STEP: f64 = 1e-6;

fn quantize(value: f64) -> f64 {
    (value / RAMP_STEP).round() * RAMP_STEP
}

/// Onset, apex and offset durations of a HapFACS clip, in seconds, and its ramp.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ClipTiming {
    pub onset_s: f64,
    pub apex_s: f64,
    pub offset_s: f64,
    #[serde(default)]
    pub ramp: Ramp,
}

impl Default for ClipTiming {
    /// HapFACS: 1 s onset, 1 s apex, 1 s offset, linear.
    fn default() -> Self {
        ClipTiming { onset_s: 1.0, apex_s: 1.0, offset_s: 1.0, ramp: Ramp::Linear }
    }
}

impl ClipTiming {
    pub fn total_s(&self) -> f64 {
        self.onset_s + self.apex_s + self.offset_s
    }

    /// The time in the middle of the apex, where the clip is at its peak.
    pub fn apex_mid_s(&self) -> f64 {
        self.onset_s + self.apex_s / 2.0
    }
}

fn default_fps() -> u32 {
    DEFAULT_FPS
}
fn default_identity() -> String {
    "wm1".into()
}
fn default_size() -> [u32; 2] {
    [super::DEFAULT_SIZE.0, super::DEFAULT_SIZE.1]
}

/// Longest timeline, in seconds (five minutes, far beyond any expression clip): with the
/// highest frame rate it bounds a video to 36,000 frames, checked before anything is allocated.
pub const MAX_DURATION_S: f64 = 300.0;
/// Most tracks in one timeline (the overlap check compares every pair).
pub const MAX_TRACKS: usize = 4096;
/// Longest timeline JSON read.
pub const MAX_JSON_BYTES: usize = 4 << 20;

/// A number for a message: as written when small, in exponent form when huge (1e300 is not
/// spelled out in 301 digits).
pub fn short_number(v: f64) -> String {
    if v.abs() < 1e9 { v.to_string() } else { format!("{v:e}") }
}

/// A whole dynamic stimulus: everything needed to render its frames again.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Timeline {
    #[serde(default = "default_fps")]
    pub fps: u32,
    pub duration_s: f64,
    #[serde(default = "default_identity")]
    pub identity: String,
    /// Rendered frame size `[width, height]` (before any padding for the video encoder).
    #[serde(default = "default_size")]
    pub size: [u32; 2],
    pub tracks: Vec<Track>,
    /// The body's motion, not an AU: how far the shoulders are raised (0 at rest, 1 a full shrug),
    /// as `[time_s, lift]` keys in time order, linear between keys and 0 outside them (laughs
    /// pulse the shoulders and heave the chest; FACS codes the face and head only). Omitted from
    /// the JSON when empty, which every timeline but a laugh's is.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub shoulders: Vec<[f64; 2]>,
}

/// What is wrong with a timeline; every message names the track (1-based) it is about.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TimelineError {
    #[error("the frame rate must be 1..=120 fps, not {0}")]
    Fps(u32),
    #[error("the duration must be a positive number of seconds up to 300, not {}", short_number(*.0))]
    Duration(f64),
    #[error("a timeline has at most 4096 tracks, not {0}")]
    Tracks(usize),
    #[error("the frame size {0}×{1} is out of range (each side 16..=4096)")]
    Size(u32, u32),
    #[error("track {track} (AU {au}): AU {au} is not in the catalog")]
    UnknownAu { track: usize, au: u16 },
    #[error("track {track} (AU {au}): AU {au} cannot be shown on one side only")]
    NotUnilateral { track: usize, au: u16 },
    #[error("track {track} (AU {au}): {what} intensity {value} is outside [0, 1]")]
    Intensity { track: usize, au: u16, what: &'static str, value: f64 },
    #[error("track {track} (AU {au}): times must satisfy 0 ≤ start ≤ end ≤ duration, got {start} → {end} s (duration {duration} s)")]
    Times { track: usize, au: u16, start: f64, end: f64, duration: f64 },
    #[error("tracks {first} and {second} (AU {au}) overlap in time on the same side")]
    Overlap { first: usize, second: usize, au: u16 },
    #[error("the timeline is not valid JSON: {0}")]
    Json(String),
    #[error("shoulders key {key}: {message}")]
    Shoulders { key: usize, message: String },
}

impl Timeline {
    /// The HapFACS clip of `expression` (each AU peaks at its own strength: scale the
    /// expression first for a weaker clip): 0 → peak over the onset, held over the apex,
    /// peak → 0 over the offset. AUs keep the expression's order.
    pub fn clip(expression: &Expression, timing: ClipTiming, fps: u32, identity: &str, size: (u32, u32)) -> Timeline {
        let mut tracks = Vec::new();
        push_clip(&mut tracks, expression, timing, 0.0);
        Timeline { fps, duration_s: timing.total_s(), identity: identity.to_string(), size: [size.0, size.1], tracks, shoulders: Vec::new() }
    }

    /// A CPT appraisal sequence: one HapFACS clip per step, the steps one after the other.
    pub fn sequence(steps: &[Expression], timing: ClipTiming, fps: u32, identity: &str, size: (u32, u32)) -> Timeline {
        let mut tracks = Vec::new();
        for (i, step) in steps.iter().enumerate() {
            push_clip(&mut tracks, step, timing, i as f64 * timing.total_s());
        }
        let duration_s = steps.len() as f64 * timing.total_s();
        Timeline { fps, duration_s, identity: identity.to_string(), size: [size.0, size.1], tracks, shoulders: Vec::new() }
    }

    /// Checks everything a render needs except the identity (see [`crate::engine::identity`]).
    pub fn validate(&self, catalog: &Catalog) -> Result<(), TimelineError> {
        if !(1..=120).contains(&self.fps) {
            return Err(TimelineError::Fps(self.fps));
        }
        if !(self.duration_s.is_finite() && self.duration_s > 0.0 && self.duration_s <= MAX_DURATION_S) {
            return Err(TimelineError::Duration(self.duration_s));
        }
        if self.tracks.len() > MAX_TRACKS {
            return Err(TimelineError::Tracks(self.tracks.len()));
        }
        let [w, h] = self.size;
        if !(16..=4096).contains(&w) || !(16..=4096).contains(&h) {
            return Err(TimelineError::Size(w, h));
        }
        for (i, track) in self.tracks.iter().enumerate() {
            let (n, au) = (i + 1, track.au.0);
            let unit = catalog.get(track.au).ok_or(TimelineError::UnknownAu { track: n, au })?;
            if track.side != Laterality::Both && !unit.unilateral {
                return Err(TimelineError::NotUnilateral { track: n, au });
            }
            for (what, value) in [("start", track.start_intensity), ("end", track.end_intensity)] {
                if !(value.is_finite() && (0.0..=1.0).contains(&value)) {
                    return Err(TimelineError::Intensity { track: n, au, what, value });
                }
            }
            let (start, end) = (track.start_s, track.end_s);
            let ok = start.is_finite() && end.is_finite() && start >= 0.0 && end >= start && end <= self.duration_s + 1e-9;
            if !ok {
                return Err(TimelineError::Times { track: n, au, start, end, duration: self.duration_s });
            }
            for (j, earlier) in self.tracks[..i].iter().enumerate() {
                let sides_overlap = earlier.side == track.side || earlier.side == Laterality::Both || track.side == Laterality::Both;
                if earlier.au == track.au && sides_overlap && earlier.start_s < end && start < earlier.end_s {
                    return Err(TimelineError::Overlap { first: j + 1, second: n, au });
                }
            }
        }
        self.validate_shoulders()
    }

    /// The shoulder keys: at most one per frame, times in [0, duration] and rising, lifts in [0, 1].
    fn validate_shoulders(&self) -> Result<(), TimelineError> {
        let fail = |key: usize, message: String| Err(TimelineError::Shoulders { key: key + 1, message });
        if self.shoulders.len() > self.frame_count() + 1 {
            return fail(self.shoulders.len() - 1, format!("{} keys for {} frames; at most one per frame", self.shoulders.len(), self.frame_count()));
        }
        for (k, &[t, lift]) in self.shoulders.iter().enumerate() {
            if !(t.is_finite() && (0.0..=self.duration_s + 1e-9).contains(&t)) || (k > 0 && t < self.shoulders[k - 1][0]) {
                return fail(k, format!("time {} s must be in [0, {}] and not before the key before it", short_number(t), self.duration_s));
            }
            if !(lift.is_finite() && (0.0..=1.0).contains(&lift)) {
                return fail(k, format!("lift {} must be in [0, 1]", short_number(lift)));
            }
        }
        Ok(())
    }

    /// How far the shoulders are raised at time `t` (see [`Timeline::shoulders`]), quantised like
    /// the AU ramps so that held and repeated poses are the same frame.
    pub fn shoulders_at(&self, t: f64) -> f64 {
        let keys = &self.shoulders;
        // The keys are in time order (validated): the first one after `t` by binary search.
        let after = keys.partition_point(|k| k[0] <= t);
        if after == keys.len() {
            return keys.last().filter(|k| k[0] == t).map_or(0.0, |k| quantize(k[1]));
        }
        if after == 0 {
            return 0.0;
        }
        let ([t0, a], [t1, b]) = (keys[after - 1], keys[after]);
        quantize(a + (b - a) * (t - t0) / (t1 - t0))
    }

    /// How far the shoulders are raised in frame `frame`, as the renderer takes it
    /// ([`crate::engine::FrameSettings::shoulders`]).
    pub fn frame_shoulders(&self, frame: usize) -> f32 {
        self.shoulders_at(self.time_of(frame)) as f32
    }

    /// What identifies the picture of frame `frame` for reuse: its expression, and the shoulder
    /// lift when the shoulders are raised.
    pub fn frame_key(&self, frame: usize, catalog: &Catalog) -> Result<String, crate::facs::NotationError> {
        Ok(self.frame_key_of(frame, &self.frame_expression(frame, catalog)?))
    }

    /// [`Timeline::frame_key`] of frame `frame` whose expression is already known.
    pub fn frame_key_of(&self, frame: usize, expression: &Expression) -> String {
        let lift = self.frame_shoulders(frame);
        if lift == 0.0 { expression.to_string() } else { format!("{expression} shoulders {lift}") }
    }

    /// Number of frames: `round(duration_s × fps)`.
    pub fn frame_count(&self) -> usize {
        (self.duration_s * self.fps as f64).round() as usize
    }

    /// When frame `frame` is shown, in seconds.
    pub fn time_of(&self, frame: usize) -> f64 {
        frame as f64 / self.fps as f64
    }

    /// The (AU, side) channels of this timeline in order of first appearance.
    pub fn channels(&self) -> Vec<(AuCode, Laterality)> {
        let mut out: Vec<(AuCode, Laterality)> = Vec::new();
        for track in &self.tracks {
            if !out.contains(&(track.au, track.side)) {
                out.push((track.au, track.side));
            }
        }
        out
    }

    /// The intensity of every channel at time `t` (0 where no track acts), in channel order.
    pub fn values_at(&self, t: f64) -> Vec<((AuCode, Laterality), f64)> {
        self.channels()
            .into_iter()
            .map(|channel| {
                let mut best: Option<(f64, f64)> = None; // (start_s, value)
                for track in self.tracks.iter().filter(|tr| (tr.au, tr.side) == channel) {
                    if let Some(value) = track.value_at(t)
                        && best.is_none_or(|(start, _)| track.start_s >= start)
                    {
                        best = Some((track.start_s, value));
                    }
                }
                (channel, best.map_or(0.0, |(_, v)| v))
            })
            .collect()
    }

    /// The expression shown at frame `frame` (a validated timeline gives a valid expression).
    pub fn frame_expression(&self, frame: usize, catalog: &Catalog) -> Result<Expression, crate::facs::NotationError> {
        self.expression_at(self.time_of(frame), catalog)
    }

    /// The expression shown at time `t`.
    pub fn expression_at(&self, t: f64, catalog: &Catalog) -> Result<Expression, crate::facs::NotationError> {
        let activations = self
            .values_at(t)
            .into_iter()
            .filter(|&(_, value)| value > 0.0)
            .map(|((au, side), value)| Activation { au, side, intensity: Some(Intensity::Fraction(value)) })
            .collect();
        Expression::from_activations(activations, catalog)
    }

    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a timeline serialises")
    }

    pub fn from_json(text: &str) -> Result<Timeline, TimelineError> {
        if text.len() > MAX_JSON_BYTES {
            return Err(TimelineError::Json(format!("{} bytes is over the 4 MiB a timeline may have", text.len())));
        }
        serde_json::from_str(text).map_err(|e| TimelineError::Json(e.to_string()))
    }
}

fn push_clip(tracks: &mut Vec<Track>, expression: &Expression, timing: ClipTiming, start: f64) {
    let ClipTiming { onset_s, apex_s, offset_s, ramp } = timing;
    let (a, b, c, d) = (start, start + onset_s, start + onset_s + apex_s, start + onset_s + apex_s + offset_s);
    for activation in expression.activations() {
        let peak = activation.strength();
        let track = |from, to, start_s, end_s| Track {
            au: activation.au,
            side: activation.side,
            start_intensity: from,
            end_intensity: to,
            start_s,
            end_s,
            ramp,
        };
        tracks.push(track(0.0, peak, a, b));
        tracks.push(track(peak, peak, b, c));
        tracks.push(track(peak, 0.0, c, d));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn catalog() -> &'static Catalog {
        Catalog::built_in()
    }

    fn hapfacs_clip(text: &str) -> Timeline {
        let e = catalog().parse(text).unwrap();
        Timeline::clip(&e, ClipTiming::default(), 30, "wm1", (485, 480))
    }

    #[test]
    fn ramps_start_at_zero_and_end_at_one() {
        for ramp in [Ramp::Linear, Ramp::Smoothstep, Ramp::Cosine] {
            assert_eq!(ramp.shape(0.0), 0.0, "{ramp:?}");
            assert_eq!(ramp.shape(1.0), 1.0, "{ramp:?}");
            assert!((ramp.shape(0.5) - 0.5).abs() < 1e-12, "{ramp:?} is symmetric");
            let mut last = 0.0;
            for i in 1..=100 {
                let v = ramp.shape(i as f64 / 100.0);
                assert!(v >= last, "{ramp:?} is monotone");
                last = v;
            }
        }
        assert_eq!(Ramp::Linear.shape(0.25), 0.25);
        assert!((Ramp::Smoothstep.shape(0.25) - 0.15625).abs() < 1e-12);
        assert!(Ramp::Cosine.shape(0.25) < 0.25, "eased ramps start slowly");
    }

    #[test]
    fn a_3_second_clip_has_90_frames_at_30_fps() {
        let t = hapfacs_clip("12");
        t.validate(catalog()).unwrap();
        assert_eq!(t.frame_count(), 90);
        assert_eq!(t.duration_s, 3.0);
        assert_eq!(t.tracks.len(), 3);
    }

    #[test]
    fn the_hapfacs_clip_rises_holds_and_falls_linearly() {
        let t = hapfacs_clip("12C+R14");
        let value = |f: usize| t.values_at(t.time_of(f)).iter().map(|&(_, v)| v).collect::<Vec<_>>();
        assert_eq!(value(0), [0.0, 0.0]);
        assert!((value(15)[0] - 0.275).abs() < 1e-12, "halfway up C (0.55) is 0.275");
        assert_eq!(value(15)[1], 0.5);
        for f in 30..=60 {
            assert_eq!(value(f), [0.55, 1.0], "frame {f} is in the apex");
        }
        assert!((value(75)[1] - 0.5).abs() < 1e-12);
        assert!((value(89)[1] - 1.0 / 30.0).abs() <= RAMP_STEP, "the last frame is 1/30 s before the end");
        assert_eq!(t.frame_expression(0, catalog()).unwrap(), Expression::neutral());
        assert_eq!(t.frame_expression(45, catalog()).unwrap().to_string(), "12@0.55+R14@1");
    }

    #[test]
    fn the_apex_expression_equals_the_scaled_still() {
        let e = catalog().parse("1+2+4B+L12C").unwrap();
        let peak = e.scaled(0.7);
        let t = Timeline::clip(&peak, ClipTiming::default(), 30, "wm1", (64, 64));
        let apex = (ClipTiming::default().apex_mid_s() * 30.0).round() as usize;
        assert_eq!(t.frame_expression(apex, catalog()).unwrap(), peak);
    }

    #[test]
    fn falling_ramps_mirror_rising_ones_exactly() {
        for ramp in [Ramp::Linear, Ramp::Smoothstep, Ramp::Cosine] {
            let e = catalog().parse("12C+4@0.37").unwrap();
            let t = Timeline::clip(&e, ClipTiming { ramp, ..ClipTiming::default() }, 30, "wm1", (64, 64));
            for k in 1..30 {
                assert_eq!(t.frame_expression(k, catalog()).unwrap(), t.frame_expression(90 - k, catalog()).unwrap(), "{ramp:?} frame {k}");
            }
        }
    }

    #[test]
    fn eased_clips_differ_from_linear_only_on_the_ramps() {
        let e = catalog().parse("12").unwrap();
        let timing = ClipTiming { ramp: Ramp::Cosine, ..ClipTiming::default() };
        let eased = Timeline::clip(&e, timing, 30, "wm1", (64, 64));
        let linear = hapfacs_clip("12");
        let at = |t: &Timeline, f| t.values_at(t.time_of(f))[0].1;
        assert!(at(&eased, 10) < at(&linear, 10));
        assert_eq!(at(&eased, 45), at(&linear, 45));
        assert_eq!(at(&eased, 0), 0.0);
    }

    #[test]
    fn a_cpt_sequence_shows_its_steps_one_after_the_other() {
        let steps: Vec<Expression> = ["1+2+5", "4+7+26+38"].iter().map(|s| catalog().parse(s).unwrap()).collect();
        let timing = ClipTiming { onset_s: 0.5, apex_s: 0.5, offset_s: 0.5, ramp: Ramp::Linear };
        let t = Timeline::sequence(&steps, timing, 30, "bf1", (64, 64));
        t.validate(catalog()).unwrap();
        assert_eq!(t.frame_count(), 90);
        assert_eq!(t.frame_expression(22, catalog()).unwrap().to_string(), "1@1+2@1+5@1");
        assert_eq!(t.frame_expression(45, catalog()).unwrap(), Expression::neutral());
        assert_eq!(t.frame_expression(67, catalog()).unwrap().to_string(), "4@1+7@1+26@1+38@1");
    }

    #[test]
    fn the_same_au_in_consecutive_steps_is_allowed() {
        let steps: Vec<Expression> = ["4+5", "7+23+25", "23+24+38"].iter().map(|s| catalog().parse(s).unwrap()).collect();
        let t = Timeline::sequence(&steps, ClipTiming::default(), 30, "wm1", (64, 64));
        t.validate(catalog()).unwrap();
        // At the boundary between steps 2 and 3 AU 23 is 0 from both sides.
        assert!(!t.expression_at(6.0, catalog()).unwrap().codes().contains(&AuCode(23)));
    }

    #[test]
    fn json_round_trip_is_exact() {
        let e = catalog().parse("1+2+4B+L12@0.4321").unwrap().scaled(0.37);
        let t = Timeline::clip(&e, ClipTiming { ramp: Ramp::Smoothstep, ..ClipTiming::default() }, 25, "bf2", (64, 48));
        let back = Timeline::from_json(&t.to_json()).unwrap();
        assert_eq!(back, t);
        for f in 0..t.frame_count() {
            assert_eq!(back.frame_expression(f, catalog()).unwrap(), t.frame_expression(f, catalog()).unwrap());
        }
    }

    #[test]
    fn json_defaults_follow_hapfacs() {
        let t = Timeline::from_json(r#"{"duration_s": 1, "tracks": [{"au": 12, "start_intensity": 0, "end_intensity": 1, "start_s": 0, "end_s": 1}]}"#).unwrap();
        assert_eq!((t.fps, t.identity.as_str(), t.size), (30, "wm1", [485, 480]));
        assert_eq!((t.tracks[0].side, t.tracks[0].ramp), (Laterality::Both, Ramp::Linear));
    }

    #[test]
    fn validation_names_the_track() {
        let mut t = hapfacs_clip("1+12");
        t.tracks[4].au = AuCode(99);
        assert_eq!(t.validate(catalog()), Err(TimelineError::UnknownAu { track: 5, au: 99 }));
        let mut t = hapfacs_clip("12");
        t.tracks[1].end_intensity = 1.2;
        assert!(t.validate(catalog()).unwrap_err().to_string().starts_with("track 2 (AU 12): end intensity 1.2"));
        let mut t = hapfacs_clip("12");
        t.tracks[0].end_s = -0.5;
        assert!(matches!(t.validate(catalog()), Err(TimelineError::Times { track: 1, .. })));
        let mut t = hapfacs_clip("12");
        t.tracks[2].start_s = 1.5;
        assert_eq!(t.validate(catalog()), Err(TimelineError::Overlap { first: 2, second: 3, au: 12 }));
        let mut t = hapfacs_clip("26");
        t.tracks[0].side = Laterality::Left;
        assert_eq!(t.validate(catalog()), Err(TimelineError::NotUnilateral { track: 1, au: 26 }));
        let mut t = hapfacs_clip("12");
        t.duration_s = -1.0;
        assert_eq!(t.validate(catalog()), Err(TimelineError::Duration(-1.0)));
        for long in [MAX_DURATION_S + 0.001, 1e12, 1e300] {
            t.duration_s = long;
            assert_eq!(t.validate(catalog()), Err(TimelineError::Duration(long)), "bounded before any frame is made");
        }
        assert!(matches!(Timeline::from_json(&" ".repeat(MAX_JSON_BYTES + 1)), Err(TimelineError::Json(m)) if m.len() < 80));
    }

    #[test]
    fn left_and_right_tracks_of_one_au_may_run_together() {
        let e = catalog().parse("L12+R12B").unwrap();
        let t = Timeline::clip(&e, ClipTiming::default(), 30, "wm1", (64, 64));
        t.validate(catalog()).unwrap();
        assert_eq!(t.frame_expression(45, catalog()).unwrap().to_string(), "L12@1+R12@0.3");
    }
}
