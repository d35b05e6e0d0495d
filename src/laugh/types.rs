//! The thirteen laugh and smile types as data (`stimuli/laughs/types.toml`).
//!
//! In: the TOML table (the built-in one, or a user's in the same format). Out: a checked
//! [`LaughTable`] of [`LaughType`]s in the table's order, each with its envelope, AU tracks,
//! laugh pulses and seeded-variation settings, which [`super::perform`] turns into curves.
//!
//! Invariants, checked once on reading so a typo is reported with the type that holds it:
//! ids are unique snake_case; every AU is in the catalog and one-sided only where the catalog
//! allows; a channel (AU and side) appears once per type, by the same rule as
//! [`super::Curves::validate`]; peaks and pulse depths lie in [0, 1]; envelope phases are
//! finite and non-negative with a positive onset and offset; a laugh has pulses and a smile none.

use serde::Deserialize;

use crate::facs::{AuCode, Catalog, Laterality};

/// The built-in table.
const BUILT_IN: &str = include_str!("../../stimuli/laughs/types.toml");

/// Laugh pulse rates facslab accepts, Hz.
pub const PULSE_RATES: std::ops::RangeInclusive<f64> = 1.0..=10.0;

/// What is wrong with a laugh-type table; messages name the type.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TypesError {
    #[error("the laugh-type table is not valid TOML: {0}")]
    Toml(String),
    #[error("type {0:?}: an id is snake_case (a-z, 0-9, _), 1-40 characters")]
    Id(String),
    #[error("type {0:?} appears twice")]
    Duplicate(String),
    #[error("type {0:?} is not a label of the `laughs` label set (stimuli/labels/laughs.toml), which names the types")]
    NotALabel(String),
    #[error("type {id:?}: AU {au} is not in the catalog")]
    UnknownAu { id: String, au: u16 },
    #[error("type {id:?}: AU {au} cannot be shown on one side only")]
    NotUnilateral { id: String, au: u16 },
    #[error("type {id:?}: AU {au} appears twice on overlapping sides")]
    DuplicateTrack { id: String, au: u16 },
    #[error("type {id:?}: {field} is {value}; it must be {range}")]
    Range { id: String, field: String, value: f64, range: &'static str },
    #[error("type {id:?}: a {kind} {rule}")]
    Kind { id: String, kind: &'static str, rule: &'static str },
    #[error("type {id:?} has no tracks")]
    NoTracks { id: String },
}

/// Whether a type pulses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Kind {
    /// Rhythmic "ha" pulses of jaw, head and cheeks.
    Laugh,
    /// Held.
    Smile,
}

/// The phases of a take, seconds.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Envelope {
    pub lead: f64,
    pub onset: f64,
    pub apex: f64,
    pub offset: f64,
    pub tail: f64,
}

impl Envelope {
    /// The natural length of a take.
    pub fn total(&self) -> f64 {
        self.lead + self.onset + self.apex + self.offset + self.tail
    }
}

/// The laugh pulses.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Pulses {
    /// Pulses per second.
    pub rate: f64,
    /// How much weaker the last pulse is than the first, in [0, 1).
    #[serde(default)]
    pub decay: f64,
}

/// How much repeated takes differ (see the table's header).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Variation {
    pub timing: f64,
    pub peak: f64,
    pub delay: f64,
    pub rate: f64,
    pub pulse_peak: f64,
}

/// A type's overrides of the table's [`Variation`].
#[derive(Debug, Clone, Copy, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct VariationOverride {
    timing: Option<f64>,
    peak: Option<f64>,
    delay: Option<f64>,
    rate: Option<f64>,
    pulse_peak: Option<f64>,
}

impl VariationOverride {
    fn over(self, base: Variation) -> Variation {
        Variation {
            timing: self.timing.unwrap_or(base.timing),
            peak: self.peak.unwrap_or(base.peak),
            delay: self.delay.unwrap_or(base.delay),
            rate: self.rate.unwrap_or(base.rate),
            pulse_peak: self.pulse_peak.unwrap_or(base.pulse_peak),
        }
    }
}

fn both() -> Laterality {
    Laterality::Both
}

