//! Performing a laugh type: one seeded take of a [`LaughType`] as per-frame [`Curves`].
//!
//! In: a type from the table and a [`Take`] (frame rate, optional duration, intensity, seed).
//! Out: curves with one track per table track, every value in [0, 1], which
//! [`Curves::to_timeline`] plays on any identity.
//!
//! A track's value at time `t` is `peak × envelope(t) × pulse(t)`: the envelope rises over the
//! onset (after the track's delay), holds through the apex and falls over the offset, each with
//! a smoothstep; for laughs, `pulse(t) = 1 − depth + depth × a_k × sin²(π u)` over pulse `k`
//! (`u` its phase), so the jaw, head and cheeks open and close together at the pulse rate, the
//! pulses weakening by the type's decay. The seeded variation jitters the phases, each track's
//! peak and start, the pulse rate (and so the number of pulses) and each pulse's strength. A
//! laugh's shoulders (the table's `shoulders`) rise and shake with the same envelope and pulses:
//! the chest heaves and the shoulders bob with each "ha".
//!
//! Invariants: the same type, take and seed give the same bytes (SplitMix64, a fixed draw
//! order, no platform-dependent maths beyond IEEE `sin`); values are rounded to
//! [`VALUE_STEP`] so the JSON and `.anim` files stay short.

use crate::seeded::SplitMix64;

use super::curves::{CurveTrack, Curves, FORMAT};
use super::types::{Envelope, LaughType, Pulses};

/// Longest take, seconds.
pub const MAX_DURATION_S: f64 = 20.0;
/// Shortest take, seconds.
pub const MIN_DURATION_S: f64 = 0.5;
/// Frame rates a take may have.
pub const FPS_RANGE: std::ops::RangeInclusive<u32> = 1..=60;
/// Curve values are rounded to this step.
pub const VALUE_STEP: f64 = 1e-4;

/// How to perform one take.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Take {
    pub fps: u32,
    /// `None`: the type's natural length (with the take's timing jitter).
    pub duration_s: Option<f64>,
    /// Scales every peak, in (0, 1].
    pub intensity: f64,
    pub seed: u64,
}

impl Default for Take {
    fn default() -> Self {
        Take { fps: 30, duration_s: None, intensity: 1.0, seed: 1 }
    }
}

/// A take that cannot be performed; the message names the value.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PerformError {
    #[error("duration {0} s is out of range ({MIN_DURATION_S}..={MAX_DURATION_S} s)")]
    Duration(f64),
    #[error("intensity {0} is out of range (0, 1]")]
    Intensity(f64),
    #[error("frame rate {0} is out of range (1..=60 fps)")]
    Fps(u32),
}

impl Take {
    fn validate(&self) -> Result<(), PerformError> {
        if !FPS_RANGE.contains(&self.fps) {
            return Err(PerformError::Fps(self.fps));
        }
        if !(self.intensity.is_finite() && self.intensity > 0.0 && self.intensity <= 1.0) {
            return Err(PerformError::Intensity(self.intensity));
        }
        match self.duration_s {
            Some(d) if !(d.is_finite() && (MIN_DURATION_S..=MAX_DURATION_S).contains(&d)) => Err(PerformError::Duration(d)),
            _ => Ok(()),
        }
    }
}

/// Performs one take of `laugh`.
pub fn perform(laugh: &LaughType, take: &Take) -> Result<Curves, PerformError> {
    take.validate()?;
    let mut rng = SplitMix64(take.seed ^ fnv1a(laugh.id.as_bytes()));
    let envelope = fit_duration(jitter_envelope(laugh, &mut rng), take.duration_s);
    let pulses = laugh.pulses.map(|p| pulse_train(p, laugh, &envelope, &mut rng));
    let frames = ((envelope.total() * take.fps as f64).round() as usize).max(2);
    let v = laugh.variation;
    let tracks = laugh
        .tracks
        .iter()
        .map(|track| {
            let peak = (track.peak * take.intensity * (1.0 + v.peak * truncated_normal(&mut rng))).clamp(0.0, 1.0);
            let delay = (track.delay + v.delay * truncated_normal(&mut rng)).max(0.0);
            let values = (0..frames).map(|f| value_at(track.pulse, peak, delay, &envelope, pulses.as_ref(), f as f64 / take.fps as f64)).collect();
            CurveTrack { au: track.au, side: track.side, values }
        })
        .collect();
    let shoulders = match laugh.shoulders {
        Some(s) => {
            let peak = (s.peak * take.intensity * (1.0 + v.peak * truncated_normal(&mut rng))).clamp(0.0, 1.0);
            (0..frames).map(|f| value_at(s.pulse, peak, 0.0, &envelope, pulses.as_ref(), f as f64 / take.fps as f64)).collect()
        }
        None => Vec::new(),
    };
    let count = pulses.as_ref().map_or(0, |p| p.len());
    let source = format!("laugh table: {}, seed {}, intensity {}, {count} pulses", laugh.id, take.seed, take.intensity);
    Ok(Curves { format: FORMAT.into(), laugh_type: laugh.id.clone(), fps: take.fps, source, tracks, fit: None, shoulders })
}

