//! Participations: start (balanced assignment), consent, demographics, per-trial saves,
//! withdrawal, exclusion and the reaper that abandons expired reservations.
//!
//! Every change to participations (starts, consent, demographics, saves, withdrawals,
//! exclusions, the reaper) is a [`Request`] stored by [`Db::write`](super::Db): on SQLite the
//! writer task (`super::writer`) runs it inside its batch transaction, on PostgreSQL it runs in a
//! transaction of its own (`super::postgres`); the steps themselves are in `super::steps`.

use std::collections::HashMap;

use super::studies::stored;
use super::writer::{Request, Written};
use super::{Db, DbError, Fields, on_backend, token_sha256};
use crate::stimuli::manifest::StimulusId;
use crate::study::assign::TrialKind;
use crate::study::design::Source;
use crate::study::{Answer, SessionState, StudyDesign};

/// A participation as the pages need it.
#[derive(Debug, Clone)]
pub struct Participation {
    pub id: i64,
    pub study_id: i64,
    pub public_id: String,
    pub worker_id: String,
    /// The platform it came through (which names its recruitment source).
    pub platform: String,
    pub platform_params: String,
    /// The between-subject arm it joined (empty without arms).
    pub arm: String,
    pub state: SessionState,
    pub consented: bool,
    pub has_demographics: bool,
    pub expires_at: i64,
}

/// One trial of a participation.
#[derive(Debug, Clone)]
pub struct TrialRow {
    pub position: i64,
    pub kind: TrialKind,
    pub stimulus_id: StimulusId,
    pub check_index: Option<usize>,
    pub answered: bool,
}

/// What a start request led to.
#[derive(Debug)]
pub enum Started {
    /// A new participation (its secret token, shown once: only its SHA-256 is stored).
    New(String),
    /// This worker already has a participation in this study (the SHA-256 of its token).
    Existing(String),
    /// Every stimulus has its ratings.
    Full,
}

/// What a save did and where the participation stands after it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SaveOutcome {
    pub saved: Saved,
    pub state: SessionState,
    /// Trials still without an answer.
    pub remaining: i64,
}

/// Whether a save stored something.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Saved {
    /// Stored now.
    Stored,
    /// The same idempotency key was stored before: nothing changed.
    Repeated,
}

/// The demographics of HapFACS Table 6.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct Demographics {
    pub age: Option<i64>,
    pub gender: String,
    pub ethnicity: String,
    pub education: String,
}

impl Demographics {
    /// One answer as the long format writes it (empty when not given).
    pub fn text(&self, measure: crate::study::measure::Demographic) -> String {
        use crate::study::measure::Demographic;
        match measure {
            Demographic::Age => self.age.map(|a| a.to_string()).unwrap_or_default(),
            Demographic::Gender => self.gender.clone(),
            Demographic::Ethnicity => self.ethnicity.clone(),
            Demographic::Education => self.education.clone(),
        }
    }
}

pub(crate) fn participation(row: &impl Fields) -> Result<Participation, DbError> {
    let state: String = row.get("state");
    Ok(Participation {
        id: row.get("id"),
        study_id: row.get("study_id"),
        public_id: row.get("public_id"),
        worker_id: row.get("worker_id"),
        platform: row.get("platform"),
        platform_params: row.get("platform_params"),
        arm: row.get("arm"),
        state: SessionState::parse(&state).ok_or_else(|| DbError::Internal(format!("unknown state \"{state}\"")))?,
        consented: row.get::<Option<String>, _>("consent_sha256").is_some(),
        has_demographics: row.get("has_demographics"),
        expires_at: row.get("expires_at"),
    })
}


pub(crate) const BY_TOKEN: &str = "SELECT p.*, EXISTS (SELECT 1 FROM demographics d WHERE d.participant_id = p.id) AS has_demographics FROM participants p WHERE p.token_sha256 = $1";

/// How long a participation may stay reserved without consent (milliseconds): after that it no
/// longer counts toward the balance and the reaper abandons it, whatever the design's
/// reservation time, so starts that never consent cannot hold a study's places for long.
pub const CONSENT_WITHIN_MS: i64 = 10 * 60_000;

