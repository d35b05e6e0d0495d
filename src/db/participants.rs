//! Participations: start (balanced assignment), consent, demographics, per-trial saves,
//! withdrawal, exclusion and the reaper that abandons expired reservations.
//!
//! Every change to participations (starts, consent, demographics, saves, withdrawals,
//! exclusions, the reaper) is a request to the writer task (`super::writer`), which runs the
//! `…_in` functions here inside its batch transaction. Every state change is written to
//! `session_events` with its reason.

use std::collections::HashMap;
use std::collections::hash_map::Entry;

use sqlx::{Row, SqliteConnection};

use super::studies::stored;
use super::writer::{Request, Written};
use super::{Db, DbError, now_ms, secret_token, token_sha256};
use crate::stimuli::manifest::StimulusId;
use crate::study::assign::{self, PlannedTrial, TrialKind};
use crate::study::task::passes_check;
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

fn participation(row: sqlx::sqlite::SqliteRow) -> Result<Participation, DbError> {
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
        has_demographics: row.get::<i64, _>("has_demographics") != 0,
        expires_at: row.get("expires_at"),
    })
}

const BY_TOKEN: &str = "SELECT p.*, EXISTS (SELECT 1 FROM demographics d WHERE d.participant_id = p.id) AS has_demographics FROM participants p WHERE p.token_sha256 = ?";
/// How long a participation may stay reserved without consent (milliseconds): after that it no
/// longer counts toward the balance and the reaper abandons it, whatever the design's
/// reservation time, so starts that never consent cannot hold a study's places for long.
pub const CONSENT_WITHIN_MS: i64 = 10 * 60_000;

const EXPIRED: &str = "SELECT p.*, 0 AS has_demographics FROM participants p WHERE (p.state IN ('reserved', 'active') AND p.expires_at <= ?1)
    OR (p.state = 'reserved' AND p.created_at <= ?1 - ?2)";

async fn log_transition(conn: &mut SqliteConnection, participant: i64, from: Option<SessionState>, to: SessionState, reason: &str) -> Result<(), DbError> {
    sqlx::query("INSERT INTO session_events (participant_id, from_state, to_state, reason, at) VALUES (?, ?, ?, ?, ?)")
        .bind(participant)
        .bind(from.map(SessionState::as_str))
        .bind(to.as_str())
        .bind(reason)
        .bind(now_ms())
        .execute(&mut *conn)
        .await?;
    Ok(())
}

/// Refuses the moves the state machine does not have.
fn may_become(from: SessionState, to: SessionState) -> Result<(), DbError> {
    if from.can_become(to) { Ok(()) } else { Err(DbError::Conflict(format!("this participation is {from} and cannot become {to}"))) }
}

/// Moves a participation along the state machine (refusing moves the machine does not have).
async fn transition(conn: &mut SqliteConnection, id: i64, from: SessionState, to: SessionState, reason: &str) -> Result<(), DbError> {
    may_become(from, to)?;
    sqlx::query("UPDATE participants SET state = ?, updated_at = ? WHERE id = ?").bind(to.as_str()).bind(now_ms()).bind(id).execute(&mut *conn).await?;
    log_transition(conn, id, Some(from), to, reason).await
}

async fn load_by_token(conn: &mut SqliteConnection, token: &str) -> Result<Participation, DbError> {
    let row = sqlx::query(BY_TOKEN).bind(token_sha256(token)).fetch_optional(&mut *conn).await?;
    participation(row.ok_or_else(|| DbError::NotFound("no such participation".into()))?)
}

