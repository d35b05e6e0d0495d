//! Label sets as data: the answers a forced-choice study offers and the labels stimuli portray.
//!
//! In: a label-set TOML text (the edge reads the file; this module does no I/O) (`id`, `name`, `none`, `report_order`, then one `[[label]]` per
//! label with `id`, `name` and `description`); the built-in ones are `stimuli/labels/*.toml`
//! (the EmFACS emotions, the 13 laugh and smile types), compiled in. Out: a [`LabelSet`], a
//! cheap handle every consumer reads (stimulus manifests, set specs, study designs, the trial
//! page, the response reader, the report), and the qualified label a manifest's `emotion`
//! column carries ([`Qualified`]: `laughs:sly_smile`; a bare label means EmFACS, so manifests
//! written before label sets existed read as before).
//!
//! **Invariants:** a set's label ids are unique, non-empty, of `a-z0-9_-`, and never `none`
//! (the "none of these" answer the set may add); a set id names one table for the life of the
//! process: [`LabelSet::register`] refuses a different table under a taken id
//! (`label_sets_are_declared_once`).

use std::sync::{Mutex, OnceLock};

use serde::Deserialize;

/// The set a bare label (no `set:` prefix) belongs to.
pub const DEFAULT_SET: &str = "emfacs";

/// The answer a set with `none = true` offers after its labels.
pub const NONE: &str = "none";

/// The label sets shipped with facslab: (file name, TOML text).
pub const BUILT_IN: [(&str, &str); 2] = [
    ("emfacs.toml", include_str!("../../stimuli/labels/emfacs.toml")),
    ("laughs.toml", include_str!("../../stimuli/labels/laughs.toml")),
];

/// A label-set file that cannot be used, with the file and what is wrong.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LabelError {
    #[error("label set {file}: {message}")]
    Invalid { file: String, message: String },
    #[error("\"{0}\" is not a declared label set (one of {1})")]
    Unknown(String, String),
}

/// One label: its id (what files store), its name (what people read) and its description.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Label {
    pub id: String,
    pub name: String,
    #[serde(default)]
    pub description: String,
}

/// The order reports list a set's labels in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum ReportOrder {
    /// As the file declares them.
    #[default]
    Declared,
    /// Alphabetically, a label called `neutral` last (HapFACS's tables).
    Alphabetical,
}

/// A declared label set.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LabelTable {
    pub id: String,
    pub name: String,
    /// Whether forms offer "none of these" after the labels.
    #[serde(default)]
    pub none: bool,
    #[serde(default)]
    pub report_order: ReportOrder,
    #[serde(rename = "label")]
    pub labels: Vec<Label>,
}

fn invalid(file: &str, message: impl Into<String>) -> LabelError {
    LabelError::Invalid { file: file.to_string(), message: message.into() }
}

fn is_id(text: &str) -> bool {
    !text.is_empty() && text.len() <= 64 && text.bytes().all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'_' || b == b'-')
}

impl LabelTable {
    /// Parses and checks a label-set file's text (`file` names it in errors).
    pub fn from_toml(file: &str, text: &str) -> Result<LabelTable, LabelError> {
        let table: LabelTable = toml::from_str(text).map_err(|e| invalid(file, e.message()))?;
        if !is_id(&table.id) {
            return Err(invalid(file, format!("id \"{}\" must be 1-64 characters of a-z, 0-9, '_' or '-'", crate::study::excerpt(&table.id, 64))));
        }
        if table.labels.is_empty() {
            return Err(invalid(file, "declares no [[label]]"));
        }
        for (i, label) in table.labels.iter().enumerate() {
            let at = format!("label[{}]", i + 1);
            if !is_id(&label.id) || label.id == NONE {
                return Err(invalid(file, format!("{at}: id \"{}\" must be 1-64 characters of a-z, 0-9, '_' or '-', and not \"{NONE}\"", crate::study::excerpt(&label.id, 64))));
            }
            if table.labels[..i].iter().any(|l| l.id == label.id) {
                return Err(invalid(file, format!("{at}: id \"{}\" is declared twice", label.id)));
            }
            if label.name.trim().is_empty() {
                return Err(invalid(file, format!("{at} ({}): name must not be empty", label.id)));
            }
        }
        Ok(table)
    }
}

/// A table with the answers forms offer, computed once.
#[derive(Debug)]
struct Declared {
    table: LabelTable,
    /// The label ids, then `none` when the set offers it.
    answers: Vec<String>,
}

impl Declared {
    fn new(table: LabelTable) -> Declared {
        let answers = table.labels.iter().map(|l| l.id.clone()).chain(table.none.then(|| NONE.to_string())).collect();
        Declared { table, answers }
    }
}