/// One AU of a type.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AuTrack {
    pub au: AuCode,
    #[serde(default = "both")]
    pub side: Laterality,
    /// Intensity at the apex, in [0, 1].
    pub peak: f64,
    /// Seconds after the type's onset starts.
    #[serde(default)]
    pub delay: f64,
    /// How deep the laugh pulses modulate this track, in [0, 1].
    #[serde(default)]
    pub pulse: f64,
}

/// The shoulders of a laugh (not an AU: the body's own channel, see
/// [`crate::engine::timeline::Timeline::shoulders`]).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodyTrack {
    /// Lift at the apex, in [0, 1] (1 = a full shrug).
    pub peak: f64,
    /// How deep the laugh pulses shake it, in [0, 1].
    #[serde(default)]
    pub pulse: f64,
}

/// One laugh or smile type.
#[derive(Debug, Clone, PartialEq)]
pub struct LaughType {
    pub id: String,
    pub name: String,
    /// Its number in the seed's Fig 1.
    pub figure: u32,
    pub kind: Kind,
    pub description: String,
    pub envelope: Envelope,
    pub pulses: Option<Pulses>,
    pub variation: Variation,
    pub tracks: Vec<AuTrack>,
    /// The shoulders' rise and shake (laughs); `None`: the body stays at rest.
    pub shoulders: Option<BodyTrack>,
}

/// The types in the table's order.
#[derive(Debug, Clone, PartialEq)]
pub struct LaughTable {
    types: Vec<LaughType>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TableFile {
    variation: Variation,
    #[serde(rename = "type")]
    types: Vec<RawType>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawType {
    id: String,
    figure: u32,
    kind: Kind,
    description: String,
    envelope: Envelope,
    pulses: Option<Pulses>,
    #[serde(default)]
    variation: VariationOverride,
    tracks: Vec<AuTrack>,
    #[serde(default)]
    shoulders: Option<BodyTrack>,
}

impl LaughTable {
    /// The thirteen types of seed 004 shipped with facslab.
    pub fn built_in() -> &'static LaughTable {
        static TABLE: std::sync::OnceLock<LaughTable> = std::sync::OnceLock::new();
        TABLE.get_or_init(|| LaughTable::from_toml(BUILT_IN, Catalog::built_in()).expect("the built-in laugh-type table is valid"))
    }

    /// Reads and checks a table.
    pub fn from_toml(text: &str, catalog: &Catalog) -> Result<LaughTable, TypesError> {
        let file: TableFile = toml::from_str(text).map_err(|e| TypesError::Toml(e.to_string()))?;
        let mut types: Vec<LaughType> = Vec::with_capacity(file.types.len());
        for raw in file.types {
            let mut laugh = LaughType {
                variation: raw.variation.over(file.variation),
                id: raw.id,
                name: String::new(),
                figure: raw.figure,
                kind: raw.kind,
                description: raw.description,
                envelope: raw.envelope,
                pulses: raw.pulses,
                tracks: raw.tracks,
                shoulders: raw.shoulders,
            };
            laugh.validate(catalog)?;
            laugh.name = type_name(&laugh.id)?;
            if types.iter().any(|t| t.id == laugh.id) {
                return Err(TypesError::Duplicate(laugh.id));
            }
            types.push(laugh);
        }
        Ok(LaughTable { types })
    }

    /// The type with this id.
    pub fn get(&self, id: &str) -> Option<&LaughType> {
        self.types.iter().find(|t| t.id == id)
    }

    pub fn iter(&self) -> impl Iterator<Item = &LaughType> {
        self.types.iter()
    }

    pub fn len(&self) -> usize {
        self.types.len()
    }

    pub fn is_empty(&self) -> bool {
        self.types.is_empty()
    }

    /// The ids, in order (for messages).
    pub fn ids(&self) -> Vec<&str> {
        self.types.iter().map(|t| t.id.as_str()).collect()
    }
}

/// A type's name: its label's in the `laughs` label set, where raters read it (declared once).
fn type_name(id: &str) -> Result<String, TypesError> {
    let set = crate::study::labels::LabelSet::named("laughs").ok_or_else(|| TypesError::NotALabel(id.to_string()))?;
    set.label(id).map(|l| l.name.clone()).ok_or_else(|| TypesError::NotALabel(id.to_string()))
}

fn is_snake_case(id: &str) -> bool {
    (1..=40).contains(&id.len())
        && id.bytes().all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'_')
        && id.as_bytes()[0].is_ascii_lowercase()
}

