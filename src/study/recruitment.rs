//! Recruitment: where a study's participants come from, and what they are sent back with.
//!
//! In: the `[recruitment]` table of a design: the study's own platform with its codes, and
//! optionally further `[[recruitment.sources]]`, each a platform of its own with the `group`
//! its participants are exported under (HapFACS Exp. 3 recruited local students and
//! Amazon Mechanical Turk workers into one study and compared them; seed 001 §4.2).
//! Out: the validated [`Source`]s, the study's own first; [`source_for`] picks the source of
//! an entry link by the worker parameter it carries (`workerId`, `PROLIFIC_PID`, `id`), else
//! the study's local source, else the study's own.
//!
//! Invariants: no two sources share a platform or a group (so the platform a participation
//! stored names its source); each source has the codes its platform needs; a local source
//! can only be the study's own (a local link carries no parameter to tell it apart).

use serde::Deserialize;

use super::design::{DesignError, fail};

/// Where participants come from, which decides the entry parameters and the completion step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Platform {
    /// Lab or link: no worker id, one is made up.
    #[default]
    Local,
    /// `?PROLIFIC_PID=…&STUDY_ID=…&SESSION_ID=…`; redirect to Prolific with `cc=` code.
    Prolific,
    /// `?workerId=…&assignmentId=…&hitId=…&turkSubmitTo=…`; externalSubmit form.
    Mturk,
    /// `?id=…` (survey code); redirect to the credit-granting URL.
    Sona,
}

impl Platform {
    pub fn as_str(self) -> &'static str {
        match self {
            Platform::Local => "local",
            Platform::Prolific => "prolific",
            Platform::Mturk => "mturk",
            Platform::Sona => "sona",
        }
    }

    /// The query parameter that identifies the worker, if the platform has one.
    pub fn worker_param(self) -> Option<&'static str> {
        match self {
            Platform::Local => None,
            Platform::Prolific => Some("PROLIFIC_PID"),
            Platform::Mturk => Some("workerId"),
            Platform::Sona => Some("id"),
        }
    }

    /// Every entry parameter kept with the participation (for the completion step and audits).
    pub fn entry_params(self) -> &'static [&'static str] {
        match self {
            Platform::Local => &[],
            Platform::Prolific => &["PROLIFIC_PID", "STUDY_ID", "SESSION_ID"],
            Platform::Mturk => &["workerId", "assignmentId", "hitId", "turkSubmitTo"],
            Platform::Sona => &["id"],
        }
    }
}


/// The `[recruitment]` table: the study's own platform and its codes, then further sources.
#[derive(Debug, Clone, PartialEq, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct Recruitment {
    #[serde(default)]
    pub platform: Platform,
    /// Shown at the end and sent to Prolific (`cc=`) or MTurk.
    #[serde(default)]
    pub completion_code: String,
    /// Prolific code for participants screened out by the attention policy.
    #[serde(default)]
    pub screened_out_code: String,
    /// SONA credit URL; `{id}` is replaced by the participant's survey code.
    #[serde(default)]
    pub sona_credit_url: String,
    /// Submit MTurk assignments to the sandbox.
    #[serde(default)]
    pub mturk_sandbox: bool,
    /// Further platforms recruiting into the same study, each exported as its own group.
    #[serde(default)]
    pub sources: Vec<Source>,
}

/// One way into a study: a platform, the group its participants are exported under, and
/// the codes its completion step needs.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Source {
    pub group: String,
    pub platform: Platform,
    #[serde(default)]
    pub completion_code: String,
    #[serde(default)]
    pub screened_out_code: String,
    #[serde(default)]
    pub sona_credit_url: String,
    #[serde(default)]
    pub mturk_sandbox: bool,
}

/// Most sources a study may have (one per platform).
const MAX_SOURCES: usize = 4;

impl Recruitment {
    /// Every source, checked: the study's own (under the design's `group`) first.
    pub fn checked_sources(&self, group: &str) -> Result<Vec<Source>, DesignError> {
        let own = Source {
            group: group.to_string(),
            platform: self.platform,
            completion_code: self.completion_code.clone(),
            screened_out_code: self.screened_out_code.clone(),
            sona_credit_url: self.sona_credit_url.clone(),
            mturk_sandbox: self.mturk_sandbox,
        };
        if self.sources.len() >= MAX_SOURCES {
            return Err(fail("recruitment.sources", format!("{} further sources; a study takes at most {} in all, one per platform", self.sources.len(), MAX_SOURCES)));
        }
        let sources: Vec<Source> = std::iter::once(own).chain(self.sources.iter().cloned()).collect();
        for (i, source) in sources.iter().enumerate() {
            let field = if i == 0 { "recruitment".to_string() } else { format!("recruitment.sources[{i}]") };
            check_source(&field, source, i)?;
            if let Some(earlier) = sources[..i].iter().find(|s| s.platform == source.platform || s.group == source.group) {
                let what = if earlier.platform == source.platform { format!("platform {}", source.platform.as_str()) } else { format!("group \"{}\"", source.group) };
                return Err(fail(field, format!("{what} is used by two sources")));
            }
        }
        Ok(sources)
    }
}

fn check_source(field: &str, s: &Source, index: usize) -> Result<(), DesignError> {
    if index > 0 {
        if s.group.trim().is_empty() || s.group.len() > 64 || s.group.contains([',', '"', '\n']) {
            return Err(fail(format!("{field}.group"), "must be 1-64 characters without commas, quotes or line breaks"));
        }
        if s.platform == Platform::Local {
            return Err(fail(format!("{field}.platform"), "a local source can only be the study's own [recruitment] platform (a local link carries no parameter to tell it apart)"));
        }
    }
    match s.platform {
        Platform::Prolific | Platform::Mturk if s.completion_code.trim().is_empty() => {
            Err(fail(format!("{field}.completion_code"), format!("{} needs a completion code", s.platform.as_str())))
        }
        Platform::Sona if !(s.sona_credit_url.starts_with("https://") && s.sona_credit_url.contains("{id}")) => {
            Err(fail(format!("{field}.sona_credit_url"), "SONA needs an https:// credit URL containing {id}"))
        }
        _ => Ok(()),
    }
}

/// (`sources` is a design's, never empty.) The source an entry link with `params` belongs to: the one whose worker parameter it
/// carries, else the local one, else the study's own (whose check then asks for its
/// parameter).
pub(super) fn source_for(sources: &[Source], has_param: impl Fn(&str) -> bool) -> &Source {
    sources
        .iter()
        .find(|s| s.platform.worker_param().is_some_and(&has_param))
        .or_else(|| sources.iter().find(|s| s.platform == Platform::Local))
        .unwrap_or(&sources[0])
}

/// The source of a participation by the platform it stored (the study's own when none
/// matches, as for participations stored before a source was removed).
pub(super) fn source_of<'a>(sources: &'a [Source], platform: &str) -> &'a Source {
    sources.iter().find(|s| s.platform.as_str() == platform).unwrap_or(&sources[0])
}