/// A handle on a declared label set (built in or registered from a file).
#[derive(Debug, Clone, Copy)]
pub struct LabelSet(&'static Declared);

impl PartialEq for LabelSet {
    fn eq(&self, other: &LabelSet) -> bool {
        self.0.table.id == other.0.table.id
    }
}

impl Eq for LabelSet {}

fn built_in_sets() -> &'static [Declared] {
    static SETS: OnceLock<Vec<Declared>> = OnceLock::new();
    SETS.get_or_init(|| BUILT_IN.iter().map(|(file, text)| Declared::new(LabelTable::from_toml(file, text).expect("the built-in label sets are valid"))).collect())
}

fn registered() -> std::sync::MutexGuard<'static, Vec<&'static Declared>> {
    static USER: Mutex<Vec<&'static Declared>> = Mutex::new(Vec::new());
    USER.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

impl LabelSet {
    /// The EmFACS emotions: the set of bare labels and of studies that name none.
    pub fn emfacs() -> LabelSet {
        LabelSet::named(DEFAULT_SET).expect("the EmFACS label set is built in")
    }

    /// The set declared under `id`, built in or registered.
    pub fn named(id: &str) -> Option<LabelSet> {
        if let Some(set) = built_in_sets().iter().find(|d| d.table.id == id) {
            return Some(LabelSet(set));
        }
        registered().iter().find(|d| d.table.id == id).map(|d| LabelSet(d))
    }

    /// The set `id`, or an error listing the declared ones.
    pub fn find(id: &str) -> Result<LabelSet, LabelError> {
        LabelSet::named(id).ok_or_else(|| LabelError::Unknown(crate::study::excerpt(id, 64), LabelSet::ids().join(", ")))
    }

    /// Makes a user's table known for the rest of the process (a table is small and a process
    /// registers a handful, so it is kept for good). The same table twice is one set.
    pub fn register(table: LabelTable) -> Result<LabelSet, LabelError> {
        if let Some(existing) = LabelSet::named(&table.id) {
            return if existing.0.table == table { Ok(existing) } else { Err(invalid(&table.id, "another label set with this id is already declared")) };
        }
        let leaked: &'static Declared = Box::leak(Box::new(Declared::new(table)));
        registered().push(leaked);
        Ok(LabelSet(leaked))
    }

    /// The ids of every declared set, built-in ones first.
    pub fn ids() -> Vec<String> {
        built_in_sets().iter().map(|d| d.table.id.clone()).chain(registered().iter().map(|d| d.table.id.clone())).collect()
    }

    /// Whether this is one of the sets shipped with facslab ([`BUILT_IN`]).
    pub fn is_built_in(self) -> bool {
        built_in_sets().iter().any(|d| std::ptr::eq(d, self.0))
    }

    pub fn id(self) -> &'static str {
        &self.0.table.id
    }

    pub fn table(self) -> &'static LabelTable {
        &self.0.table
    }

    /// The answer labels, in the order forms show them: the declared ids, then `none` when the
    /// set offers it.
    pub fn labels(self) -> &'static [String] {
        &self.0.answers
    }

    /// The index of `label` among [`LabelSet::labels`], if it is one of the set's answers.
    pub fn position(self, label: &str) -> Option<usize> {
        self.labels().iter().position(|l| l == label)
    }

    /// The declared label `id` (not `none`).
    pub fn label(self, id: &str) -> Option<&'static Label> {
        self.0.table.labels.iter().find(|l| l.id == id)
    }

    /// The declared labels in the order reports list them.
    pub fn report_order(self) -> Vec<String> {
        let mut ids: Vec<String> = self.0.table.labels.iter().map(|l| l.id.clone()).collect();
        if self.0.table.report_order == ReportOrder::Alphabetical {
            ids.sort_by_key(|id| (id == "neutral", id.clone()));
        }
        ids
    }

    /// How forms and messages call an answer: the label's name, or "None of these".
    pub fn display(self, answer: &str) -> String {
        match self.label(answer) {
            Some(label) => label.name.clone(),
            None if answer == NONE => "None of these".to_string(),
            None => answer.to_string(),
        }
    }
}

/// A label as a manifest stores it: `set:label`, or a bare EmFACS label.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Qualified<'a> {
    pub set: &'a str,
    pub label: &'a str,
}

