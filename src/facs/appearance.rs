//! What each Action Unit looks like: the reference the AU basis is built and reviewed against.
//!
//! In: `stimuli/facs/appearance.toml` (built in) or a user's file of the same form. Out: an
//! [`AppearanceSpec`] with one [`Appearance`] per catalog AU: what moves, the furrows, bulges and
//! shape changes, and what each level A–E shows. The Markdown view of it (`docs/au-appearance.md`)
//! is written from this declaration, never by hand.
//!
//! Invariant: a spec built by [`AppearanceSpec::for_catalog`] has exactly one entry per catalog AU,
//! no entry for an AU outside the catalog, and a non-empty movement and level text for A–E.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use serde::Deserialize;

use super::{AuCode, Catalog, IntensityLevel};

/// The appearance changes of one Action Unit.
#[derive(Debug, Clone, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct Appearance {
    pub code: AuCode,
    /// What moves, where to, and by what it is pulled.
    pub movement: String,
    /// Wrinkles and furrows that appear or deepen.
    pub furrows: Vec<String>,
    /// Skin that bunches or bulges.
    pub bulges: Vec<String>,
    /// Features that narrow, widen, lengthen or flatten.
    pub shape: Vec<String>,
    /// What the face shows at each level.
    pub levels: Levels,
}

/// The evidence at each FACS intensity level.
#[derive(Debug, Clone, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
#[allow(non_snake_case)]
pub struct Levels {
    pub A: String,
    pub B: String,
    pub C: String,
    pub D: String,
    pub E: String,
}

impl Levels {
    /// The text for one level.
    pub fn get(&self, level: IntensityLevel) -> &str {
        match level {
            IntensityLevel::A => &self.A,
            IntensityLevel::B => &self.B,
            IntensityLevel::C => &self.C,
            IntensityLevel::D => &self.D,
            IntensityLevel::E => &self.E,
        }
    }
}

