//! The changes to participations (starts, consent, demographics, saves, withdrawals,
//! exclusions, the reaper) inside a transaction the caller holds: the SQLite writer task's
//! batch ([`super::writer`]) or one PostgreSQL transaction per request ([`super::postgres`]).
//!
//! In: a connection in a transaction and a [`Request`]. Out: what it stored ([`Written`]).
//! Every state change is written to `session_events` with its reason. The functions are written
//! once, in `steps!`, and compiled once per backend: [`in_sqlite`] and [`in_postgres`]; the
//! SQL is the same on both (numbered placeholders), and what differs is the lock each step
//! takes first, a constant of the backend's module.
//!
//! Invariants: a start reads the loads and the worker's participation only after it holds its
//! study's lock, and every other step reads its participation only after it holds that
//! participation's lock, so what they decide on cannot change before they commit. On SQLite both
//! locks are the writer's: one connection, in `BEGIN IMMEDIATE` (the statements are `None`); on
//! PostgreSQL they are row locks (`SELECT ... FOR UPDATE`), and the reaper skips rows another
//! transaction holds (`SKIP LOCKED`), leaving them to its next run.

use std::collections::HashMap;

use super::participants::{BY_TOKEN, CONSENT_WITHIN_MS, Demographics, Participation, SaveOutcome, SaveRequest, Saved, StartRequest, Started, StimulusLoads, participation};
use super::writer::{Request, Written};
use super::{DbError, Fields, now_ms, secret_token, token_sha256};
use crate::study::SessionState;
use crate::study::assign::{self, PlannedTrial};
use crate::study::task::passes_check;