impl Db {
    /// Starts a participation for `worker_id` (or finds the one it has): assigns the balanced
    /// share of stimuli and the seeded trial plan (on SQLite stored by the writer task together
    /// with the other writes waiting).
    pub async fn start_participation(&self, study_id: i64, design: &StudyDesign, source: &Source, worker_id: &str, platform_params: &str) -> Result<Started, DbError> {
        let request = StartRequest::new(study_id, design, source, worker_id, platform_params);
        match self.write(Request::Start(request)).await? {
            Written::Started(started) => Ok(started),
            other => Err(other.unexpected()),
        }
    }

    /// The id of the study a participation token belongs to, from memory once seen (a
    /// participation never changes study), so a save needs no read before the writer's.
    pub async fn participation_study(&self, token: &str) -> Result<Option<i64>, DbError> {
        let hash = token_sha256(token);
        let remembered = self.studies_of_tokens.lock().ok().and_then(|mut known| known.get(&hash));
        if remembered.is_some() {
            return Ok(remembered);
        }
        let sql = "SELECT study_id FROM participants WHERE token_sha256 = $1";
        let study: Option<i64> = on_backend!(self, b => sqlx::query_scalar(sql).bind(&hash).fetch_optional(&b.reader).await?);
        if let (Some(study), Ok(mut known)) = (study, self.studies_of_tokens.lock()) {
            known.insert(hash, study);
        }
        Ok(study)
    }

    pub async fn participation(&self, token: &str) -> Result<Option<Participation>, DbError> {
        on_backend!(self, b => sqlx::query(BY_TOKEN).bind(token_sha256(token)).fetch_optional(&b.reader).await?.map(|r| participation(&r)).transpose())
    }

    /// Every trial of a participation, in order, with whether it has a saved answer.
    pub async fn trials(&self, participant: i64) -> Result<Vec<TrialRow>, DbError> {
        let sql = "SELECT t.position, t.kind, t.stimulus_id, t.check_index, r.id IS NOT NULL FROM trials t
             LEFT JOIN responses r ON r.participant_id = t.participant_id AND r.position = t.position
             WHERE t.participant_id = $1 ORDER BY t.position";
        on_backend!(self, b => sqlx::query(sql).bind(participant).fetch_all(&b.reader).await?.iter().map(trial_row).collect())
    }

    /// Records consent (with the consent text's hash): reserved → active.
    pub async fn give_consent(&self, token: &str, consent_sha256: &str) -> Result<(), DbError> {
        self.record(Request::Consent { token: token.to_string(), consent_sha256: consent_sha256.to_string() }).await
    }

    pub async fn save_demographics(&self, token: &str, demographics: &Demographics) -> Result<(), DbError> {
        self.record(Request::Demographics { token: token.to_string(), demographics: demographics.clone() }).await
    }

    /// Saves the answer to trial `position` exactly once. A repeated idempotency key returns
    /// [`Saved::Repeated`] whatever the participation's state now; a second answer to an
    /// answered trial under a new key is a conflict. Completes the participation with its last
    /// trial, or screens it out when attention checks fail too often.
    pub async fn save_response(&self, token: &str, position: i64, key: &str, answer: &Answer, timing: SaveTiming, design: &StudyDesign) -> Result<SaveOutcome, DbError> {
        let save = SaveRequest::new(token, position, key, answer, timing, design);
        match self.write(Request::Save(save)).await? {
            Written::Saved(outcome) => Ok(outcome),
            other => Err(other.unexpected()),
        }
    }

    /// Stores the answers of one screen's trials (`study::screen`; `(position, key, answer)` in
    /// screen order) in one step: all of them, or none when any is refused. Returns the last
    /// trial's outcome (where the participation stands after the screen).
    pub async fn save_screen(&self, token: &str, parts: &[(i64, String, Answer)], timing: SaveTiming, design: &StudyDesign) -> Result<SaveOutcome, DbError> {
        let saves = parts.iter().map(|(position, key, answer)| SaveRequest::new(token, *position, key, answer, timing.clone(), design)).collect();
        match self.write(Request::SaveScreen(saves)).await? {
            Written::Saved(outcome) => Ok(outcome),
            other => Err(other.unexpected()),
        }
    }

    /// The participant withdraws: their answers stay stored but leave every export.
    pub async fn withdraw(&self, token: &str) -> Result<(), DbError> {
        self.record(Request::Withdraw { token: token.to_string() }).await
    }

    /// Consent, demographics, a withdrawal or an exclusion, stored by [`Db::write`].
    async fn record(&self, request: Request) -> Result<(), DbError> {
        match self.write(request).await? {
            Written::Recorded => Ok(()),
            other => Err(other.unexpected()),
        }
    }

