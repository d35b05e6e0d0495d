//! Phones → mouth channels over time: the viseme table and its coarticulation.
//!
//! In: the phones of an [`Utterance`](super::Utterance) (IPA symbol, start, end). Out: for any
//! time `t`, the intensity of each speech channel (an AU) and the viseme class of the phone
//! sounding then.
//!
//! The table is data (`stimuli/engine/visemes.toml`, compiled in; its header explains every
//! field): phone classes with a target per AU and a dominance strength. Coarticulation follows
//! the dominance model (Cohen & Massaro 1993): phone `i` has dominance
//! `strength_i · exp(−d / (τ · spread_i))`, where `d` is the distance from `t` to the phone's core (all but its
//! first and last tenth) and `τ` is `ahead_s` before the phone (look-ahead) and `behind_s` after it (carry-over);
//! a channel's value is the dominance-weighted mean of the phones' targets, with a weak constant
//! rest dominance so that the mouth closes where nobody speaks.
//!
//! Invariants: values are in [0, 1] and continuous in `t` (no snapping between shapes: every
//! dominance is continuous); only the table's channels are ever non-zero.

use std::collections::BTreeMap;
use std::sync::OnceLock;

use serde::Deserialize;

use super::espeak::Phone;
use crate::facs::AuCode;

const TABLE: &str = include_str!("../../stimuli/engine/visemes.toml");
/// The dominance of the mouth at rest, present at every time.
const REST_DOMINANCE: f64 = 0.05;
/// The core of a phone (full dominance) leaves out this fraction of its length at each end.
const CORE_MARGIN: f64 = 0.1;
/// Only phones within this many time constants of `t` are weighed (exp(−8) < 0.04 %).
const REACH: f64 = 8.0;

