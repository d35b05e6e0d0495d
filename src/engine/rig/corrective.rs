//! Pair correctives: extra channel values for AU combinations whose summed basis double-counts
//! or fights (data: `stimuli/engine/correctives.toml`).
//!
//! In: the strength of every AU on each side of the face. Out: (channel, side, value) additions
//! to the basis' channel values. A corrective acts on a side with the smallest strength of its
//! AUs there (none shown → nothing), times each channel's `max`. Invariant: an expression without
//! all of a corrective's AUs gets nothing from it; values are bounded by `max` in magnitude.

use std::collections::BTreeMap;

use serde::Deserialize;

use super::{Channel, ChannelUse, RawChannel, RigError, Side};
use crate::facs::AuCode;

/// The most AUs a corrective may name, and the most correctives in a table.
const MAX_AUS: usize = 4;
const MAX_CORRECTIVES: usize = 256;

/// One combination and the channel values that correct it.
#[derive(Debug, Clone)]
pub struct Corrective {
    pub aus: Vec<AuCode>,
    pub channels: Vec<ChannelUse>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCorrective {
    aus: Vec<AuCode>,
    /// What the combination looks like in FACS and what the corrective fixes (documentation).
    #[allow(dead_code)]
    why: String,
    channels: Vec<RawChannel>,
}

#[derive(Deserialize)]
struct CorrectiveFile {
    corrective: Vec<RawCorrective>,
}

/// Reads a correctives table; `known` says whether an AU code is in the basis.
pub fn from_toml(text: &str, known: impl Fn(AuCode) -> bool) -> Result<Vec<Corrective>, RigError> {
    let file: CorrectiveFile = toml::from_str(text)?;
    if file.corrective.len() > MAX_CORRECTIVES {
        return Err(RigError::Corrective(format!("{} correctives (at most {MAX_CORRECTIVES})", file.corrective.len())));
    }
    let mut seen = std::collections::BTreeSet::new();
    let mut out = Vec::new();
    for raw in file.corrective {
        let mut aus = raw.aus.clone();
        aus.sort();
        aus.dedup();
        let name = raw.aus.iter().map(|a| a.to_string()).collect::<Vec<_>>().join("+");
        if aus.len() < 2 || aus.len() > MAX_AUS || aus.len() != raw.aus.len() {
            return Err(RigError::Corrective(format!("{name}: name 2..={MAX_AUS} different AUs")));
        }
        if let Some(unknown) = aus.iter().find(|&&a| !known(a)) {
            return Err(RigError::Corrective(format!("{name}: AU {unknown} is not in the basis")));
        }
        if !seen.insert(aus.clone()) {
            return Err(RigError::Corrective(format!("{name} appears twice")));
        }
        let channels = raw.channels.into_iter().map(ChannelUse::from_raw).collect::<Result<Vec<_>, RigError>>()?;
        if let Some(rigid) = channels.iter().find(|c| c.channel.is_rigid()) {
            return Err(RigError::Corrective(format!("{name}: rigid channel {:?} (correctives shape the face only)", rigid.channel)));
        }
        out.push(Corrective { aus, channels });
    }
    Ok(out)
}

impl Corrective {
    /// The corrective's weight on `side`: the smallest strength of its AUs there.
    pub fn weight(&self, strengths: &BTreeMap<(AuCode, Side), f32>, side: Side) -> f32 {
        self.aus.iter().map(|au| strengths.get(&(*au, side)).copied().unwrap_or(0.0)).fold(f32::INFINITY, f32::min)
    }

    /// The (channel, side, value) additions for the given per-side AU strengths.
    pub fn additions(&self, strengths: &BTreeMap<(AuCode, Side), f32>) -> Vec<(Channel, Side, f32)> {
        let mut out = Vec::new();
        for side in Side::BOTH {
            let weight = self.weight(strengths, side);
            if weight <= 0.0 {
                continue;
            }
            for use_ in self.channels.iter().filter(|u| u.side.is_none_or(|s| s == side)) {
                out.push((use_.channel.clone(), side, use_.value_at(weight)));
            }
        }
        out
    }
}
