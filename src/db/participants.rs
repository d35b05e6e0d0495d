//! Participations: start (balanced assignment), consent, demographics, per-trial saves,
//! withdrawal, exclusion and the reaper that abandons expired reservations.
//!
//! Every function that reads and then writes runs in one `BEGIN IMMEDIATE` transaction, and
//! every state change is written to `session_events` with its reason.

use sqlx::{Row, SqliteConnection};

use super::{Db, DbError, now_ms, secret_token};
use crate::study::assign::{self, PlannedTrial, TrialKind};
use crate::study::task::passes_check;
use crate::study::{Answer, SessionState, StudyDesign};

/// A participation as the pages need it.
#[derive(Debug, Clone)]
pub struct Participation {
    pub id: i64,
    pub study_id: i64,
    pub token: String,
    pub public_id: String,
    pub worker_id: String,
    pub platform_params: String,
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
    pub stimulus_id: String,
    pub check_index: Option<usize>,
    pub answered: bool,
}

/// What a start request led to.
#[derive(Debug)]
pub enum Started {
    /// A new participation (its secret token).
    New(String),
    /// This worker already has a participation in this study (its token).
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

fn participation(row: sqlx::sqlite::SqliteRow) -> Result<Participation, DbError> {
    let state: String = row.get("state");
    Ok(Participation {
        id: row.get("id"),
        study_id: row.get("study_id"),
        token: row.get("token"),
        public_id: row.get("public_id"),
        worker_id: row.get("worker_id"),
        platform_params: row.get("platform_params"),
        state: SessionState::parse(&state).ok_or_else(|| DbError::Conflict(format!("unknown state \"{state}\"")))?,
        consented: row.get::<Option<String>, _>("consent_sha256").is_some(),
        has_demographics: row.get::<i64, _>("has_demographics") != 0,
        expires_at: row.get("expires_at"),
    })
}

const BY_TOKEN: &str = "SELECT p.*, EXISTS (SELECT 1 FROM demographics d WHERE d.participant_id = p.id) AS has_demographics FROM participants p WHERE p.token = ?";
const EXPIRED: &str = "SELECT p.*, 0 AS has_demographics FROM participants p WHERE p.state IN ('reserved', 'active') AND p.expires_at <= ?";

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

/// Moves a participation along the state machine (refusing moves the machine does not have).
async fn transition(conn: &mut SqliteConnection, id: i64, from: SessionState, to: SessionState, reason: &str) -> Result<(), DbError> {
    if !from.can_become(to) {
        return Err(DbError::Conflict(format!("this participation is {from} and cannot become {to}")));
    }
    sqlx::query("UPDATE participants SET state = ?, updated_at = ? WHERE id = ?").bind(to.as_str()).bind(now_ms()).bind(id).execute(&mut *conn).await?;
    log_transition(conn, id, Some(from), to, reason).await
}

async fn load_by_token(conn: &mut SqliteConnection, token: &str) -> Result<Participation, DbError> {
    let row = sqlx::query(BY_TOKEN).bind(token).fetch_optional(&mut *conn).await?;
    participation(row.ok_or_else(|| DbError::NotFound("no such participation".into()))?)
}

impl Db {
    /// Starts a participation for `worker_id` (or finds the one it has): assigns the balanced
    /// share of stimuli and the seeded trial plan in one immediate transaction.
    pub async fn start_participation(&self, study_id: i64, design: &StudyDesign, worker_id: &str, platform_params: &str) -> Result<Started, DbError> {
        let mut tx = self.immediate().await?;
        let now = now_ms();
        let existing = sqlx::query("SELECT token FROM participants WHERE study_id = ? AND worker_id = ?")
            .bind(study_id)
            .bind(worker_id)
            .fetch_optional(&mut *tx)
            .await?;
        if let Some(row) = existing {
            return Ok(Started::Existing(row.get(0)));
        }
        // Load = main trials of completed participations plus those of unexpired reservations.
        let loads: Vec<(String, usize)> = sqlx::query(
            "SELECT s.stimulus_id, COUNT(p.id) FROM stimuli s
             LEFT JOIN trials t ON t.stimulus_id = s.stimulus_id AND t.kind = 'trial'
             LEFT JOIN participants p ON p.id = t.participant_id AND p.study_id = s.study_id AND p.excluded = 0
                 AND (p.state = 'completed' OR (p.state IN ('reserved', 'active') AND p.expires_at > ?2))
             WHERE s.study_id = ?1 GROUP BY s.stimulus_id ORDER BY s.stimulus_id",
        )
        .bind(study_id)
        .bind(now)
        .fetch_all(&mut *tx)
        .await?
        .into_iter()
        .map(|r| (r.get::<String, _>(0), r.get::<i64, _>(1) as usize))
        .collect();
        let seed = u64::from_str_radix(&secret_token()[..16], 16).unwrap_or(0) >> 1;
        let share = match assign::choose_stimuli(&loads, design.trials_per_participant, design.ratings_per_stimulus, seed) {
            Ok(share) => share,
            Err(_) => return Ok(Started::Full),
        };
        let pool: Vec<String> = loads.iter().map(|(id, _)| id.clone()).collect();
        let plan = assign::plan_trials(&share, &pool, design.practice_trials, design.attention.checks.len(), seed);
        let token = secret_token();
        let public_id = format!("p{}", &secret_token()[..12]);
        let expires = now + i64::from(design.reservation_minutes) * 60_000;
        let id: i64 = sqlx::query(
            "INSERT INTO participants (study_id, token, public_id, worker_id, platform, platform_params, grp, seed, state, created_at, updated_at, expires_at)
             VALUES (?, ?, ?, ?, ?, ?, ?, ?, 'reserved', ?, ?, ?) RETURNING id",
        )
        .bind(study_id)
        .bind(&token)
        .bind(&public_id)
        .bind(worker_id)
        .bind(design.recruitment.platform.as_str())
        .bind(platform_params)
        .bind(&design.group)
        .bind(seed as i64)
        .bind(now)
        .bind(now)
        .bind(expires)
        .fetch_one(&mut *tx)
        .await?
        .get(0);
        insert_plan(&mut tx, id, &plan).await?;
        log_transition(&mut tx, id, None, SessionState::Reserved, "started").await?;
        tx.commit().await?;
        Ok(Started::New(token))
    }