impl Db {
    /// Starts a participation for `worker_id` (or finds the one it has): assigns the balanced
    /// share of stimuli and the seeded trial plan, stored by the writer task together with the
    /// other writes waiting.
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
        let study: Option<i64> = sqlx::query_scalar("SELECT study_id FROM participants WHERE token_sha256 = ?").bind(&hash).fetch_optional(&self.reader).await?;
        if let (Some(study), Ok(mut known)) = (study, self.studies_of_tokens.lock()) {
            known.insert(hash, study);
        }
        Ok(study)
    }

    pub async fn participation(&self, token: &str) -> Result<Option<Participation>, DbError> {
        let row = sqlx::query(BY_TOKEN).bind(token_sha256(token)).fetch_optional(&self.reader).await?;
        row.map(participation).transpose()
    }

    /// Every trial of a participation, in order, with whether it has a saved answer.
    pub async fn trials(&self, participant: i64) -> Result<Vec<TrialRow>, DbError> {
        let rows = sqlx::query(
            "SELECT t.position, t.kind, t.stimulus_id, t.check_index, r.id IS NOT NULL FROM trials t
             LEFT JOIN responses r ON r.participant_id = t.participant_id AND r.position = t.position
             WHERE t.participant_id = ? ORDER BY t.position",
        )
        .bind(participant)
        .fetch_all(&self.reader)
        .await?;
        rows.into_iter()
            .map(|r| {
                let (kind, id): (&str, &str) = (r.get(1), r.get(2));
                Ok(TrialRow {
                    position: r.get(0),
                    kind: stored(TrialKind::parse(kind), "trial kind", kind)?,
                    stimulus_id: stored(StimulusId::parse(id).ok(), "stimulus id", id)?,
                    check_index: r.get::<Option<i64>, _>(3).map(|i| i as usize),
                    answered: r.get::<i64, _>(4) != 0,
                })
            })
            .collect()
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

    /// The participant withdraws: their answers stay stored but leave every export.
    pub async fn withdraw(&self, token: &str) -> Result<(), DbError> {
        self.record(Request::Withdraw { token: token.to_string() }).await
    }

    /// Consent, demographics or a withdrawal, through the writer task.
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
        let rows = sqlx::query(
            "SELECT p.public_id, p.worker_id, p.state, p.excluded, COALESCE(p.exclusion_reason, ''), p.attention_failures, p.created_at, p.updated_at,
                    (SELECT COUNT(*) FROM responses r WHERE r.participant_id = p.id), (SELECT COUNT(*) FROM trials t WHERE t.participant_id = p.id),
                    p.grp, p.arm
             FROM participants p WHERE p.study_id = ? ORDER BY p.id",
        )
        .bind(study_id)
        .fetch_all(&self.reader)
        .await?;
        Ok(rows
            .into_iter()
            .map(|r| ParticipantSummary {
                public_id: r.get(0),
                worker_id: r.get(1),
                state: r.get(2),
                excluded: r.get::<i64, _>(3) != 0,
                exclusion_reason: r.get(4),
                attention_failures: r.get(5),
                created_at: r.get(6),
                updated_at: r.get(7),
                answered: r.get(8),
                trials: r.get(9),
                group: r.get(10),
                arm: r.get(11),
            })
            .collect())
    }
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

async fn insert_plan(conn: &mut SqliteConnection, participant: i64, plan: &[PlannedTrial]) -> Result<(), DbError> {
    // One multi-row INSERT per 100 trials: one round trip instead of one per trial.
    for chunk in plan.chunks(100).enumerate() {
        let (first, trials) = chunk;
        let sql = format!("INSERT INTO trials (participant_id, position, kind, stimulus_id, check_index) VALUES {}", vec!["(?, ?, ?, ?, ?)"; trials.len()].join(", "));
        let mut query = sqlx::query(sqlx::AssertSqlSafe(sql));
        for (offset, t) in trials.iter().enumerate() {
            query = query.bind(participant).bind((first * 100 + offset) as i64).bind(t.kind.as_str()).bind(&t.stimulus_id).bind(t.check_index.map(|i| i as i64));
        }
        query.execute(&mut *conn).await?;
    }
    Ok(())
}

/// How long counted stimulus loads are used before they are counted again (milliseconds):
/// counting reads every main trial of the study, and the starts in between are added as they
/// are stored; a reservation that expires in between is released for assignment this much later.
const LOADS_KEPT_MS: i64 = 1_000;

/// The load of each stimulus of a study (main trials of completed participations plus those
/// of unexpired reservations), in stimulus id order: counted at most every [`LOADS_KEPT_MS`],
/// kept current by adding the share of each start the writer stores, and counted again after
/// anything that makes a participation stop counting (withdrawal, screen-out, exclusion, the
/// reaper's abandonments, a failed batch). This holds because every change to participations
/// goes through the writer task.
#[derive(Debug, Default)]
pub(crate) struct StimulusLoads {
    by_study: HashMap<i64, CountedLoads>,
}

#[derive(Debug)]
struct CountedLoads {
    counted_at: i64,
    loads: Vec<(String, usize)>,
}