impl LaughType {
    fn validate(&self, catalog: &Catalog) -> Result<(), TypesError> {
        if !is_snake_case(&self.id) {
            return Err(TypesError::Id(self.id.chars().take(40).collect()));
        }
        let e = self.envelope;
        let phases = [("envelope.lead", e.lead), ("envelope.apex", e.apex), ("envelope.tail", e.tail)];
        for (field, value) in phases {
            self.check(field, value, value.is_finite() && (0.0..=20.0).contains(&value), "in [0, 20] seconds")?;
        }
        for (field, value) in [("envelope.onset", e.onset), ("envelope.offset", e.offset)] {
            self.check(field, value, value.is_finite() && value > 0.0 && value <= 20.0, "in (0, 20] seconds")?;
        }
        self.validate_kind()?;
        let v = self.variation;
        for (field, value) in [("variation.timing", v.timing), ("variation.peak", v.peak), ("variation.rate", v.rate), ("variation.pulse_peak", v.pulse_peak)] {
            self.check(field, value, (0.0..=0.4).contains(&value), "in [0, 0.4]")?;
        }
        self.check("variation.delay", v.delay, (0.0..=0.5).contains(&v.delay), "in [0, 0.5] seconds")?;
        if let Some(s) = self.shoulders {
            self.check("shoulders.peak", s.peak, (0.0..=1.0).contains(&s.peak), "in [0, 1]")?;
            self.check("shoulders.pulse", s.pulse, (0.0..=1.0).contains(&s.pulse), "in [0, 1]")?;
        }
        self.validate_tracks(catalog)
    }

    fn check(&self, field: &str, value: f64, ok: bool, range: &'static str) -> Result<(), TypesError> {
        if ok {
            return Ok(());
        }
        Err(TypesError::Range { id: self.id.clone(), field: field.to_string(), value, range })
    }

    fn validate_kind(&self) -> Result<(), TypesError> {
        let id = self.id.clone();
        match (self.kind, self.pulses) {
            (Kind::Laugh, None) => Err(TypesError::Kind { id, kind: "laugh", rule: "needs pulses" }),
            (Kind::Smile, Some(_)) => Err(TypesError::Kind { id, kind: "smile", rule: "has no pulses" }),
            (Kind::Smile, None) => Ok(()),
            (Kind::Laugh, Some(p)) => {
                self.check("pulses.rate", p.rate, PULSE_RATES.contains(&p.rate), "in [1, 10] Hz")?;
                self.check("pulses.decay", p.decay, (0.0..1.0).contains(&p.decay), "in [0, 1)")
            }
        }
    }