    pub async fn participation(&self, token: &str) -> Result<Option<Participation>, DbError> {
        let row = sqlx::query(BY_TOKEN).bind(token).fetch_optional(&self.reader).await?;
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
                let kind: String = r.get(1);
                Ok(TrialRow {
                    position: r.get(0),
                    kind: TrialKind::parse(&kind).ok_or_else(|| DbError::Conflict(format!("unknown trial kind \"{kind}\"")))?,
                    stimulus_id: r.get(2),
                    check_index: r.get::<Option<i64>, _>(3).map(|i| i as usize),
                    answered: r.get::<i64, _>(4) != 0,
                })
            })
            .collect()
    }

    /// Records consent (with the consent text's hash): reserved → active.
    pub async fn give_consent(&self, token: &str, consent_sha256: &str) -> Result<(), DbError> {
        let mut tx = self.immediate().await?;
        let p = load_by_token(&mut tx, token).await?;
        if p.consented {
            return Ok(());
        }
        sqlx::query("UPDATE participants SET consent_sha256 = ? WHERE id = ?").bind(consent_sha256).bind(p.id).execute(&mut *tx).await?;
        transition(&mut tx, p.id, p.state, SessionState::Active, "consent given").await?;
        tx.commit().await?;
        Ok(())
    }

    pub async fn save_demographics(&self, token: &str, d: &Demographics) -> Result<(), DbError> {
        let mut tx = self.immediate().await?;
        let p = load_by_token(&mut tx, token).await?;
        if !p.state.is_open() {
            return Err(DbError::Conflict(format!("this participation is {}", p.state)));
        }
        sqlx::query("INSERT OR REPLACE INTO demographics (participant_id, age, gender, ethnicity, education) VALUES (?, ?, ?, ?, ?)")
            .bind(p.id)
            .bind(d.age)
            .bind(&d.gender)
            .bind(&d.ethnicity)
            .bind(&d.education)
            .execute(&mut *tx)
            .await?;
        tx.commit().await?;
        Ok(())
    }

    /// Saves the answer to trial `position` exactly once. A repeated idempotency key returns
    /// [`Saved::Repeated`] whatever the participation's state now; a second answer to an
    /// answered trial under a new key is a conflict. Completes the participation with its last
    /// trial, or screens it out when attention checks fail too often.
    pub async fn save_response(&self, token: &str, position: i64, key: &str, answer: &Answer, timing: SaveTiming, design: &StudyDesign) -> Result<SaveOutcome, DbError> {
        let answers = serde_json::to_string(&answer.0).map_err(|e| DbError::Conflict(e.to_string()))?;
        let mut tx = self.immediate().await?;
        // Everything the checks need, in one statement (each statement is a round trip to
        // SQLite's worker thread, and the writer is the bottleneck under load).
        let row = sqlx::query(
            "SELECT p.id, p.state, t.kind IS NOT NULL, t.check_index,
                    (SELECT r.participant_id = p.id AND r.position = ?2 FROM responses r WHERE r.idempotency_key = ?3),
                    EXISTS (SELECT 1 FROM responses r WHERE r.participant_id = p.id AND r.position = ?2),
                    (SELECT COUNT(*) FROM trials u WHERE u.participant_id = p.id
                        AND NOT EXISTS (SELECT 1 FROM responses r WHERE r.participant_id = u.participant_id AND r.position = u.position))
             FROM participants p LEFT JOIN trials t ON t.participant_id = p.id AND t.position = ?2
             WHERE p.token = ?1",
        )
        .bind(token)
        .bind(position)
        .bind(key)
        .fetch_optional(&mut *tx)
        .await?
        .ok_or_else(|| DbError::NotFound("no such participation".into()))?;
        let (id, state_text, trial_exists, check, key_match, answered, remaining): (i64, String, bool, Option<i64>, Option<bool>, bool, i64) =
            (row.get(0), row.get(1), row.get(2), row.get(3), row.get(4), row.get(5), row.get(6));
        let state = SessionState::parse(&state_text).ok_or_else(|| DbError::Conflict(format!("unknown state \"{state_text}\"")))?;
        match key_match {
            Some(true) => return Ok(SaveOutcome { saved: Saved::Repeated, state, remaining }),
            Some(false) => return Err(DbError::Conflict("this idempotency key belongs to another answer".into())),
            None => {}
        }
        if state != SessionState::Active {
            return Err(DbError::Conflict(format!("this participation is {state}, not active")));
        }
        if !trial_exists {
            return Err(DbError::NotFound(format!("there is no trial {position}")));
        }
        if answered {
            return Err(DbError::Conflict(format!("trial {position} is answered already")));
        }
        let now = now_ms();
        sqlx::query("INSERT INTO responses (participant_id, position, idempotency_key, answers, rt_ms, video_ended, load_failed, received_at) VALUES (?, ?, ?, ?, ?, ?, ?, ?)")
            .bind(id)
            .bind(position)
            .bind(key)
            .bind(&answers)
            .bind(timing.rt_ms)
            .bind(timing.video_ended)
            .bind(timing.load_failed)
            .bind(now)
            .execute(&mut *tx)
            .await?;
        let remaining = remaining - 1;
        let mut state = state;
        if let Some(check) = check.and_then(|i| design.attention.checks.get(i as usize))
            && !passes_check(answer, &check.measure, &check.value)
        {
            let failures: i64 = sqlx::query("UPDATE participants SET attention_failures = attention_failures + 1 WHERE id = ? RETURNING attention_failures")
                .bind(id)
                .fetch_one(&mut *tx)
                .await?
                .get(0);
            if failures >= i64::from(design.attention.max_failures) {
                transition(&mut tx, id, state, SessionState::ScreenedOut, &format!("failed {failures} attention checks")).await?;
                state = SessionState::ScreenedOut;
            }
        }
        let expires = now + i64::from(design.reservation_minutes) * 60_000;
        sqlx::query("UPDATE participants SET updated_at = ?, expires_at = ? WHERE id = ?").bind(now).bind(expires).bind(id).execute(&mut *tx).await?;
        if remaining == 0 && state == SessionState::Active {
            transition(&mut tx, id, state, SessionState::Completed, "last trial saved").await?;
            state = SessionState::Completed;
        }
        tx.commit().await?;
        Ok(SaveOutcome { saved: Saved::Stored, state, remaining })
    }

    /// The participant withdraws: their answers stay stored but leave every export.
    pub async fn withdraw(&self, token: &str) -> Result<(), DbError> {
        let mut tx = self.immediate().await?;
        let p = load_by_token(&mut tx, token).await?;
        transition(&mut tx, p.id, p.state, SessionState::Withdrawn, "withdrawn by the participant").await?;
        tx.commit().await?;
        Ok(())
    }

    /// Marks or unmarks a participation as excluded from analyses (with the reason).
    pub async fn set_excluded(&self, study_id: i64, public_id: &str, excluded: bool, reason: &str) -> Result<(), DbError> {
        let done = sqlx::query("UPDATE participants SET excluded = ?, exclusion_reason = ? WHERE study_id = ? AND public_id = ?")
            .bind(excluded)
            .bind(if excluded { Some(reason) } else { None })
            .bind(study_id)
            .bind(public_id)
            .execute(&self.writer)
            .await?;
        if done.rows_affected() == 0 {
            return Err(DbError::NotFound(format!("no participant \"{public_id}\" in this study")));
        }
        Ok(())
    }

    /// Abandons every open participation whose reservation expired before `now`; returns how many.
    pub async fn reap(&self, now: i64) -> Result<usize, DbError> {
        let mut tx = self.immediate().await?;
        let expired = sqlx::query(EXPIRED).bind(now).fetch_all(&mut *tx).await?;
        let n = expired.len();
        for row in expired {
            let p = participation(row)?;
            transition(&mut tx, p.id, p.state, SessionState::Abandoned, "reservation expired").await?;
        }
        tx.commit().await?;
        Ok(n)
    }

    /// Participations of a study for the admin table.
    pub async fn participants(&self, study_id: i64) -> Result<Vec<ParticipantSummary>, DbError> {
        let rows = sqlx::query(
            "SELECT p.public_id, p.worker_id, p.state, p.excluded, COALESCE(p.exclusion_reason, ''), p.attention_failures, p.created_at, p.updated_at,
                    (SELECT COUNT(*) FROM responses r WHERE r.participant_id = p.id), (SELECT COUNT(*) FROM trials t WHERE t.participant_id = p.id)
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
            })
            .collect())
    }
}

/// Timing facts sent with a save.
#[derive(Debug, Clone, Copy, Default)]
pub struct SaveTiming {
    pub rt_ms: Option<f64>,
    pub video_ended: Option<bool>,
    pub load_failed: bool,
}

/// One row of the admin's participant table.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ParticipantSummary {
    pub public_id: String,
    pub worker_id: String,
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
    for (position, t) in plan.iter().enumerate() {
        sqlx::query("INSERT INTO trials (participant_id, position, kind, stimulus_id, check_index) VALUES (?, ?, ?, ?, ?)")
            .bind(participant)
            .bind(position as i64)
            .bind(t.kind.as_str())
            .bind(&t.stimulus_id)
            .bind(t.check_index.map(|i| i as i64))
            .execute(&mut *conn)
            .await?;
    }
    Ok(())
}