impl StimulusLoads {
    /// The loads of `study_id`'s stimuli at `now`.
    pub(crate) async fn of(&mut self, conn: &mut SqliteConnection, study_id: i64, now: i64) -> Result<&[(String, usize)], DbError> {
        let counted = match self.by_study.entry(study_id) {
            Entry::Occupied(known) if now - known.get().counted_at < LOADS_KEPT_MS => known.into_mut(),
            entry => {
                let loads = count_loads(conn, study_id, now).await?;
                entry.insert_entry(CountedLoads { counted_at: now, loads }).into_mut()
            }
        };
        Ok(&counted.loads)
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

/// The condition (on participation `p`; `?2` = now, `?3` = [`CONSENT_WITHIN_MS`]) under which a
/// participation counts toward the balance of stimuli and of arms: not excluded; completed, or
/// open and unexpired; and, while reserved, started within the consent window.
macro_rules! counts_toward_balance {
    () => {
        "p.excluded = 0
             AND (p.state = 'completed' OR (p.state IN ('reserved', 'active') AND p.expires_at > ?2))
             AND (p.state <> 'reserved' OR p.created_at > ?2 - ?3)"
    };
}

/// Only stimuli with trials of their own count: one shown beside its entry's lead is never a
/// trial (`[au_coding] together`).
async fn count_loads(conn: &mut SqliteConnection, study_id: i64, now: i64) -> Result<Vec<(String, usize)>, DbError> {
    let rows = sqlx::query(concat!(
        "SELECT s.stimulus_id, COUNT(p.id) FROM stimuli s
         LEFT JOIN trials t ON t.stimulus_id = s.stimulus_id AND t.kind = 'trial'
         LEFT JOIN participants p ON p.id = t.participant_id AND p.study_id = s.study_id AND ",
        counts_toward_balance!(),
        " WHERE s.study_id = ?1 AND s.lead IS NULL GROUP BY s.stimulus_id ORDER BY s.stimulus_id",
    ))
    .bind(study_id)
    .bind(now)
    .bind(CONSENT_WITHIN_MS)
    .fetch_all(&mut *conn)
    .await?;
    Ok(rows.into_iter().map(|r| (r.get::<String, _>(0), r.get::<i64, _>(1) as usize)).collect())
}

/// A start, as the writer task runs it (the design's facts it needs).
#[derive(Debug)]
pub(crate) struct StartRequest {
    study_id: i64,
    pub(super) worker_id: String,
    platform: &'static str,
    platform_params: String,
    group: String,
    /// The design's arm names, in declaration order (empty: no arms).
    arms: Vec<String>,
    trials_per_participant: usize,
    ratings_per_stimulus: usize,
    practice_trials: usize,
    attention_checks: usize,
    reservation_minutes: u32,
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
            ratings_per_stimulus: design.ratings_per_stimulus,
            practice_trials: design.practice_trials,
            attention_checks: design.attention.checks.len(),
            reservation_minutes: design.reservation_minutes,
        }
    }
}