/// FNV-1a of the type's id, so one seed gives different takes of different types.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3))
}

/// A standard normal draw truncated at ±2.
fn truncated_normal(rng: &mut SplitMix64) -> f64 {
    rng.normal().clamp(-2.0, 2.0)
}

fn jitter_envelope(laugh: &LaughType, rng: &mut SplitMix64) -> Envelope {
    let e = laugh.envelope;
    let timing = laugh.variation.timing;
    let mut scale = || 1.0 + timing * truncated_normal(rng);
    Envelope { onset: e.onset * scale(), apex: e.apex * scale(), offset: e.offset * scale(), ..e }
}

/// Stretches or shrinks the apex to make the take last `duration` seconds; when even a zero
/// apex is too long, every phase shrinks in proportion.
fn fit_duration(e: Envelope, duration: Option<f64>) -> Envelope {
    let Some(duration) = duration else { return e };
    let rest = e.lead + e.onset + e.offset + e.tail;
    if duration >= rest {
        return Envelope { apex: duration - rest, ..e };
    }
    let k = duration / rest;
    Envelope { lead: e.lead * k, onset: e.onset * k, apex: 0.0, offset: e.offset * k, tail: e.tail * k }
}

/// One laugh pulse: its start, length and strength.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Pulse {
    start: f64,
    length: f64,
    strength: f64,
}

/// The pulses from the start of the onset to the end of the offset, at the take's jittered
/// rate, each a little longer or shorter and stronger or weaker, weakening by the decay.
fn pulse_train(p: Pulses, laugh: &LaughType, e: &Envelope, rng: &mut SplitMix64) -> Vec<Pulse> {
    let v = laugh.variation;
    let rate = p.rate * (1.0 + v.rate * truncated_normal(rng));
    let (start, end) = (e.lead, e.lead + e.onset + e.apex + e.offset);
    let count = (((end - start) * rate).floor() as usize).max(1);
    let mut pulses = Vec::with_capacity(count);
    let mut t = start;
    for k in 0..count {
        let length = (1.0 / rate) * (1.0 + 0.5 * v.rate * truncated_normal(rng));
        let fade = 1.0 - p.decay * k as f64 / count.max(2).saturating_sub(1) as f64;
        let strength = (fade * (1.0 + v.pulse_peak * truncated_normal(rng))).clamp(0.2, 1.3);
        pulses.push(Pulse { start: t, length, strength });
        t += length;
    }
    pulses
}

fn smoothstep(s: f64) -> f64 {
    let s = s.clamp(0.0, 1.0);
    s * s * (3.0 - 2.0 * s)
}

/// The envelope of a track delayed by `delay`: 0 before, rising over the onset, 1 through the
/// apex, falling over the offset (which ends where the type's does).
fn envelope_at(e: &Envelope, delay: f64, t: f64) -> f64 {
    let rise_start = e.lead + delay.min(e.onset + e.apex);
    let fall_start = e.lead + e.onset + e.apex;
    let rise = smoothstep((t - rise_start) / e.onset);
    let fall = 1.0 - smoothstep((t - fall_start) / e.offset);
    rise.min(fall)
}

/// The pulse factor at `t` for a track pulsed to `depth`.
fn pulse_at(pulses: &[Pulse], depth: f64, t: f64) -> f64 {
    if depth == 0.0 {
        return 1.0;
    }
    let open = pulses
        .iter()
        .find(|p| t >= p.start && t < p.start + p.length)
        .map_or(0.0, |p| p.strength * (std::f64::consts::PI * (t - p.start) / p.length).sin().powi(2));
    1.0 - depth + depth * open
}

