//! Emotion tables: EmFACS prototypes (HapFACS Table 5) and the CPT appraisal checks (Table 15).
//!
//! Both are data (`stimuli/facs/emfacs.toml`, `stimuli/facs/cpt.toml`), read from TOML and
//! validated against the catalog when loaded, so a typo in a user's table is reported once,
//! with the entry that holds it, before anything is rendered.

use serde::Deserialize;

use super::catalog::Catalog;
use super::notation::{Expression, NotationError};

/// Problems with an emotion or appraisal table.
#[derive(Debug, thiserror::Error)]
pub enum EmotionError {
    #[error("the table is not valid TOML: {0}")]
    Toml(#[from] toml::de::Error),
    #[error("entry \"{entry}\": {source}")]
    Expression { entry: String, source: NotationError },
    #[error("entry \"{0}\" appears twice")]
    Duplicate(String),
}

/// One emotion prototype.
#[derive(Debug, Clone, PartialEq)]
pub struct Emotion {
    pub label: String,
    /// The prototype at 100 %.
    pub expression: Expression,
}

/// The emotions a lay rater chooses from, with their prototypes.
#[derive(Debug, Clone)]
pub struct EmotionTable {
    emotions: Vec<Emotion>,
}

#[derive(Deserialize)]
struct EmotionFile {
    emotion: Vec<RawEntry>,
}

#[derive(Deserialize)]
struct RawEntry {
    label: String,
    expression: String,
}

fn parse_entry(catalog: &Catalog, entry: &str, text: &str) -> Result<Expression, EmotionError> {
    catalog.parse(text).map_err(|source| EmotionError::Expression { entry: entry.to_string(), source })
}

fn refuse_duplicates<'a>(names: impl Iterator<Item = &'a str>) -> Result<(), EmotionError> {
    let mut seen = std::collections::BTreeSet::new();
    for name in names {
        if !seen.insert(name) {
            return Err(EmotionError::Duplicate(name.to_string()));
        }
    }
    Ok(())
}

impl EmotionTable {
    /// The HapFACS Table 5 prototypes shipped with facslab.
    pub fn built_in() -> EmotionTable {
        EmotionTable::from_toml(include_str!("../../stimuli/facs/emfacs.toml"), Catalog::built_in())
            .expect("the built-in EmFACS table is valid")
    }

    pub fn from_toml(text: &str, catalog: &Catalog) -> Result<EmotionTable, EmotionError> {
        let file: EmotionFile = toml::from_str(text)?;
        refuse_duplicates(file.emotion.iter().map(|e| e.label.as_str()))?;
        let emotions = file
            .emotion
            .into_iter()
            .map(|raw| {
                let expression = parse_entry(catalog, &raw.label, &raw.expression)?;
                Ok(Emotion { label: raw.label, expression })
            })
            .collect::<Result<_, EmotionError>>()?;
        Ok(EmotionTable { emotions })
    }

    pub fn iter(&self) -> impl Iterator<Item = &Emotion> {
        self.emotions.iter()
    }

    pub fn get(&self, label: &str) -> Option<&Emotion> {
        self.emotions.iter().find(|e| e.label == label)
    }
}

/// One Sequential Evaluation Check and its AU groups, in time order.
#[derive(Debug, Clone, PartialEq)]
pub struct AppraisalCheck {
    pub name: String,
    pub steps: Vec<Expression>,
}

/// The CPT appraisal table.
#[derive(Debug, Clone)]
pub struct AppraisalTable {
    checks: Vec<AppraisalCheck>,
}

#[derive(Deserialize)]
struct AppraisalFile {
    check: Vec<RawCheck>,
}

#[derive(Deserialize)]
struct RawCheck {
    name: String,
    steps: Vec<String>,
}

impl AppraisalTable {
    /// HapFACS Table 15, shipped with facslab.
    pub fn built_in() -> AppraisalTable {
        AppraisalTable::from_toml(include_str!("../../stimuli/facs/cpt.toml"), Catalog::built_in())
            .expect("the built-in CPT table is valid")
    }

    pub fn from_toml(text: &str, catalog: &Catalog) -> Result<AppraisalTable, EmotionError> {
        let file: AppraisalFile = toml::from_str(text)?;
        refuse_duplicates(file.check.iter().map(|c| c.name.as_str()))?;
        let checks = file
            .check
            .into_iter()
            .map(|raw| {
                let steps = raw.steps.iter().map(|s| parse_entry(catalog, &raw.name, s)).collect::<Result<_, _>>()?;
                Ok(AppraisalCheck { name: raw.name, steps })
            })
            .collect::<Result<_, EmotionError>>()?;
        Ok(AppraisalTable { checks })
    }

    pub fn iter(&self) -> impl Iterator<Item = &AppraisalCheck> {
        self.checks.iter()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_5_prototypes() {
        let table = EmotionTable::built_in();
        let get = |label: &str| table.get(label).unwrap().expression.to_string();
        assert_eq!(table.iter().count(), 10);
        assert_eq!(get("happiness"), "6+12+25");
        assert_eq!(get("anger"), "5+7+9+10+15+17+42");
        assert_eq!(get("contempt"), "12+R14");
        assert_eq!(get("neutral"), "0");
    }

    #[test]
    fn table_15_checks() {
        let table = AppraisalTable::built_in();
        assert_eq!(table.iter().count(), 7);
        let novelty = table.iter().next().unwrap();
        assert_eq!(novelty.steps.iter().map(|s| s.to_string()).collect::<Vec<_>>(), ["1+2+5", "4+7+26+38"]);
    }

    #[test]
    fn a_bad_entry_is_named() {
        let text = "[[emotion]]\nlabel = \"joy\"\nexpression = \"6+120\"\n";
        let err = EmotionTable::from_toml(text, Catalog::built_in()).unwrap_err().to_string();
        assert!(err.contains("\"joy\"") && err.contains("120"), "{err}");
    }
}
