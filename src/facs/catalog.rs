//! The catalog of Action Units: number, name, face region, whether a side can be given, and the
//! appearance changes FACS lists. Read from TOML (`stimuli/facs/action_units.toml` is built in).

use std::collections::BTreeMap;
use std::fmt;

use serde::Deserialize;

use super::notation::{self, Expression, NotationError};

/// A FACS Action Unit number (1 = Inner Brow Raiser, … 66 = Cross-eye).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Deserialize, serde::Serialize)]
#[serde(transparent)]
pub struct AuCode(pub u16);

impl fmt::Display for AuCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

impl AuCode {
    /// The column name used by per-frame ground truth (`AU01`, `AU12`, the OpenFace convention).
    pub fn column(self) -> String {
        format!("AU{:02}", self.0)
    }
}

/// Where on the face an AU acts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Region {
    Upper,
    Lower,
    HeadEye,
}

impl Region {
    pub fn label(self) -> &'static str {
        match self {
            Region::Upper => "upper face",
            Region::Lower => "lower face",
            Region::HeadEye => "head and eye positions",
        }
    }
}

/// What kind of change an AU code describes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum AuKind {
    /// A muscle action.
    Action,
    /// A held head or eye position.
    Position,
    /// A head movement that oscillates in video (a still shows its extreme).
    Movement,
}

/// One catalog entry.
#[derive(Debug, Clone, Deserialize, serde::Serialize)]
pub struct ActionUnit {
    pub code: AuCode,
    pub name: String,
    pub region: Region,
    /// True when the AU may be shown on one side only (`L12`, `R14`).
    pub unilateral: bool,
    /// True for the 49 AUs HapFACS 3.0 controls.
    pub hapfacs: bool,
    pub kind: AuKind,
    /// The appearance changes the FACS manual lists, in short.
    pub appearance: String,
}

/// Problems with a catalog file.
#[derive(Debug, thiserror::Error)]
pub enum CatalogError {
    #[error("the Action Unit catalog is not valid TOML: {0}")]
    Toml(#[from] toml::de::Error),
    #[error("AU {0} appears twice in the catalog")]
    Duplicate(AuCode),
    #[error("AU code 0 is reserved for the neutral face")]
    ZeroCode,
}

#[derive(Deserialize)]
struct CatalogFile {
    action_unit: Vec<ActionUnit>,
}

/// The Action Units facslab knows, ordered by code.
#[derive(Debug, Clone)]
pub struct Catalog {
    units: BTreeMap<AuCode, ActionUnit>,
}

const BUILT_IN: &str = include_str!("../../stimuli/facs/action_units.toml");

impl Catalog {
    /// The catalog shipped with facslab (`stimuli/facs/action_units.toml`).
    pub fn built_in() -> &'static Catalog {
        static CATALOG: std::sync::OnceLock<Catalog> = std::sync::OnceLock::new();
        CATALOG.get_or_init(|| Catalog::from_toml(BUILT_IN).expect("the built-in catalog is valid"))
    }

    /// Reads a catalog from TOML text.
    pub fn from_toml(text: &str) -> Result<Catalog, CatalogError> {
        let file: CatalogFile = toml::from_str(text)?;
        let mut units = BTreeMap::new();
        for unit in file.action_unit {
            if unit.code.0 == 0 {
                return Err(CatalogError::ZeroCode);
            }
            let code = unit.code;
            if units.insert(code, unit).is_some() {
                return Err(CatalogError::Duplicate(code));
            }
        }
        Ok(Catalog { units })
    }

    pub fn get(&self, code: AuCode) -> Option<&ActionUnit> {
        self.units.get(&code)
    }

    /// Every AU, ordered by code.
    pub fn iter(&self) -> impl Iterator<Item = &ActionUnit> {
        self.units.values()
    }

    pub fn len(&self) -> usize {
        self.units.len()
    }

    pub fn is_empty(&self) -> bool {
        self.units.is_empty()
    }

    /// Parses FACS notation and checks every AU and side against this catalog.
    pub fn parse(&self, text: &str) -> Result<Expression, NotationError> {
        notation::parse(text, self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn count(pred: impl Fn(&ActionUnit) -> bool) -> usize {
        Catalog::built_in().iter().filter(|u| pred(u)).count()
    }

    #[test]
    fn hapfacs_set_has_49_aus_in_its_three_regions() {
        assert_eq!(count(|u| u.hapfacs), 49);
        assert_eq!(count(|u| u.hapfacs && u.region == Region::Upper), 12);
        assert_eq!(count(|u| u.hapfacs && u.region == Region::Lower), 21);
        assert_eq!(count(|u| u.hapfacs && u.region == Region::HeadEye), 16);
    }

    #[test]
    fn facs_1978_codes_and_head_eye_positions_are_present() {
        let catalog = Catalog::built_in();
        for code in [41, 42, 44, 51, 52, 53, 54, 55, 56, 57, 58, 61, 62, 63, 64, 65, 66] {
            assert!(catalog.get(AuCode(code)).is_some(), "AU {code} missing");
        }
        assert_eq!(catalog.get(AuCode(41)).map(|u| u.name.as_str()), Some("Glabella Lowerer"));
    }

    #[test]
    fn at_least_hapfacs_many_aus_can_be_unilateral() {
        assert!(count(|u| u.unilateral && u.hapfacs) >= 19);
        assert_eq!(count(|u| u.unilateral && u.region == Region::HeadEye), 0);
    }

    #[test]
    fn duplicate_codes_are_refused() {
        let text = "[[action_unit]]\ncode = 1\nname = \"a\"\nregion = \"upper\"\nunilateral = true\nhapfacs = true\nkind = \"action\"\nappearance = \"\"\n";
        let twice = format!("{text}{text}");
        assert!(matches!(Catalog::from_toml(&twice), Err(CatalogError::Duplicate(AuCode(1)))));
    }
}