    /// Marks or unmarks a participation as excluded from analyses (with the reason); an
    /// excluded participation does not count for balanced assignment.
    pub async fn set_excluded(&self, study_id: i64, public_id: &str, excluded: bool, reason: &str) -> Result<(), DbError> {
        self.record(Request::Exclude { study_id, public_id: public_id.to_string(), excluded, reason: reason.to_string() }).await
    }

    /// Abandons every open participation whose reservation expired before `now`; returns how many.
    pub async fn reap(&self, now: i64) -> Result<usize, DbError> {
        match self.write(Request::Reap { now }).await? {
            Written::Reaped(n) => Ok(n),
            other => Err(other.unexpected()),
        }
    }

    /// Participations of a study for the admin table.
    pub async fn participants(&self, study_id: i64) -> Result<Vec<ParticipantSummary>, DbError> {
        let sql = "SELECT p.public_id, p.worker_id, p.state, p.excluded, COALESCE(p.exclusion_reason, ''), p.attention_failures, p.created_at, p.updated_at,
                    (SELECT COUNT(*) FROM responses r WHERE r.participant_id = p.id), (SELECT COUNT(*) FROM trials t WHERE t.participant_id = p.id),
                    p.grp, p.arm
             FROM participants p WHERE p.study_id = $1 ORDER BY p.id";
        Ok(on_backend!(self, b => sqlx::query(sql).bind(study_id).fetch_all(&b.reader).await?.iter().map(summary_row).collect()))
    }
}

/// One row of the admin's participant table, as read.
fn summary_row(r: &impl Fields) -> ParticipantSummary {
    ParticipantSummary {
        public_id: r.get(0),
        worker_id: r.get(1),
        state: r.get(2),
        excluded: r.get(3),
        exclusion_reason: r.get(4),
        attention_failures: r.get(5),
        created_at: r.get(6),
        updated_at: r.get(7),
        answered: r.get(8),
        trials: r.get(9),
        group: r.get(10),
        arm: r.get(11),
    }
}

/// One trial of a participation, as read.
fn trial_row(r: &impl Fields) -> Result<TrialRow, DbError> {
    let (kind, id): (String, String) = (r.get(1), r.get(2));
    Ok(TrialRow {
        position: r.get(0),
        kind: stored(TrialKind::parse(&kind), "trial kind", &kind)?,
        stimulus_id: stored(StimulusId::parse(&id).ok(), "stimulus id", &id)?,
        check_index: r.get::<Option<i64>, _>(3).map(|i| i as usize),
        answered: r.get(4),
    })
}

/// Timing and viewing facts sent with a save.
#[derive(Debug, Clone, Default)]
pub struct SaveTiming {
    pub rt_ms: Option<f64>,
    pub video_ended: Option<bool>,
    pub load_failed: bool,
    /// Replays, frame steps, speeds and time on task (stored as JSON in `responses.viewing`).
    pub viewing: Option<crate::study::viewing::Viewing>,
}

/// One row of the admin's participant table.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ParticipantSummary {
    pub public_id: String,
    pub worker_id: String,
    /// The recruitment source's group and the between-subject arm (empty without arms).
    pub group: String,
    pub arm: String,
    pub state: String,
    pub excluded: bool,
    pub exclusion_reason: String,
    pub attention_failures: i64,
    pub created_at: i64,
    pub updated_at: i64,
    pub answered: i64,
    pub trials: i64,
}


/// How long counted stimulus loads are used before they are counted again (milliseconds):
/// counting reads every main trial of the study, and the starts in between are added as they
/// are stored; a reservation that expires in between is released for assignment this much later.
const LOADS_KEPT_MS: i64 = 1_000;

/// The load of each stimulus of a study (main trials of completed participations plus those
/// of unexpired reservations), in stimulus id order: counted at most every [`LOADS_KEPT_MS`],
/// kept current by adding the share of each start the writer stores, and counted again after
/// anything that makes a participation stop counting (withdrawal, screen-out, exclusion, the
/// reaper's abandonments, a failed batch). This holds on SQLite because every change to
/// participations goes through the writer task; on PostgreSQL, where other instances write too,
/// the loads are never kept ([`StimulusLoads::uncached`]) and each start counts them under its
/// study's lock.
#[derive(Debug)]
pub(crate) struct StimulusLoads {
    by_study: HashMap<i64, CountedLoads>,
    /// How long counted loads are used ([`LOADS_KEPT_MS`]; 0: never kept).
    kept_ms: i64,
}