/// Why the viseme table is unusable.
#[derive(Debug, Clone, thiserror::Error)]
#[error("stimuli/engine/visemes.toml: {0}")]
pub struct VisemeTableError(String);

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTable {
    ahead_s: f64,
    behind_s: f64,
    pause: String,
    fallback: String,
    class: Vec<RawClass>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawClass {
    name: String,
    phones: Vec<String>,
    strength: f64,
    #[serde(default = "one")]
    spread: f64,
    aus: BTreeMap<String, f64>,
}

fn one() -> f64 {
    1.0
}

/// One viseme class: its name, dominance and per-channel targets (in [`VisemeTable::channels`] order).
#[derive(Debug, Clone)]
pub struct VisemeClass {
    pub name: String,
    pub phones: Vec<String>,
    pub strength: f64,
    /// Multiplies `ahead_s` and `behind_s` for this class (below 1: a shape that is held only
    /// close to its phone, such as the lip closure of p/b/m).
    pub spread: f64,
    pub targets: Vec<f64>,
}

/// The parsed viseme table.
#[derive(Debug, Clone)]
pub struct VisemeTable {
    /// Every AU some class moves, ascending.
    pub channels: Vec<AuCode>,
    pub classes: Vec<VisemeClass>,
    pub ahead_s: f64,
    pub behind_s: f64,
    pause: usize,
    fallback: usize,
}

/// Stress, length and syllable marks that do not change the mouth shape.
const MARKS: [char; 6] = ['ˈ', 'ˌ', 'ː', 'ˑ', '̩', '.'];

impl VisemeTable {
    /// The compiled-in table.
    pub fn built_in() -> &'static VisemeTable {
        static TABLE_CELL: OnceLock<VisemeTable> = OnceLock::new();
        TABLE_CELL.get_or_init(|| VisemeTable::parse(TABLE).expect("the built-in viseme table is valid (tested)"))
    }

    pub fn parse(text: &str) -> Result<VisemeTable, VisemeTableError> {
        let raw: RawTable = toml::from_str(text).map_err(|e| VisemeTableError(e.to_string()))?;
        let mut channels: Vec<AuCode> = Vec::new();
        for class in &raw.class {
            for key in class.aus.keys() {
                let au = key.parse::<u16>().map(AuCode).map_err(|_| VisemeTableError(format!("class {}: `{key}` is not an AU number", class.name)))?;
                if crate::facs::Catalog::built_in().get(au).is_none() {
                    return Err(VisemeTableError(format!("class {}: AU {key} is not in the catalog", class.name)));
                }
                if !channels.contains(&au) {
                    channels.push(au);
                }
            }
        }
        channels.sort();
        let mut classes = Vec::new();
        for class in raw.class {
            let positive = |v: f64| v.is_finite() && v > 0.0;
            if !positive(class.strength) || !positive(class.spread) || class.aus.values().any(|v| !(0.0..=1.0).contains(v)) {
                return Err(VisemeTableError(format!("class {}: strength and spread must be positive and targets in [0, 1]", class.name)));
            }
            let targets = channels.iter().map(|au| class.aus.get(&au.0.to_string()).copied().unwrap_or(0.0)).collect();
            classes.push(VisemeClass { name: class.name, phones: class.phones, strength: class.strength, spread: class.spread, targets });
        }
        let find = |name: &str| classes.iter().position(|c| c.name == name).ok_or_else(|| VisemeTableError(format!("no class named `{name}`")));
        let (pause, fallback) = (find(&raw.pause)?, find(&raw.fallback)?);
        if !(raw.ahead_s > 0.0 && raw.behind_s > 0.0) {
            return Err(VisemeTableError("ahead_s and behind_s must be positive".into()));
        }
        Ok(VisemeTable { channels, classes, ahead_s: raw.ahead_s, behind_s: raw.behind_s, pause, fallback })
    }

    /// The class of an IPA symbol (see the table's header for the matching rule).
    pub fn class_of(&self, symbol: &str) -> &VisemeClass {
        let bare: String = symbol.chars().filter(|c| !MARKS.contains(c)).collect();
        if bare.is_empty() {
            return &self.classes[self.pause];
        }
        let first: String = bare.chars().take(1).collect();
        [bare.as_str(), first.as_str()]
            .iter()
            .find_map(|s| self.classes.iter().find(|c| c.phones.iter().any(|p| p == s)))
            .unwrap_or(&self.classes[self.fallback])
    }

    /// The speech channels at time `t` (in [`VisemeTable::channels`] order).
    pub fn values_at(&self, phones: &[Phone], t: f64) -> Vec<f64> {
        let mut sum = vec![0.0; self.channels.len()];
        let mut total = REST_DOMINANCE;
        let reach = REACH * self.ahead_s.max(self.behind_s);
        for phone in phones.iter().filter(|p| p.end_s + reach >= t && p.start_s - reach <= t) {
            let class = self.class_of(&phone.symbol);
            let margin = (phone.end_s - phone.start_s) * CORE_MARGIN;
            let (core_start, core_end) = (phone.start_s + margin, phone.end_s - margin);
            let dominance = if t < core_start {
                class.strength * (-(core_start - t) / (self.ahead_s * class.spread)).exp()
            } else if t > core_end {
                class.strength * (-(t - core_end) / (self.behind_s * class.spread)).exp()
            } else {
                class.strength
            };
            total += dominance;
            for (s, target) in sum.iter_mut().zip(&class.targets) {
                *s += dominance * target;
            }
        }
        sum.into_iter().map(|s| (s / total).clamp(0.0, 1.0)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn phone(symbol: &str, start_s: f64, end_s: f64) -> Phone {
        Phone { symbol: symbol.into(), start_s, end_s }
    }

    fn jaw(table: &VisemeTable, phones: &[Phone], t: f64) -> f64 {
        let at = table.channels.iter().position(|&au| au == AuCode(26)).unwrap();
        table.values_at(phones, t)[at]
    }

    #[test]
    fn the_built_in_table_classifies_ipa() {
        let table = VisemeTable::built_in();
        assert_eq!(table.class_of("p").name, "bilabial");
        assert_eq!(table.class_of("ɑː").name, "open");
        assert_eq!(table.class_of("aɪ").name, "open");
        assert_eq!(table.class_of("oʊ").name, "round");
        assert_eq!(table.class_of("").name, "rest");
        assert_eq!(table.class_of("ʘ").name, "mid");
    }

    #[test]
    fn the_jaw_opens_on_a_vowel_closes_on_m_and_never_snaps() {
        let table = VisemeTable::built_in();
        let phones = [phone("ɑː", 0.0, 0.2), phone("m", 0.2, 0.28), phone("ɑː", 0.28, 0.5)];
        assert!(jaw(table, &phones, 0.1) > 0.6, "open vowel: {}", jaw(table, &phones, 0.1));
        assert!(jaw(table, &phones, 0.24) < 0.2, "m: {}", jaw(table, &phones, 0.24));
        // Continuous: no jump larger than a small fraction over 1 ms anywhere.
        let steps: Vec<f64> = (0..500).map(|ms| jaw(table, &phones, ms as f64 / 1000.0)).collect();
        let jump = steps.windows(2).map(|w| (w[1] - w[0]).abs()).fold(0.0, f64::max);
        assert!(jump < 0.05, "largest change in 1 ms: {jump}");
        // Look-ahead: the jaw starts closing before the /m/ begins.
        assert!(jaw(table, &phones, 0.19) < jaw(table, &phones, 0.1));
    }
}