/// Problems with an appearance file, each naming the AU concerned.
#[derive(Debug, thiserror::Error)]
pub enum AppearanceError {
    #[error("the AU appearance file is not valid TOML: {0}")]
    Toml(#[from] toml::de::Error),
    #[error("AU {0} is described twice in the appearance file")]
    Duplicate(AuCode),
    #[error("AU {0} is described in the appearance file but is not in the catalog")]
    NotInCatalog(AuCode),
    #[error("AU {0} is in the catalog but the appearance file does not describe it")]
    Missing(AuCode),
    #[error("AU {code}: `{field}` is empty in the appearance file")]
    Empty { code: AuCode, field: &'static str },
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct AppearanceFile {
    au: Vec<Appearance>,
}

/// One [`Appearance`] per catalog AU, ordered by code.
#[derive(Debug, Clone)]
pub struct AppearanceSpec {
    entries: BTreeMap<AuCode, Appearance>,
}

const BUILT_IN: &str = include_str!("../../stimuli/facs/appearance.toml");

impl AppearanceSpec {
    /// The specification shipped with facslab, checked against the built-in catalog.
    pub fn built_in() -> &'static AppearanceSpec {
        static SPEC: std::sync::OnceLock<AppearanceSpec> = std::sync::OnceLock::new();
        SPEC.get_or_init(|| {
            AppearanceSpec::for_catalog(BUILT_IN, Catalog::built_in()).expect("the built-in AU appearance file is valid")
        })
    }

    /// Reads a specification and checks that it describes exactly the AUs of `catalog`.
    pub fn for_catalog(text: &str, catalog: &Catalog) -> Result<AppearanceSpec, AppearanceError> {
        let file: AppearanceFile = toml::from_str(text)?;
        let mut entries = BTreeMap::new();
        for entry in file.au {
            check_filled(&entry)?;
            let code = entry.code;
            if catalog.get(code).is_none() {
                return Err(AppearanceError::NotInCatalog(code));
            }
            if entries.insert(code, entry).is_some() {
                return Err(AppearanceError::Duplicate(code));
            }
        }
        if let Some(unit) = catalog.iter().find(|u| !entries.contains_key(&u.code)) {
            return Err(AppearanceError::Missing(unit.code));
        }
        Ok(AppearanceSpec { entries })
    }

    pub fn get(&self, code: AuCode) -> Option<&Appearance> {
        self.entries.get(&code)
    }

    /// Every entry, ordered by code.
    pub fn iter(&self) -> impl Iterator<Item = &Appearance> {
        self.entries.values()
    }

    /// The specification as a Markdown document (`docs/au-appearance.md`).
    pub fn to_markdown(&self, catalog: &Catalog) -> String {
        let mut out = String::from(
            "# What each Action Unit looks like\n\n\
             Written from `stimuli/facs/appearance.toml` (`facslab catalog --appearance` prints the same);\n\
             the AU basis is built and reviewed against it. Levels: A trace, B slight, C marked or\n\
             pronounced, D severe or extreme, E maximum.\n",
        );
        for entry in self.iter() {
            let name = catalog.get(entry.code).map_or("", |u| u.name.as_str());
            let _ = write!(out, "\n## AU{} {}\n\n{}.\n\n", entry.code, name, capitalised(&entry.movement));
            for (label, items) in [("Furrows", &entry.furrows), ("Bulges", &entry.bulges), ("Shape", &entry.shape)] {
                if !items.is_empty() {
                    let _ = writeln!(out, "- **{label}**: {}.", items.join("; "));
                }
            }
            out.push_str("\n| level | what shows |\n|---|---|\n");
            for level in IntensityLevel::ALL {
                let _ = writeln!(out, "| {} | {} |", level.letter(), entry.levels.get(level));
            }
        }
        out
    }
}

fn check_filled(entry: &Appearance) -> Result<(), AppearanceError> {
    let empty = |field| Err(AppearanceError::Empty { code: entry.code, field });
    if entry.movement.trim().is_empty() {
        return empty("movement");
    }
    for (level, field) in IntensityLevel::ALL.into_iter().zip(["levels.A", "levels.B", "levels.C", "levels.D", "levels.E"]) {
        if entry.levels.get(level).trim().is_empty() {
            return empty(field);
        }
    }
    Ok(())
}

fn capitalised(text: &str) -> String {
    let mut chars = text.chars();
    chars.next().map_or_else(String::new, |first| first.to_uppercase().chain(chars).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_built_in_spec_describes_every_catalog_au_once() {
        let spec = AppearanceSpec::built_in();
        let catalog = Catalog::built_in();
        assert_eq!(spec.iter().count(), catalog.len());
        for unit in catalog.iter() {
            assert!(spec.get(unit.code).is_some(), "AU{} has no appearance entry", unit.code);
        }
    }

    #[test]
    fn a_missing_au_is_named() {
        let text = BUILT_IN.replacen("code = 6\n", "code = 1006\n", 1);
        let err = AppearanceSpec::for_catalog(&text, Catalog::built_in()).unwrap_err();
        assert!(matches!(err, AppearanceError::NotInCatalog(AuCode(1006))), "{err}");
        let cut = BUILT_IN.rsplit_once("\n[[au]]\n").map(|(head, _)| head).unwrap_or_default();
        let err = AppearanceSpec::for_catalog(cut, Catalog::built_in()).unwrap_err();
        assert_eq!(err.to_string(), "AU 66 is in the catalog but the appearance file does not describe it");
    }

    #[test]
    fn an_empty_level_is_refused_with_its_field() {
        let text = BUILT_IN.replacen(
            "levels.B = \"inner brows slightly raised, brows start to slant; faint central forehead lines on a smooth forehead\"",
            "levels.B = \"  \"",
            1,
        );
        assert_ne!(text, BUILT_IN, "the test edits the AU1 level B text");
        let err = AppearanceSpec::for_catalog(&text, Catalog::built_in()).unwrap_err();
        assert_eq!(err.to_string(), "AU 1: `levels.B` is empty in the appearance file");
    }

    #[test]
    fn an_unknown_field_is_refused() {
        let text = BUILT_IN.replacen("furrows = [", "furrow = [", 1);
        assert!(AppearanceSpec::for_catalog(&text, Catalog::built_in()).is_err());
    }

    #[test]
    fn the_docs_page_is_written_from_the_spec() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/au-appearance.md");
        let expected = AppearanceSpec::built_in().to_markdown(Catalog::built_in());
        if std::env::var_os("FACSLAB_UPDATE_DOCS").is_some() {
            std::fs::write(path, &expected).expect("write docs/au-appearance.md");
        }
        let actual = std::fs::read_to_string(path).unwrap_or_default();
        assert!(actual == expected, "docs/au-appearance.md is out of date: regenerate with FACSLAB_UPDATE_DOCS=1 cargo test --lib facs::appearance");
    }
}
