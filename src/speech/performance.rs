//! A speaking face: an utterance and a face (an expression or a timeline) → one timeline of
//! AU tracks, the phone and viseme of every frame, and the sound track on the video's clock.
//!
//! In: an [`Utterance`], a [`Face`], the frame rate, identity, size and a seed. Out: a
//! [`Performance`]. The video starts with [`LEAD_S`] of silence and ends [`TAIL_S`] after the
//! speech, rounded up to whole frames; the sound is padded with silence to exactly the video's
//! length, so sound and picture last equally long by construction.
//!
//! Blend rules (per frame; "speech" is [`VisemeTable::values_at`], "face" the given face):
//! 1. **Speech owns** the jaw and the lips' closure and rounding: AUs 18, 19, 22, 23, 24, 25,
//!    26, 27 and 28 take the speech value; the face's values for them are dropped (a surprised
//!    speaker's jaw drop gives way to the words).
//! 2. **Speech adds** to the lip corners and upper lip: AUs 10, 12 and 20 are face + speech,
//!    capped at 1 (a happy speaker keeps smiling while the lips spread on /i/).
//! 3. **The face keeps** everything else: brows, lids, cheeks, nose, chin and the other lower-face
//!    AUs (an angry speaker still lowers the brows and raises the chin).
//! 4. **Life**: seeded blinks (AU45, every 2–5 s, 0.27 s each) and small seeded head motion
//!    (turn 51/52, nod 53/54, tilt 55/56, at most 0.06, sums of slow sines) are added to the
//!    face's head AUs (a signed sum per pair, split back into the pair's two AUs).
//!
//! Invariants: same inputs → the same timeline; every frame's value of an AU the face sets and
//! rule 3 keeps equals the face's value (head AUs differ by at most the motion's amplitude).

use std::collections::BTreeMap;

use super::espeak::Utterance;
use super::visemes::VisemeTable;
use crate::engine::timeline::{Ramp, Timeline, Track};
use crate::facs::{AuCode, Expression, Laterality};
use crate::seeded::SplitMix64;

/// Silence before the speech starts.
pub const LEAD_S: f64 = 0.3;
/// Silence after the speech ends.
pub const TAIL_S: f64 = 0.3;
/// AUs whose value is the speech's (rule 1).
pub const SPEECH_OWNS: [u16; 9] = [18, 19, 22, 23, 24, 25, 26, 27, 28];
/// AUs to which the speech adds (rule 2).
pub const SPEECH_ADDS: [u16; 3] = [10, 12, 20];
/// Head AU pairs moved by the seeded head motion: (positive, negative, amplitude).
const HEAD_PAIRS: [(u16, u16, f64); 3] = [(51, 52, 0.06), (53, 54, 0.05), (55, 56, 0.04)];
const BLINK: u16 = 45;

/// What the face does while it speaks.
#[derive(Debug, Clone)]
pub enum Face {
    /// One expression, held for the whole video (an EmFACS prototype or any FACS expression).
    Held(Expression),
    /// A timeline's values over time (its identity, size and rate are not used).
    Timeline(Timeline),
}

type Channel = (AuCode, Laterality);

impl Face {
    fn values_at(&self, t: f64) -> Vec<(Channel, f64)> {
        match self {
            Face::Held(expression) => expression.activations().iter().map(|a| ((a.au, a.side), a.strength())).collect(),
            Face::Timeline(timeline) => timeline.values_at(t),
        }
    }
}

/// One frame's speech: the phone sounding (IPA, empty in a pause) and its viseme class.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameSpeech {
    pub phoneme: String,
    pub viseme: String,
}

/// Everything a speaking video needs.
#[derive(Debug, Clone)]
pub struct Performance {
    pub timeline: Timeline,
    pub frames: Vec<FrameSpeech>,
    /// The sound at `sample_rate`, exactly `timeline.duration_s` long.
    pub samples: Vec<i16>,
    pub sample_rate: u32,
}

/// Where a performance is shown.
#[derive(Debug, Clone, Copy)]
pub struct Staging<'a> {
    pub fps: u32,
    pub identity: &'a str,
    pub size: (u32, u32),
    /// Seeds the blinks and the head motion.
    pub seed: u64,
}

/// Builds the performance of `utterance` on `face` (see the module doc).
pub fn perform(utterance: &Utterance, face: &Face, staging: Staging) -> Performance {
    let fps = f64::from(staging.fps);
    let frame_count = ((LEAD_S + utterance.duration_s() + TAIL_S) * fps).ceil() as usize;
    let duration_s = frame_count as f64 / fps;
    let phones: Vec<_> = utterance.phones.iter().map(|p| super::espeak::Phone { start_s: p.start_s + LEAD_S, end_s: p.end_s + LEAD_S, ..p.clone() }).collect();
    let table = VisemeTable::built_in();
    let life = Life::new(staging.seed, duration_s);
    let mut values: Vec<BTreeMap<Channel, f64>> = Vec::with_capacity(frame_count);
    let mut frames = Vec::with_capacity(frame_count);
    for f in 0..frame_count {
        let t = f as f64 / fps;
        let speech: Vec<(AuCode, f64)> = table.channels.iter().copied().zip(table.values_at(&phones, t)).collect();
        values.push(blend(&face.values_at(t), &speech, &life, t));
        let phoneme = super::espeak::phone_at(&phones, t).map(|p| p.symbol.clone()).unwrap_or_default();
        frames.push(FrameSpeech { viseme: table.class_of(&phoneme).name.clone(), phoneme });
    }
    let timeline = Timeline {
        fps: staging.fps,
        duration_s,
        identity: staging.identity.to_string(),
        size: [staging.size.0, staging.size.1],
        tracks: tracks_through(&values, fps),
        shoulders: Vec::new(),
    };
    let lead = (LEAD_S * f64::from(utterance.sample_rate)).round() as usize;
    let total = (duration_s * f64::from(utterance.sample_rate)).round() as usize;
    let mut samples = vec![0i16; lead];
    samples.extend_from_slice(&utterance.samples);
    samples.resize(total, 0);
    Performance { timeline, frames, samples, sample_rate: utterance.sample_rate }
}