/// A trial save, as the writer task runs it.
#[derive(Debug)]
pub(crate) struct SaveRequest {
    token: String,
    position: i64,
    key: String,
    answer: Answer,
    timing: SaveTiming,
    reservation_minutes: u32,
    checks: Vec<crate::study::design::AttentionCheck>,
    max_failures: u32,
    needs_demographics: bool,
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

/// One start inside the writer's transaction: finds the worker's participation, or assigns the
/// least-loaded stimuli (counting the starts stored before it) and stores the plan.
pub(crate) async fn start_in(conn: &mut SqliteConnection, start: &StartRequest, loads: &mut StimulusLoads) -> Result<Started, DbError> {
    let now = now_ms();
    let existing = sqlx::query("SELECT token_sha256 FROM participants WHERE study_id = ? AND worker_id = ?")
        .bind(start.study_id)
        .bind(&start.worker_id)
        .fetch_optional(&mut *conn)
        .await?;
    if let Some(row) = existing {
        return Ok(Started::Existing(row.get(0)));
    }
    let seed = u64::from_str_radix(&secret_token()[..16], 16).unwrap_or(0) >> 1;
    let arm = match start.arms.is_empty() {
        true => String::new(),
        false => join_arm(conn, start, now, seed).await?,
    };
    let members = arm_members(conn, start.study_id, &arm).await?;
    let study_loads = loads.of(conn, start.study_id, now).await?;
    // Practice stimuli come from the whole study (outside the participant's share when it can).
    let pool: Vec<String> = study_loads.iter().map(|(id, _)| id.clone()).collect();
    let arm_loads: Vec<(String, usize)> = study_loads.iter().filter(|(id, _)| members.as_ref().is_none_or(|m| m.contains(id))).cloned().collect();
    let Ok(share) = assign::choose_stimuli(&arm_loads, start.trials_per_participant, start.ratings_per_stimulus, seed) else {
        return Ok(Started::Full);
    };
    let plan = assign::plan_trials(&share, &pool, start.practice_trials, start.attention_checks, seed);
    let token = secret_token();
    let public_id = format!("p{}", &secret_token()[..12]);
    let expires = now + i64::from(start.reservation_minutes) * 60_000;
    let id: i64 = sqlx::query(
        "INSERT INTO participants (study_id, token_sha256, public_id, worker_id, platform, platform_params, grp, arm, seed, state, created_at, updated_at, expires_at)
         VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, 'reserved', ?, ?, ?) RETURNING id",
    )
    .bind(start.study_id)
    .bind(token_sha256(&token))
    .bind(&public_id)
    .bind(&start.worker_id)
    .bind(start.platform)
    .bind(&start.platform_params)
    .bind(&start.group)
    .bind(&arm)
    .bind(seed as i64)
    .bind(now)
    .bind(now)
    .bind(expires)
    .fetch_one(&mut *conn)
    .await?
    .get(0);
    insert_plan(conn, id, &plan).await?;
    log_transition(conn, id, None, SessionState::Reserved, "started").await?;
    loads.add(start.study_id, &share);
    Ok(Started::New(token))
}

/// The arm a new participation joins: one with the fewest participations that count toward the
/// balance ([`counts_toward_balance`], as for the stimulus loads).
async fn join_arm(conn: &mut SqliteConnection, start: &StartRequest, now: i64, seed: u64) -> Result<String, DbError> {
    let rows = sqlx::query(concat!("SELECT p.arm, COUNT(*) FROM participants p WHERE p.study_id = ?1 AND ", counts_toward_balance!(), " GROUP BY p.arm"))
    .bind(start.study_id)
    .bind(now)
    .bind(CONSENT_WITHIN_MS)
    .fetch_all(&mut *conn)
    .await?;
    let counted: HashMap<String, i64> = rows.into_iter().map(|r| (r.get(0), r.get(1))).collect();
    let counts: Vec<usize> = start.arms.iter().map(|a| counted.get(a).copied().unwrap_or(0) as usize).collect();
    Ok(start.arms.get(crate::study::arm::choose_arm(&counts, seed)).cloned().unwrap_or_default())
}

/// The stimuli of `arm` (`None`: no arm, every stimulus of the study).
async fn arm_members(conn: &mut SqliteConnection, study_id: i64, arm: &str) -> Result<Option<std::collections::HashSet<String>>, DbError> {
    if arm.is_empty() {
        return Ok(None);
    }
    let rows = sqlx::query("SELECT stimulus_id, arms FROM stimuli WHERE study_id = ?").bind(study_id).fetch_all(&mut *conn).await?;
    Ok(Some(rows.into_iter().filter(|r| r.get::<String, _>(1).split_whitespace().any(|a| a == arm)).map(|r| r.get(0)).collect()))
}

/// Consent inside the writer's transaction: reserved → active (once).
pub(crate) async fn consent_in(conn: &mut SqliteConnection, token: &str, consent_sha256: &str) -> Result<(), DbError> {
    let p = load_by_token(conn, token).await?;
    if p.consented {
        return Ok(());
    }
    let active = SessionState::Active;
    may_become(p.state, active)?;
    sqlx::query("UPDATE participants SET consent_sha256 = ?, state = ?, updated_at = ? WHERE id = ?")
        .bind(consent_sha256)
        .bind(active.as_str())
        .bind(now_ms())
        .bind(p.id)
        .execute(&mut *conn)
        .await?;
    log_transition(conn, p.id, Some(p.state), active, "consent given").await
}