    fn validate_tracks(&self, catalog: &Catalog) -> Result<(), TypesError> {
        if self.tracks.is_empty() {
            return Err(TypesError::NoTracks { id: self.id.clone() });
        }
        for (i, track) in self.tracks.iter().enumerate() {
            let (id, au) = (self.id.clone(), track.au.0);
            let unit = catalog.get(track.au).ok_or_else(|| TypesError::UnknownAu { id: id.clone(), au })?;
            if track.side != Laterality::Both && !unit.unilateral {
                return Err(TypesError::NotUnilateral { id, au });
            }
            let overlaps = |other: &AuTrack| other.au == track.au && (other.side == track.side || other.side == Laterality::Both || track.side == Laterality::Both);
            if self.tracks[..i].iter().any(overlaps) {
                return Err(TypesError::DuplicateTrack { id, au });
            }
            let field = |name: &str| format!("AU {au} {name}");
            self.check(&field("peak"), track.peak, (0.0..=1.0).contains(&track.peak), "in [0, 1]")?;
            self.check(&field("pulse"), track.pulse, (0.0..=1.0).contains(&track.pulse), "in [0, 1]")?;
            self.check(&field("delay"), track.delay, (0.0..=5.0).contains(&track.delay), "in [0, 5] seconds")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The laugh table says how each type is performed, the `laughs` label set
    /// (stimuli/labels/laughs.toml) what raters read; the table takes its names from the set, and
    /// lists the set's labels in the set's order.
    #[test]
    fn the_laughs_label_set_names_the_same_types_in_the_same_order() {
        let set = crate::study::labels::LabelSet::named("laughs").expect("the laughs label set is declared");
        let labels: Vec<(String, String)> =
            set.labels().iter().filter_map(|id| set.label(id)).map(|l| (l.id.clone(), l.name.clone())).collect();
        let types: Vec<(String, String)> = LaughTable::built_in().iter().map(|t| (t.id.clone(), t.name.clone())).collect();
        assert_eq!(labels, types);
    }

    #[test]
    fn the_built_in_table_has_the_thirteen_types_in_the_seeds_order() {
        let table = LaughTable::built_in();
        let ids = table.ids();
        assert_eq!(
            ids,
            [
                "uproarious_laughter", "laughter", "open_mouthed_smile", "closed_mouth_smile", "stifled_smile", "melancholy_smile",
                "eager_smile", "ingratiating_smile", "sly_smile", "debauched_smile", "abashed_smile", "false_smile", "false_laughter",
            ]
        );
        for (n, laugh) in table.iter().enumerate() {
            assert_eq!(laugh.figure as usize, n + 1, "{}", laugh.id);
            assert!(laugh.description.len() > 60, "{} has a description", laugh.id);
        }
        // The false smile lacks the cheek raiser the closed-mouth smile has (Duchenne's marker).
        let has = |id: &str, au: u16| table.get(id).unwrap().tracks.iter().any(|t| t.au == AuCode(au));
        assert!(has("closed_mouth_smile", 6) && !has("false_smile", 6));
        assert!(has("uproarious_laughter", 27) && !has("stifled_smile", 25));
    }

    #[test]
    fn bad_tables_name_the_type() {
        let catalog = Catalog::built_in();
        let good = "[variation]\ntiming = 0.1\npeak = 0.1\ndelay = 0.0\nrate = 0.1\npulse_peak = 0.1\n\n[[type]]\nid = \"sly_smile\"\nfigure = 1\nkind = \"smile\"\ndescription = \"d\"\nenvelope = { lead = 0.2, onset = 0.5, apex = 1.0, offset = 0.5, tail = 0.2 }\ntracks = [{ au = 12, peak = 0.8 }]\n";
        assert_eq!(LaughTable::from_toml(good, catalog).unwrap().len(), 1);
        let bad = |from: &str, to: &str| LaughTable::from_toml(&good.replace(from, to), catalog).unwrap_err().to_string();
        assert_eq!(bad("au = 12,", "au = 3,"), "type \"sly_smile\": AU 3 is not in the catalog");
        assert_eq!(bad("peak = 0.8", "peak = 1.5"), "type \"sly_smile\": AU 12 peak is 1.5; it must be in [0, 1]");
        assert_eq!(bad("kind = \"smile\"", "kind = \"laugh\""), "type \"sly_smile\": a laugh needs pulses");
        assert_eq!(bad("{ au = 12, peak = 0.8 }", "{ au = 12, peak = 0.8 }, { au = 12, side = \"left\", peak = 0.2 }"), "type \"sly_smile\": AU 12 appears twice on overlapping sides");
        assert_eq!(bad("{ au = 12, peak = 0.8 }", "{ au = 25, side = \"left\", peak = 0.2 }"), "type \"sly_smile\": AU 25 cannot be shown on one side only");
        assert_eq!(bad("id = \"sly_smile\"", "id = \"Big Grin\""), "type \"Big Grin\": an id is snake_case (a-z, 0-9, _), 1-40 characters");
        assert_eq!(bad("onset = 0.5", "onset = 0.0"), "type \"sly_smile\": envelope.onset is 0; it must be in (0, 20] seconds");
        assert!(bad("figure = 1", "figure = -1").starts_with("the laugh-type table is not valid TOML"));
        assert_eq!(bad("id = \"sly_smile\"", "id = \"grin\""), "type \"grin\" is not a label of the `laughs` label set (stimuli/labels/laughs.toml), which names the types");
        assert_eq!(LaughTable::from_toml(good, catalog).unwrap().get("sly_smile").unwrap().name, "Sly smile", "the name is the label set's");
    }
}