#[derive(Debug)]
struct CountedLoads {
    counted_at: i64,
    loads: Vec<(String, usize)>,
}

impl Default for StimulusLoads {
    fn default() -> StimulusLoads {
        StimulusLoads { by_study: HashMap::new(), kept_ms: LOADS_KEPT_MS }
    }
}

impl StimulusLoads {
    /// Loads that are never kept: counted again at every start (PostgreSQL, where other
    /// instances start participations too).
    pub(crate) fn uncached() -> StimulusLoads {
        StimulusLoads { by_study: HashMap::new(), kept_ms: 0 }
    }

    /// Whether the loads of `study_id` are known and recent enough to use at `now`.
    pub(crate) fn fresh(&self, study_id: i64, now: i64) -> bool {
        self.by_study.get(&study_id).is_some_and(|known| now - known.counted_at < self.kept_ms)
    }

    /// Keeps the loads of `study_id` counted at `now`.
    pub(crate) fn counted(&mut self, study_id: i64, now: i64, loads: Vec<(String, usize)>) {
        self.by_study.insert(study_id, CountedLoads { counted_at: now, loads });
    }

    /// The loads of `study_id` as kept (empty when not counted).
    pub(crate) fn of(&self, study_id: i64) -> &[(String, usize)] {
        self.by_study.get(&study_id).map_or(&[], |known| known.loads.as_slice())
    }

    /// Counts again at the next start (a participation stopped counting).
    pub(crate) fn forget(&mut self) {
        self.by_study.clear();
    }

    /// Counts a new participation's main stimuli.
    pub(crate) fn add(&mut self, study_id: i64, share: &[String]) {
        let Some(CountedLoads { loads, .. }) = self.by_study.get_mut(&study_id) else { return };
        for stimulus in share {
            if let Ok(at) = loads.binary_search_by(|(id, _)| id.as_str().cmp(stimulus)) {
                loads[at].1 += 1;
            }
        }
    }
}

/// A start, as the steps run it (the design's facts it needs).
#[derive(Debug, Clone)]
pub(crate) struct StartRequest {
    pub(super) study_id: i64,
    pub(super) worker_id: String,
    pub(super) platform: &'static str,
    pub(super) platform_params: String,
    pub(super) group: String,
    /// The design's arm names, in declaration order (empty: no arms).
    pub(super) arms: Vec<String>,
    pub(super) trials_per_participant: usize,
    pub(super) labels_per_participant: usize,
    pub(super) ratings_per_stimulus: usize,
    pub(super) practice_trials: usize,
    pub(super) attention_checks: usize,
    pub(super) reservation_minutes: u32,
}

impl StartRequest {
    pub(crate) fn new(study_id: i64, design: &StudyDesign, source: &Source, worker_id: &str, platform_params: &str) -> StartRequest {
        StartRequest {
            study_id,
            worker_id: worker_id.to_string(),
            platform: source.platform.as_str(),
            platform_params: platform_params.to_string(),
            group: source.group.clone(),
            arms: design.arms.iter().map(|a| a.name.clone()).collect(),
            trials_per_participant: design.trials_per_participant,
            labels_per_participant: design.labels_per_participant,
            ratings_per_stimulus: design.ratings_per_stimulus,
            practice_trials: design.practice_trials,
            attention_checks: design.attention.checks.len(),
            reservation_minutes: design.reservation_minutes,
        }
    }
}

/// A trial save, as the steps run it.
#[derive(Debug, Clone)]
pub(crate) struct SaveRequest {
    pub(super) token: String,
    pub(super) position: i64,
    pub(super) key: String,
    pub(super) answer: Answer,
    pub(super) timing: SaveTiming,
    pub(super) reservation_minutes: u32,
    pub(super) checks: Vec<crate::study::design::AttentionCheck>,
    pub(super) max_failures: u32,
    pub(super) needs_demographics: bool,
}

impl SaveRequest {
    pub(crate) fn new(token: &str, position: i64, key: &str, answer: &Answer, timing: SaveTiming, design: &StudyDesign) -> SaveRequest {
        SaveRequest {
            token: token.to_string(),
            position,
            key: key.to_string(),
            answer: answer.clone(),
            timing,
            reservation_minutes: design.reservation_minutes,
            checks: design.attention.checks.clone(),
            max_failures: design.attention.max_failures,
            needs_demographics: design.demographics,
        }
    }
}