/// Demographics inside the writer's transaction while the participation is open: written
/// once; a second post is a conflict and changes nothing.
pub(crate) async fn demographics_in(conn: &mut SqliteConnection, token: &str, d: &Demographics) -> Result<(), DbError> {
    let p = load_by_token(conn, token).await?;
    if !p.state.is_open() {
        return Err(DbError::Conflict(format!("this participation is {}", p.state)));
    }
    let stored = sqlx::query("INSERT INTO demographics (participant_id, age, gender, ethnicity, education) VALUES (?, ?, ?, ?, ?) ON CONFLICT (participant_id) DO NOTHING")
        .bind(p.id)
        .bind(d.age)
        .bind(&d.gender)
        .bind(&d.ethnicity)
        .bind(&d.education)
        .execute(&mut *conn)
        .await?;
    if stored.rows_affected() == 0 {
        return Err(DbError::Conflict("Your answers about yourself are saved already; they are kept as first given.".into()));
    }
    Ok(())
}

/// An exclusion (or its undoing) inside the writer's transaction.
pub(crate) async fn exclude_in(conn: &mut SqliteConnection, study_id: i64, public_id: &str, excluded: bool, reason: &str) -> Result<(), DbError> {
    let done = sqlx::query("UPDATE participants SET excluded = ?, exclusion_reason = ? WHERE study_id = ? AND public_id = ?")
        .bind(excluded)
        .bind(if excluded { Some(reason) } else { None })
        .bind(study_id)
        .bind(public_id)
        .execute(&mut *conn)
        .await?;
    if done.rows_affected() == 0 {
        return Err(DbError::NotFound(format!("no participant \"{public_id}\" in this study")));
    }
    Ok(())
}

/// The reaper inside the writer's transaction: abandons the open participations whose
/// reservation expired before `now`; returns how many.
pub(crate) async fn reap_in(conn: &mut SqliteConnection, now: i64) -> Result<usize, DbError> {
    let expired = sqlx::query(EXPIRED).bind(now).bind(CONSENT_WITHIN_MS).fetch_all(&mut *conn).await?;
    let n = expired.len();
    for row in expired {
        let p = participation(row)?;
        transition(conn, p.id, p.state, SessionState::Abandoned, "reservation expired").await?;
    }
    Ok(n)
}

/// A withdrawal inside the writer's transaction.
pub(crate) async fn withdraw_in(conn: &mut SqliteConnection, token: &str) -> Result<(), DbError> {
    let p = load_by_token(conn, token).await?;
    transition(conn, p.id, p.state, SessionState::Withdrawn, "withdrawn by the participant").await
}

/// What a save's checks need, read in one statement (each statement is a round trip to
/// SQLite's worker thread, and the writer is the bottleneck under load).
struct SaveFacts {
    id: i64,
    state: SessionState,
    failures: i64,
    trial_exists: bool,
    check: Option<i64>,
    /// The answer stored under this idempotency key, if any: (same trial of the same participation, its answers).
    keyed: Option<(bool, String)>,
    answered: bool,
    has_demographics: bool,
    remaining: i64,
}

async fn save_facts(tx: &mut SqliteConnection, save: &SaveRequest) -> Result<SaveFacts, DbError> {
    let row = sqlx::query(
        "SELECT p.id, p.state, p.attention_failures, t.kind IS NOT NULL, t.check_index,
                k.participant_id = p.id AND k.position = ?2, k.answers,
                EXISTS (SELECT 1 FROM responses r WHERE r.participant_id = p.id AND r.position = ?2),
                EXISTS (SELECT 1 FROM demographics d WHERE d.participant_id = p.id),
                (SELECT COUNT(*) FROM trials u WHERE u.participant_id = p.id
                    AND NOT EXISTS (SELECT 1 FROM responses r WHERE r.participant_id = u.participant_id AND r.position = u.position))
         FROM participants p LEFT JOIN trials t ON t.participant_id = p.id AND t.position = ?2
         LEFT JOIN responses k ON k.idempotency_key = ?3
         WHERE p.token_sha256 = ?1",
    )
    .bind(token_sha256(&save.token))
    .bind(save.position)
    .bind(&save.key)
    .fetch_optional(&mut *tx)
    .await?
    .ok_or_else(|| DbError::NotFound("no such participation".into()))?;
    let state_text: String = row.get(1);
    let keyed = row.get::<Option<String>, _>(6).map(|answers| (row.get::<bool, _>(5), answers));
    Ok(SaveFacts {
        id: row.get(0),
        state: SessionState::parse(&state_text).ok_or_else(|| DbError::Internal(format!("unknown state \"{state_text}\"")))?,
        failures: row.get(2),
        trial_exists: row.get(3),
        check: row.get(4),
        keyed,
        answered: row.get(7),
        has_demographics: row.get(8),
        remaining: row.get(9),
    })
}

