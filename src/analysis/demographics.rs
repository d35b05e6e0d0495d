//! Participants' demographics per stimulus group (HapFACS Table 6).
//!
//! Convention: a participant belongs to every condition (media × intensity) they answered at
//! least one stimulus of; coders (who only gave `aus` answers) form the `coders` row. Percentages
//! are of the row's participants, including those who did not state the item; mean age is over
//! those who stated an age. Gender and ethnicity levels are the lower-cased values as given.

use std::collections::{BTreeMap, BTreeSet};

use serde::Serialize;

use super::manifest::Manifest;
use super::responses::Responses;

pub const CONVENTION: &str = "A participant counts in every condition (media x intensity) they answered; coders form their own row. Percent of the row's participants (unstated included in the denominator); mean age over stated ages; levels lower-cased as given.";

/// One level of a categorical item.
#[derive(Debug, Clone, Serialize)]
pub struct Level {
    pub level: String,
    pub n: usize,
    pub percent: f64,
    /// Mean age of the level's participants (gender rows only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mean_age: Option<f64>,
}

/// One row of Table 6.
#[derive(Debug, Clone, Serialize)]
pub struct DemographicRow {
    pub stratum: String,
    pub participants: usize,
    pub mean_age: Option<f64>,
    pub gender: Vec<Level>,
    pub ethnicity: Vec<Level>,
    pub education: Vec<Level>,
}

/// Table 6 plus the all-participants row.
#[derive(Debug, Clone, Serialize)]
pub struct Demographics {
    pub convention: String,
    pub rows: Vec<DemographicRow>,
}

fn mean(x: &[f64]) -> Option<f64> {
    (!x.is_empty()).then(|| x.iter().sum::<f64>() / x.len() as f64)
}

fn row(stratum: String, who: &BTreeSet<usize>, r: &Responses) -> DemographicRow {
    let n = who.len();
    let levels = |get: fn(&super::responses::Participant) -> Option<&String>, with_age: bool| -> Vec<Level> {
        let mut by: BTreeMap<String, Vec<usize>> = BTreeMap::new();
        for &p in who {
            if let Some(v) = get(&r.participants[p]) {
                by.entry(v.clone()).or_default().push(p);
            }
        }
        let mut out: Vec<Level> = by
            .into_iter()
            .map(|(level, ps)| Level {
                percent: 100.0 * ps.len() as f64 / n as f64,
                n: ps.len(),
                mean_age: if with_age { mean(&ps.iter().filter_map(|&p| r.participants[p].age).collect::<Vec<_>>()) } else { None },
                level,
            })
            .collect();
        out.sort_by(|a, b| b.n.cmp(&a.n).then(a.level.cmp(&b.level)));
        out
    };
    DemographicRow {
        stratum,
        participants: n,
        mean_age: mean(&who.iter().filter_map(|&p| r.participants[p].age).collect::<Vec<_>>()),
        gender: levels(|p| p.gender.as_ref(), true),
        ethnicity: levels(|p| p.ethnicity.as_ref(), false),
        education: levels(|p| p.education.as_ref(), false),
    }
}

/// Computes Table 6; `None` when no participant stated any demographic item.
pub fn analyze(manifest: &Manifest, responses: &Responses) -> Option<Demographics> {
    let any = responses.participants.iter().any(|p| p.age.is_some() || p.gender.is_some() || p.ethnicity.is_some() || p.education.is_some());
    if !any {
        return None;
    }
    let mut by_cond: BTreeMap<(std::cmp::Reverse<super::manifest::Media>, std::cmp::Reverse<u32>), BTreeSet<usize>> = BTreeMap::new();
    for e in &responses.emotions {
        let s = &manifest.stimuli[e.stimulus];
        by_cond.entry((std::cmp::Reverse(s.media), std::cmp::Reverse(s.intensity_percent()))).or_default().insert(e.participant);
    }
    for x in &responses.ratings {
        let s = &manifest.stimuli[x.stimulus];
        by_cond.entry((std::cmp::Reverse(s.media), std::cmp::Reverse(s.intensity_percent()))).or_default().insert(x.participant);
    }
    let mut rows: Vec<DemographicRow> =
        by_cond.iter().map(|((m, i), who)| row(format!("{} {}%", m.0.as_str(), i.0), who, responses)).collect();
    let coders: BTreeSet<usize> = responses.aus.iter().map(|a| a.participant).collect();
    if !coders.is_empty() {
        rows.push(row("coders".into(), &coders, responses));
    }
    let all: BTreeSet<usize> = (0..responses.participants.len()).collect();
    rows.push(row("all participants".into(), &all, responses));
    Some(Demographics { convention: CONVENTION.into(), rows })
}