impl<'a> Qualified<'a> {
    /// Splits a manifest's label (`laughs:sly_smile`; `happiness` is `emfacs:happiness`).
    pub fn split(text: &'a str) -> Qualified<'a> {
        match text.split_once(':') {
            Some((set, label)) => Qualified { set, label },
            None => Qualified { set: DEFAULT_SET, label: text },
        }
    }

    /// The manifest's form: bare for EmFACS (as every manifest before label sets), else `set:label`.
    pub fn text(set: &str, label: &str) -> String {
        if set == DEFAULT_SET { label.to_string() } else { format!("{set}:{label}") }
    }

    /// The declared set and label this names, or what is wrong with it.
    pub fn resolve(self) -> Result<(LabelSet, &'static Label), String> {
        let set = LabelSet::find(self.set).map_err(|e| e.to_string())?;
        let label = set.label(self.label).ok_or_else(|| format!("\"{}\" is not a label of the {} label set", crate::study::excerpt(self.label, 64), set.id()))?;
        Ok((set, label))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn emfacs_labels_follow_the_emotion_table() {
        let table = crate::facs::EmotionTable::built_in();
        let declared: Vec<&str> = LabelSet::emfacs().table().labels.iter().map(|l| l.id.as_str()).collect();
        let emotions: Vec<&str> = table.iter().map(|e| e.label.as_str()).collect();
        assert_eq!(declared, emotions);
        assert_eq!(LabelSet::emfacs().labels().last().map(String::as_str), Some(NONE));
        let order = LabelSet::emfacs().report_order();
        assert_eq!(order.first().map(String::as_str), Some("anger"));
        assert_eq!(order.last().map(String::as_str), Some("neutral"));
    }

    #[test]
    fn the_laugh_set_declares_the_seeds_thirteen_types() {
        let laughs = LabelSet::find("laughs").unwrap();
        assert_eq!(laughs.table().labels.len(), 13);
        assert_eq!(laughs.report_order()[0], "uproarious_laughter");
        assert_eq!(laughs.report_order()[12], "false_laughter");
        assert!(laughs.table().labels.iter().all(|l| l.description.len() > 40), "every type has a context description");
        assert_eq!(laughs.display("sly_smile"), "Sly smile");
        assert_eq!(laughs.display(NONE), "None of these");
    }

    #[test]
    fn qualified_labels_name_their_set() {
        assert_eq!(Qualified::split("happiness"), Qualified { set: "emfacs", label: "happiness" });
        assert_eq!(Qualified::split("laughs:sly_smile"), Qualified { set: "laughs", label: "sly_smile" });
        assert_eq!(Qualified::text("emfacs", "fear"), "fear");
        assert_eq!(Qualified::text("laughs", "laughter"), "laughs:laughter");
        assert_eq!(Qualified::split("laughs:laughter").resolve().unwrap().1.name, "Laughter");
        assert!(Qualified::split("joy").resolve().unwrap_err().contains("emfacs"));
        assert!(Qualified::split("moods:joy").resolve().unwrap_err().contains("not a declared label set"));
    }

    #[test]
    fn label_sets_are_declared_once() {
        let text = "id = \"colours\"\nname = \"Colours\"\n[[label]]\nid = \"red\"\nname = \"Red\"\n[[label]]\nid = \"blue\"\nname = \"Blue\"\n";
        let set = LabelSet::register(LabelTable::from_toml("colours.toml", text).unwrap()).unwrap();
        assert_eq!(set.labels(), ["red", "blue"]);
        assert_eq!(LabelSet::named("colours"), Some(set));
        assert_eq!(LabelSet::register(LabelTable::from_toml("c.toml", text).unwrap()), Ok(set), "the same table again is the same set");
        let other = text.replace("Blue", "Azure");
        assert!(LabelSet::register(LabelTable::from_toml("c.toml", &other).unwrap()).is_err());
        let emfacs = BUILT_IN[0].1.replace("Happiness", "Joy");
        assert!(LabelSet::register(LabelTable::from_toml("e.toml", &emfacs).unwrap()).is_err(), "a built-in id is taken");
    }

    #[test]
    fn bad_label_files_name_the_file_and_label() {
        let cases = [
            ("id = \"x\"\nname = \"X\"\n", "label"),
            ("id = \"X Y\"\nname = \"X\"\n[[label]]\nid = \"a\"\nname = \"A\"\n", "id \"X Y\""),
            ("id = \"x\"\nname = \"X\"\n[[label]]\nid = \"none\"\nname = \"A\"\n", "label[1]"),
            ("id = \"x\"\nname = \"X\"\n[[label]]\nid = \"a\"\nname = \"A\"\n[[label]]\nid = \"a\"\nname = \"B\"\n", "label[2]: id \"a\" is declared twice"),
            ("id = \"x\"\nname = \"X\"\n[[label]]\nid = \"a\"\nname = \" \"\n", "name must not be empty"),
        ];
        for (text, expected) in cases {
            let e = LabelTable::from_toml("mine.toml", text).unwrap_err().to_string();
            assert!(e.starts_with("label set mine.toml: ") && e.contains(expected), "{e}");
        }
    }
}