/// Refuses a save that the participation's state, the design's steps or an earlier save rule
/// out; `Some` is the answer to a repeated save (the same key with the same answer).
fn check_save(facts: &SaveFacts, save: &SaveRequest, answers: &str) -> Result<Option<SaveOutcome>, DbError> {
    let position = save.position;
    match &facts.keyed {
        Some((true, stored)) if stored == answers => return Ok(Some(SaveOutcome { saved: Saved::Repeated, state: facts.state, remaining: facts.remaining })),
        Some((true, _)) => return Err(DbError::Conflict(format!("trial {position} was saved under this idempotency key with another answer; the first answer is kept"))),
        Some((false, _)) => return Err(DbError::Conflict("this idempotency key belongs to another answer".into())),
        None => {}
    }
    if facts.state != SessionState::Active {
        return Err(DbError::Conflict(format!("this participation is {}, not active", facts.state)));
    }
    if save.needs_demographics && !facts.has_demographics {
        return Err(DbError::Conflict("the questions about you come before the trials".into()));
    }
    if !facts.trial_exists {
        return Err(DbError::NotFound(format!("there is no trial {position}")));
    }
    if facts.answered {
        return Err(DbError::Conflict(format!("trial {position} is answered already")));
    }
    Ok(None)
}

/// One save inside the writer's transaction.
pub(crate) async fn save_in(tx: &mut SqliteConnection, save: &SaveRequest) -> Result<SaveOutcome, DbError> {
    let SaveRequest { position, key, answer, timing, .. } = save;
    let answers = serde_json::to_string(&answer.0).map_err(|e| DbError::Internal(e.to_string()))?;
    let viewing = timing.viewing.as_ref().map(serde_json::to_string).transpose().map_err(|e| DbError::Internal(e.to_string()))?;
    let facts = save_facts(tx, save).await?;
    if let Some(repeated) = check_save(&facts, save, &answers)? {
        return Ok(repeated);
    }
    let failed_check = facts.check.and_then(|i| save.checks.get(i as usize)).is_some_and(|c| !passes_check(answer, c.measure, &c.value));
    let failures = facts.failures + i64::from(failed_check);
    let remaining = facts.remaining - 1;
    let (state, reason) = match after_save(failed_check, failures, save.max_failures, remaining) {
        Some((to, reason)) => (to, Some(reason)),
        None => (SessionState::Active, None),
    };
    let now = now_ms();
    sqlx::query("INSERT INTO responses (participant_id, position, idempotency_key, answers, rt_ms, video_ended, load_failed, viewing, received_at) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)")
        .bind(facts.id)
        .bind(*position)
        .bind(key)
        .bind(&answers)
        .bind(timing.rt_ms)
        .bind(timing.video_ended)
        .bind(timing.load_failed)
        .bind(viewing)
        .bind(now)
        .execute(&mut *tx)
        .await?;
    // The attention failures, the state and the renewed reservation in one statement.
    sqlx::query("UPDATE participants SET attention_failures = ?, state = ?, updated_at = ?, expires_at = ? WHERE id = ?")
        .bind(failures)
        .bind(state.as_str())
        .bind(now)
        .bind(now + i64::from(save.reservation_minutes) * 60_000)
        .bind(facts.id)
        .execute(&mut *tx)
        .await?;
    if let Some(reason) = reason {
        log_transition(tx, facts.id, Some(SessionState::Active), state, &reason).await?;
    }
    Ok(SaveOutcome { saved: Saved::Stored, state, remaining })
}

/// Where an active participation goes after a stored answer, and why: screened out when this
/// answer failed an attention check once too often, completed with its last trial.
fn after_save(failed_check: bool, failures: i64, max_failures: u32, remaining: i64) -> Option<(SessionState, String)> {
    if failed_check && failures >= i64::from(max_failures) {
        Some((SessionState::ScreenedOut, format!("failed {failures} attention checks")))
    } else if remaining == 0 {
        Some((SessionState::Completed, "last trial saved".to_string()))
    } else {
        None
    }
}