/// A track's value at `t`: `peak` under the envelope (started `delay` late), shaken by the
/// pulses to `depth`.
fn value_at(depth: f64, peak: f64, delay: f64, e: &Envelope, pulses: Option<&Vec<Pulse>>, t: f64) -> f64 {
    let pulse = pulses.map_or(1.0, |p| pulse_at(p, depth, t));
    let value = (peak * envelope_at(e, delay, t) * pulse).clamp(0.0, 1.0);
    (value / VALUE_STEP).round() * VALUE_STEP
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::facs::{AuCode, Catalog, Laterality};
    use crate::laugh::types::LaughTable;

    fn track(curves: &Curves, au: u16) -> &[f64] {
        &curves.tracks.iter().find(|t| t.au == AuCode(au) && t.side == Laterality::Both).unwrap().values
    }

    /// Local maxima above half the track's peak: the laugh's visible pulses.
    fn bursts(values: &[f64]) -> usize {
        let top = values.iter().cloned().fold(0.0, f64::max);
        values.windows(3).filter(|w| w[1] > w[0] && w[1] >= w[2] && w[1] > 0.5 * top).count()
    }

    #[test]
    fn every_type_performs_into_valid_curves_and_the_same_seed_gives_the_same_take() {
        let catalog = Catalog::built_in();
        for laugh in LaughTable::built_in().iter() {
            let curves = perform(laugh, &Take::default()).unwrap();
            curves.validate(catalog).unwrap();
            assert_eq!(curves.laugh_type, laugh.id);
            assert_eq!(curves.tracks.len(), laugh.tracks.len());
            let again = perform(laugh, &Take::default()).unwrap();
            assert_eq!(curves.to_json(), again.to_json(), "{}", laugh.id);
            let other = perform(laugh, &Take { seed: 2, ..Take::default() }).unwrap();
            assert_ne!(curves.to_json(), other.to_json(), "seed 2 differs for {}", laugh.id);
            // Every take starts and ends at rest.
            for t in &curves.tracks {
                assert!(t.values[0] == 0.0 && *t.values.last().unwrap() < 0.01, "{} AU{} rests at the ends", laugh.id, t.au);
            }
        }
    }

    #[test]
    fn laughs_pulse_at_their_rate_and_smiles_hold() {
        let table = LaughTable::built_in();
        let uproarious = perform(table.get("uproarious_laughter").unwrap(), &Take::default()).unwrap();
        let seconds = uproarious.frame_count() as f64 / 30.0;
        let n = bursts(track(&uproarious, 26));
        assert!((10..=22).contains(&n), "uproarious laughter: {n} jaw bursts in {seconds:.1} s");
        let smile = perform(table.get("closed_mouth_smile").unwrap(), &Take::default()).unwrap();
        assert_eq!(bursts(track(&smile, 12)), 1, "a smile rises once and holds");
        // Pulse counts differ between seeds (rate and apex vary).
        let counts: std::collections::BTreeSet<usize> = (1..8)
            .map(|seed| bursts(track(&perform(table.get("laughter").unwrap(), &Take { seed, ..Take::default() }).unwrap(), 26)))
            .collect();
        assert!(counts.len() >= 2, "pulse counts over seven seeds: {counts:?}");
        // The shoulders rise and bob with the same pulses as the jaw; a smile's stay at rest.
        let shoulders = &uproarious.shoulders;
        assert_eq!(bursts(shoulders), n, "a shoulder bob per jaw burst");
        let top = shoulders.iter().copied().fold(0.0, f64::max);
        assert!((0.45..=0.75).contains(&top) && shoulders[0] == 0.0, "uproarious laughter lifts the shoulders to {top:.2} of a shrug, from rest");
        assert!(smile.shoulders.is_empty(), "a smile does not move the shoulders");
    }

    #[test]
    fn duration_and_intensity_shape_the_take_and_bad_values_are_named() {
        let laugh = LaughTable::built_in().get("laughter").unwrap();
        let long = perform(laugh, &Take { duration_s: Some(8.0), ..Take::default() }).unwrap();
        assert_eq!(long.frame_count(), 240);
        let short = perform(laugh, &Take { duration_s: Some(1.0), fps: 25, ..Take::default() }).unwrap();
        assert_eq!(short.frame_count(), 25);
        let half = perform(laugh, &Take { intensity: 0.5, ..Take::default() }).unwrap();
        let full = perform(laugh, &Take::default()).unwrap();
        let max = |c: &Curves| track(c, 12).iter().cloned().fold(0.0, f64::max);
        assert!((max(&half) / max(&full) - 0.5).abs() < 0.01, "{} vs {}", max(&half), max(&full));
        let err = |take: Take| perform(laugh, &take).unwrap_err().to_string();
        assert_eq!(err(Take { duration_s: Some(21.0), ..Take::default() }), "duration 21 s is out of range (0.5..=20 s)");
        assert_eq!(err(Take { intensity: 0.0, ..Take::default() }), "intensity 0 is out of range (0, 1]");
        assert_eq!(err(Take { fps: 0, ..Take::default() }), "frame rate 0 is out of range (1..=60 fps)");
    }
}