/// One frame's channels by the blend rules of the module doc.
fn blend(face: &[(Channel, f64)], speech: &[(AuCode, f64)], life: &Life, t: f64) -> BTreeMap<Channel, f64> {
    let mut out: BTreeMap<Channel, f64> = BTreeMap::new();
    for &((au, side), v) in face {
        if !SPEECH_OWNS.contains(&au.0) && v > 0.0 {
            out.insert((au, side), v);
        }
    }
    for &(au, v) in speech.iter().filter(|(_, v)| *v > 0.0) {
        if SPEECH_OWNS.contains(&au.0) {
            out.insert((au, Laterality::Both), v);
        } else if out.contains_key(&(au, Laterality::Both)) || !out.keys().any(|(a, _)| *a == au) {
            *out.entry((au, Laterality::Both)).or_insert(0.0) += v;
        } else {
            for side in [Laterality::Left, Laterality::Right] {
                *out.entry((au, side)).or_insert(0.0) += v;
            }
        }
    }
    let blink = life.blink_at(t);
    if blink > 0.0 {
        let v = out.entry((AuCode(BLINK), Laterality::Both)).or_insert(0.0);
        *v = v.max(blink);
    }
    for (i, &(up, down, _)) in HEAD_PAIRS.iter().enumerate() {
        let (up, down) = ((AuCode(up), Laterality::Both), (AuCode(down), Laterality::Both));
        let net = out.remove(&up).unwrap_or(0.0) - out.remove(&down).unwrap_or(0.0) + life.head_at(i, t);
        out.insert(if net >= 0.0 { up } else { down }, net.abs());
    }
    out.retain(|_, v| {
        *v = (*v * 1e3).round() / 1e3;
        *v = v.min(1.0);
        *v > 0.0
    });
    out
}

/// Per-channel tracks through the frames' values: one linear segment per frame step, runs of a
/// held value as one track, nothing where a channel is 0 at both ends.
fn tracks_through(values: &[BTreeMap<Channel, f64>], fps: f64) -> Vec<Track> {
    let mut channels: Vec<Channel> = values.iter().flat_map(|m| m.keys().copied()).collect();
    channels.sort();
    channels.dedup();
    let mut tracks = Vec::new();
    for (au, side) in channels {
        let series: Vec<f64> = values.iter().map(|m| m.get(&(au, side)).copied().unwrap_or(0.0)).collect();
        let mut f = 0;
        while f + 1 < series.len() {
            let (a, b) = (series[f], series[f + 1]);
            let mut end = f + 1;
            if a == b {
                while end + 1 < series.len() && series[end + 1] == a {
                    end += 1;
                }
            }
            if a > 0.0 || b > 0.0 {
                let (start_s, end_s) = (f as f64 / fps, end as f64 / fps);
                tracks.push(Track { au, side, start_intensity: a, end_intensity: b, start_s, end_s, ramp: Ramp::Linear });
            }
            f = end;
        }
        if series.len() == 1 && series[0] > 0.0 {
            tracks.push(Track { au, side, start_intensity: series[0], end_intensity: series[0], start_s: 0.0, end_s: 0.0, ramp: Ramp::Linear });
        }
    }
    tracks
}

/// Seeded blinks and head motion.
struct Life {
    /// Blink start times.
    blinks: Vec<f64>,
    /// Per head pair: (frequency Hz, phase) of two sines.
    head: Vec<[(f64, f64); 2]>,
}

/// A blink closes over 0.08 s, stays closed 0.04 s and opens over 0.15 s.
const BLINK_SHAPE: [(f64, f64); 4] = [(0.0, 0.0), (0.08, 1.0), (0.12, 1.0), (0.27, 0.0)];

impl Life {
    fn new(seed: u64, duration_s: f64) -> Life {
        let mut rng = SplitMix64(seed ^ 0x5EED_B11E);
        let mut blinks = Vec::new();
        let mut t = 0.5 + 1.5 * rng.unit();
        while t < duration_s {
            blinks.push(t);
            t += 2.0 + 3.0 * rng.unit();
        }
        let head = HEAD_PAIRS.iter().map(|_| [0, 1].map(|_| (0.15 + 0.35 * rng.unit(), std::f64::consts::TAU * rng.unit()))).collect();
        Life { blinks, head }
    }

    fn blink_at(&self, t: f64) -> f64 {
        let Some(start) = self.blinks.iter().copied().rfind(|&b| b <= t) else { return 0.0 };
        let s = t - start;
        BLINK_SHAPE.windows(2).find(|w| s >= w[0].0 && s <= w[1].0).map_or(0.0, |w| {
            let ((t0, v0), (t1, v1)) = (w[0], w[1]);
            v0 + (v1 - v0) * (s - t0) / (t1 - t0)
        })
    }

    fn head_at(&self, pair: usize, t: f64) -> f64 {
        let amplitude = HEAD_PAIRS[pair].2;
        amplitude * self.head[pair].iter().map(|(f, phase)| (std::f64::consts::TAU * f * t + phase).sin()).sum::<f64>() / 2.0
    }
}