/// Refuses the moves the state machine does not have.
fn may_become(from: SessionState, to: SessionState) -> Result<(), DbError> {
    if from.can_become(to) { Ok(()) } else { Err(DbError::Conflict(format!("this participation is {from} and cannot become {to}"))) }
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

/// The condition (on participation `p`; `$2` = now, `$3` = [`CONSENT_WITHIN_MS`]) under which a
/// participation counts toward the balance of stimuli and of arms: not excluded; completed, or
/// open and unexpired; and, while reserved, started within the consent window.
macro_rules! counts_toward_balance {
    () => {
        "NOT p.excluded
             AND (p.state = 'completed' OR (p.state IN ('reserved', 'active') AND p.expires_at > $2))
             AND (p.state <> 'reserved' OR p.created_at > $2 - $3)"
    };
}

/// The open participations whose reservation expired (`$1` = now, `$2` = [`CONSENT_WITHIN_MS`]).
macro_rules! expired {
    () => {
        "SELECT p.*, FALSE AS has_demographics FROM participants p WHERE (p.state IN ('reserved', 'active') AND p.expires_at <= $1)
            OR (p.state = 'reserved' AND p.created_at <= $1 - $2)"
    };
}

/// The steps, written once; `Conn`, `LOCK_STUDY`, `LOCK_PARTICIPATION` and `REAP` are the
/// backend's, from the module the macro is expanded in.
macro_rules! steps {
    () => {
        async fn log_transition(conn: &mut Conn, participant: i64, from: Option<SessionState>, to: SessionState, reason: &str) -> Result<(), DbError> {
            sqlx::query("INSERT INTO session_events (participant_id, from_state, to_state, reason, at) VALUES ($1, $2, $3, $4, $5)")
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
        async fn transition(conn: &mut Conn, id: i64, from: SessionState, to: SessionState, reason: &str) -> Result<(), DbError> {
            may_become(from, to)?;
            sqlx::query("UPDATE participants SET state = $1, updated_at = $2 WHERE id = $3").bind(to.as_str()).bind(now_ms()).bind(id).execute(&mut *conn).await?;
            log_transition(conn, id, Some(from), to, reason).await
        }

        async fn load_by_token(conn: &mut Conn, token: &str) -> Result<Participation, DbError> {
            let row = sqlx::query(BY_TOKEN).bind(token_sha256(token)).fetch_optional(&mut *conn).await?;
            participation(&row.ok_or_else(|| DbError::NotFound("no such participation".into()))?)
        }

        async fn insert_plan(conn: &mut Conn, participant: i64, plan: &[PlannedTrial]) -> Result<(), DbError> {
            // One multi-row INSERT per 100 trials: one round trip instead of one per trial.
            for chunk in plan.chunks(100).enumerate() {
                let (first, trials) = chunk;
                let rows: Vec<String> = (0..trials.len()).map(|t| format!("(${}, ${}, ${}, ${}, ${})", 5 * t + 1, 5 * t + 2, 5 * t + 3, 5 * t + 4, 5 * t + 5)).collect();
                let sql = format!("INSERT INTO trials (participant_id, position, kind, stimulus_id, check_index) VALUES {}", rows.join(", "));
                let mut query = sqlx::query(sqlx::AssertSqlSafe(sql));
                for (offset, t) in trials.iter().enumerate() {
                    query = query.bind(participant).bind((first * 100 + offset) as i64).bind(t.kind.as_str()).bind(&t.stimulus_id).bind(t.check_index.map(|i| i as i64));
                }
                query.execute(&mut *conn).await?;
            }
            Ok(())
        }


        /// Only stimuli with trials of their own count: one shown beside its entry's lead is never a
        /// trial (`[au_coding] together`).
        async fn count_loads(conn: &mut Conn, study_id: i64, now: i64) -> Result<Vec<(String, usize)>, DbError> {
            let rows = sqlx::query(concat!(
                "SELECT s.stimulus_id, COUNT(p.id) FROM stimuli s
                 LEFT JOIN trials t ON t.stimulus_id = s.stimulus_id AND t.kind = 'trial'
                 LEFT JOIN participants p ON p.id = t.participant_id AND p.study_id = s.study_id AND ",
                counts_toward_balance!(),
                " WHERE s.study_id = $1 AND s.lead IS NULL GROUP BY s.stimulus_id ORDER BY s.stimulus_id",
            ))
            .bind(study_id)
            .bind(now)
            .bind(CONSENT_WITHIN_MS)
            .fetch_all(&mut *conn)
            .await?;
            Ok(rows.into_iter().map(|r| (r.get::<String, _>(0), r.get::<i64, _>(1) as usize)).collect())
        }


        /// The loads of `study_id`'s stimuli at `now`: those `loads` keeps, or counted again.
        async fn loads_of<'l>(loads: &'l mut StimulusLoads, conn: &mut Conn, study_id: i64, now: i64) -> Result<&'l [(String, usize)], DbError> {
            if !loads.fresh(study_id, now) {
                let counted = count_loads(conn, study_id, now).await?;
                loads.counted(study_id, now, counted);
            }
            Ok(loads.of(study_id))
        }

        /// Locks the study's row until the transaction ends (PostgreSQL: starts of one study run one at a time).
        async fn lock_study(conn: &mut Conn, study_id: i64) -> Result<(), DbError> {
            if let Some(sql) = LOCK_STUDY {
                sqlx::query(sql).bind(study_id).fetch_optional(&mut *conn).await?;
            }
            Ok(())
        }

        /// Locks the participation's row until the transaction ends (PostgreSQL: its steps run one at a time).
        async fn lock_participation(conn: &mut Conn, token: &str) -> Result<(), DbError> {
            if let Some(sql) = LOCK_PARTICIPATION {
                sqlx::query(sql).bind(token_sha256(token)).fetch_optional(&mut *conn).await?;
            }
            Ok(())
        }

        /// One start inside the request's transaction: finds the worker's participation, or assigns the
        /// least-loaded stimuli (counting the starts stored before it) and stores the plan.
        pub(crate) async fn start_in(conn: &mut Conn, start: &StartRequest, loads: &mut StimulusLoads) -> Result<Started, DbError> {
            lock_study(conn, start.study_id).await?;
            let now = now_ms();
            let existing = sqlx::query("SELECT token_sha256 FROM participants WHERE study_id = $1 AND worker_id = $2")
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
            let study_loads = loads_of(loads, conn, start.study_id, now).await?;
            // Practice stimuli come from the whole study (outside the participant's share when it can).
            let pool: Vec<String> = study_loads.iter().map(|(id, _)| id.clone()).collect();
            let arm_loads: Vec<(String, usize)> = study_loads.iter().filter(|(id, _)| members.as_ref().is_none_or(|m| m.contains(id))).cloned().collect();
            let Some((share, plan)) = plan_share(conn, start, &arm_loads, &pool, seed).await? else {
                return Ok(Started::Full);
            };
            let token = secret_token();
            let public_id = format!("p{}", &secret_token()[..12]);
            let expires = now + i64::from(start.reservation_minutes) * 60_000;
            let id: i64 = sqlx::query(
                "INSERT INTO participants (study_id, token_sha256, public_id, worker_id, platform, platform_params, grp, arm, seed, state, created_at, updated_at, expires_at)
                 VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, 'reserved', $10, $11, $12) RETURNING id",
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
        async fn join_arm(conn: &mut Conn, start: &StartRequest, now: i64, seed: u64) -> Result<String, DbError> {
            let rows = sqlx::query(concat!("SELECT p.arm, COUNT(*) FROM participants p WHERE p.study_id = $1 AND ", counts_toward_balance!(), " GROUP BY p.arm"))
            .bind(start.study_id)
            .bind(now)
            .bind(CONSENT_WITHIN_MS)
            .fetch_all(&mut *conn)
            .await?;
            let counted: HashMap<String, i64> = rows.into_iter().map(|r| (r.get(0), r.get(1))).collect();
            let counts: Vec<usize> = start.arms.iter().map(|a| counted.get(a).copied().unwrap_or(0) as usize).collect();
            Ok(start.arms.get(crate::study::arm::choose_arm(&counts, seed)).cloned().unwrap_or_default())
        }

        /// The participant's share and plan: a balanced share of stimuli, or whole labels
        /// (`labels_per_participant`); `None` when the study has every rating it asked for.
        async fn plan_share(conn: &mut Conn, start: &StartRequest, loads: &[(String, usize)], pool: &[String], seed: u64) -> Result<Option<(Vec<String>, Vec<PlannedTrial>)>, DbError> {
            if start.labels_per_participant == 0 {
                let Ok(share) = assign::choose_stimuli(loads, start.trials_per_participant, start.ratings_per_stimulus, seed) else { return Ok(None) };
                let plan = assign::plan_trials(&share, pool, start.practice_trials, start.attention_checks, seed);
                return Ok(Some((share, plan)));
            }
            let rows = sqlx::query("SELECT stimulus_id, emotion FROM stimuli WHERE study_id = $1").bind(start.study_id).fetch_all(&mut *conn).await?;
            let labels: std::collections::HashMap<String, String> = rows.into_iter().map(|r| (r.get(0), r.get(1))).collect();
            let label_of = |id: &str| labels.get(id).cloned();
            let Ok(groups) = assign::choose_labels(loads, &label_of, start.labels_per_participant, start.ratings_per_stimulus, seed) else { return Ok(None) };
            let plan = assign::plan_label_trials(&groups, pool, start.practice_trials, start.attention_checks, seed);
            Ok(Some((groups.concat(), plan)))
        }

        /// The stimuli of `arm` (`None`: no arm, every stimulus of the study).
        async fn arm_members(conn: &mut Conn, study_id: i64, arm: &str) -> Result<Option<std::collections::HashSet<String>>, DbError> {
            if arm.is_empty() {
                return Ok(None);
            }
            let rows = sqlx::query("SELECT stimulus_id, arms FROM stimuli WHERE study_id = $1").bind(study_id).fetch_all(&mut *conn).await?;
            Ok(Some(rows.into_iter().filter(|r| r.get::<String, _>(1).split_whitespace().any(|a| a == arm)).map(|r| r.get(0)).collect()))
        }

        /// Consent inside the request's transaction: reserved → active (once).
        pub(crate) async fn consent_in(conn: &mut Conn, token: &str, consent_sha256: &str) -> Result<(), DbError> {
            lock_participation(conn, token).await?;
            let p = load_by_token(conn, token).await?;
            if p.consented {
                return Ok(());
            }
            let active = SessionState::Active;
            may_become(p.state, active)?;
            sqlx::query("UPDATE participants SET consent_sha256 = $1, state = $2, updated_at = $3 WHERE id = $4")
                .bind(consent_sha256)
                .bind(active.as_str())
                .bind(now_ms())
                .bind(p.id)
                .execute(&mut *conn)
                .await?;
            log_transition(conn, p.id, Some(p.state), active, "consent given").await
        }

        /// Demographics inside the request's transaction while the participation is open: written
        /// once; a second post is a conflict and changes nothing.
        pub(crate) async fn demographics_in(conn: &mut Conn, token: &str, d: &Demographics) -> Result<(), DbError> {
            lock_participation(conn, token).await?;
            let p = load_by_token(conn, token).await?;
            if !p.state.is_open() {
                return Err(DbError::Conflict(format!("this participation is {}", p.state)));
            }
            let stored = sqlx::query("INSERT INTO demographics (participant_id, age, gender, ethnicity, education) VALUES ($1, $2, $3, $4, $5) ON CONFLICT (participant_id) DO NOTHING")
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

        /// An exclusion (or its undoing) inside the request's transaction.
        pub(crate) async fn exclude_in(conn: &mut Conn, study_id: i64, public_id: &str, excluded: bool, reason: &str) -> Result<(), DbError> {
            let done = sqlx::query("UPDATE participants SET excluded = $1, exclusion_reason = $2 WHERE study_id = $3 AND public_id = $4")
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

        /// The reaper inside the request's transaction: abandons the open participations whose
        /// reservation expired before `now`; returns how many.
        pub(crate) async fn reap_in(conn: &mut Conn, now: i64) -> Result<usize, DbError> {
            let expired = sqlx::query(REAP).bind(now).bind(CONSENT_WITHIN_MS).fetch_all(&mut *conn).await?;
            let n = expired.len();
            for row in expired {
                let p = participation(&row)?;
                transition(conn, p.id, p.state, SessionState::Abandoned, "reservation expired").await?;
            }
            Ok(n)
        }

        /// A withdrawal inside the request's transaction.
        pub(crate) async fn withdraw_in(conn: &mut Conn, token: &str) -> Result<(), DbError> {
            lock_participation(conn, token).await?;
            let p = load_by_token(conn, token).await?;
            transition(conn, p.id, p.state, SessionState::Withdrawn, "withdrawn by the participant").await
        }

        async fn save_facts(tx: &mut Conn, save: &SaveRequest) -> Result<SaveFacts, DbError> {
            let row = sqlx::query(
                "SELECT p.id, p.state, p.attention_failures, t.kind IS NOT NULL, t.check_index,
                        k.participant_id = p.id AND k.position = $2, k.answers,
                        EXISTS (SELECT 1 FROM responses r WHERE r.participant_id = p.id AND r.position = $2),
                        EXISTS (SELECT 1 FROM demographics d WHERE d.participant_id = p.id),
                        (SELECT COUNT(*) FROM trials u WHERE u.participant_id = p.id
                            AND NOT EXISTS (SELECT 1 FROM responses r WHERE r.participant_id = u.participant_id AND r.position = u.position))
                 FROM participants p LEFT JOIN trials t ON t.participant_id = p.id AND t.position = $2
                 LEFT JOIN responses k ON k.idempotency_key = $3
                 WHERE p.token_sha256 = $1",
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

        /// One save inside the writer's transaction.
        pub(crate) async fn save_in(tx: &mut Conn, save: &SaveRequest) -> Result<SaveOutcome, DbError> {
            let SaveRequest { position, key, answer, timing, .. } = save;
            let answers = serde_json::to_string(&answer.0).map_err(|e| DbError::Internal(e.to_string()))?;
            let viewing = timing.viewing.as_ref().map(serde_json::to_string).transpose().map_err(|e| DbError::Internal(e.to_string()))?;
            lock_participation(tx, &save.token).await?;
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
            sqlx::query("INSERT INTO responses (participant_id, position, idempotency_key, answers, rt_ms, video_ended, load_failed, viewing, received_at) VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9)")
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
            sqlx::query("UPDATE participants SET attention_failures = $1, state = $2, updated_at = $3, expires_at = $4 WHERE id = $5")
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

        /// [`save_in`], and the loads forgotten when the save screened the participation out.
        async fn save_forgetting(conn: &mut Conn, save: &SaveRequest, loads: &mut StimulusLoads) -> Result<SaveOutcome, DbError> {
            let outcome = save_in(conn, save).await?;
            if outcome.saved == Saved::Stored && outcome.state == SessionState::ScreenedOut {
                loads.forget();
            }
            Ok(outcome)
        }

        /// Runs one participation change inside the caller's transaction.
        pub(crate) async fn run(conn: &mut Conn, request: Request, loads: &mut StimulusLoads) -> Result<Written, DbError> {
            match request {
                Request::Start(start) => start_in(conn, &start, loads).await.map(Written::Started),
                Request::Consent { token, consent_sha256 } => consent_in(conn, &token, &consent_sha256).await.map(|()| Written::Recorded),
                Request::Demographics { token, demographics } => demographics_in(conn, &token, &demographics).await.map(|()| Written::Recorded),
                Request::Save(save) => save_forgetting(conn, &save, loads).await.map(Written::Saved),
                Request::SaveScreen(saves) => {
                    // The caller's savepoint holds them together: one failing undoes the others.
                    let mut last = None;
                    for save in &saves {
                        last = Some(save_forgetting(conn, save, loads).await?);
                    }
                    last.map(Written::Saved).ok_or_else(|| DbError::Invalid("a screen without trials".into()))
                }
                Request::Withdraw { token } => {
                    withdraw_in(conn, &token).await?;
                    loads.forget();
                    Ok(Written::Recorded)
                }
                Request::Exclude { study_id, public_id, excluded, reason } => {
                    exclude_in(conn, study_id, &public_id, excluded, &reason).await?;
                    loads.forget();
                    Ok(Written::Recorded)
                }
                Request::Reap { now } => {
                    let abandoned = reap_in(conn, now).await?;
                    if abandoned > 0 {
                        loads.forget();
                    }
                    Ok(Written::Reaped(abandoned))
                }
            }
        }
    };
}

/// The steps on SQLite, inside the writer task's batch: the writer holds the database's only
/// write lock, so the steps lock nothing more.
pub(crate) mod in_sqlite {
    use super::*;

    type Conn = sqlx::SqliteConnection;
    const LOCK_STUDY: Option<&str> = None;
    const LOCK_PARTICIPATION: Option<&str> = None;
    const REAP: &str = expired!();

    steps!();
}

/// The steps on PostgreSQL, each request in its own transaction beside other instances'.
pub(crate) mod in_postgres {
    use super::*;

    type Conn = sqlx::PgConnection;
    const LOCK_STUDY: Option<&str> = Some("SELECT id FROM studies WHERE id = $1 FOR UPDATE");
    const LOCK_PARTICIPATION: Option<&str> = Some("SELECT id FROM participants WHERE token_sha256 = $1 FOR UPDATE");
    const REAP: &str = concat!(expired!(), " FOR UPDATE OF p SKIP LOCKED");

    steps!();
}
