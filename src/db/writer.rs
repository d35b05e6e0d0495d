//! The writer task: every change to participations (starts, consent, demographics, trial saves,
//! withdrawals, exclusions, the reaper) waits in one queue, and the task stores whatever is
//! waiting, up to [`BATCH`] requests, in one `BEGIN IMMEDIATE` transaction on the writer
//! connection (group commit), then answers each request.
//!
//! Participants' steps (consent, demographics, trial saves) go into the next batch as they
//! come; at most [`ORDERED_PER_BATCH`] of the other requests (starts, withdrawals, exclusions,
//! the reaper), which cost more, go into one batch, the rest wait for the next ones, so a burst
//! of arrivals does not hold up the saves of those already at work ([`Batches`]).
//!
//! Invariants: the ordered requests run in arrival order, and a step may only run ahead of
//! ordered requests that arrived before it (a step needs the token of a start that has been
//! answered, so it never depends on one still waiting); each request sees what those before it
//! in the same batch wrote, so one-participation-per-worker and idempotency checks hold across
//! a batch;
//! balanced assignment counts the stimulus loads at most once a second, adds each start's share
//! and counts again after a withdrawal, a screen-out, an exclusion, an abandonment or a failed
//! batch ([`StimulusLoads`]). Each request runs in its own savepoint: one that fails (a
//! conflict, a missing trial, an SQL error) is rolled back alone and gets its own error while
//! the rest of the batch commits. When the transaction itself fails (begin, a savepoint, the commit),
//! nothing of the batch is stored and every request in it gets [`DbError::Unavailable`], so the
//! client may send it again.

use std::collections::VecDeque;

use sqlx::SqlitePool;
use tokio::sync::{mpsc, oneshot};

use super::DbError;
use super::participants::{Demographics, SaveOutcome, SaveRequest, StartRequest, Started, StimulusLoads};
use super::steps::in_sqlite;

/// Most requests stored in one transaction.
pub(crate) const BATCH: usize = 128;

/// How many requests may wait for the writer before senders wait too.
pub(crate) const QUEUE: usize = 4096;

/// Most ordered requests (starts, withdrawals, exclusions, reaps) in one batch.
pub(crate) const ORDERED_PER_BATCH: usize = 8;

/// A change to participations, as the writer task runs it.
#[derive(Debug, Clone)]
pub(crate) enum Request {
    Start(StartRequest),
    Consent { token: String, consent_sha256: String },
    Demographics { token: String, demographics: Demographics },
    Save(SaveRequest),
    /// The trials of one screen (`study::screen`), stored together or not at all.
    SaveScreen(Vec<SaveRequest>),
    Withdraw { token: String },
    Exclude { study_id: i64, public_id: String, excluded: bool, reason: String },
    /// Abandons the reservations that expired before `now`.
    Reap { now: i64 },
}

/// What a request stored.
#[derive(Debug)]
pub(crate) enum Written {
    Started(Started),
    Saved(SaveOutcome),
    /// Consent, demographics, a withdrawal or an exclusion.
    Recorded,
    /// How many reservations the reaper abandoned.
    Reaped(usize),
}

impl Request {
    /// A participant's step in a participation already started: it never waits behind ordered
    /// requests.
    fn is_step(&self) -> bool {
        matches!(self, Request::Consent { .. } | Request::Demographics { .. } | Request::Save(_) | Request::SaveScreen(_))
    }
}

impl Written {
    /// The error for an answer of the wrong kind (the writer answers each request with its own
    /// kind, so this does not happen).
    pub(crate) fn unexpected(self) -> DbError {
        DbError::Unavailable(format!("the writer answered with {self:?}"))
    }
}

/// A request waiting in the queue, with where its answer goes.
pub(crate) struct Write {
    pub(crate) request: Request,
    pub(crate) reply: oneshot::Sender<Result<Written, DbError>>,
}

/// Cuts the queue into batches: every waiting step, and the ordered requests in arrival order,
/// at most [`ORDERED_PER_BATCH`] of them per batch (the others are held for the next batches).
#[derive(Default)]
pub(crate) struct Batches {
    held: VecDeque<Write>,
}

impl Batches {
    /// The next batch (never empty); waits for a request when nothing is waiting; `None` once
    /// the queue is closed and nothing is held.
    pub(crate) async fn next(&mut self, queue: &mut mpsc::Receiver<Write>) -> Option<Vec<Write>> {
        let mut batch = Vec::new();
        let mut ordered = 0;
        while ordered < ORDERED_PER_BATCH {
            let Some(write) = self.held.pop_front() else { break };
            batch.push(write);
            ordered += 1;
        }
        if batch.is_empty() {
            let write = queue.recv().await?;
            self.place(write, &mut batch, &mut ordered);
        }
        while batch.len() < BATCH && self.held.len() < QUEUE {
            match queue.try_recv() {
                Ok(write) => self.place(write, &mut batch, &mut ordered),
                Err(_) => break,
            }
        }
        Some(batch)
    }

    /// Puts `write` in this batch, or holds it behind the ordered requests already held.
    fn place(&mut self, write: Write, batch: &mut Vec<Write>, ordered: &mut usize) {
        if write.request.is_step() {
            batch.push(write);
        } else if *ordered < ORDERED_PER_BATCH && self.held.is_empty() {
            *ordered += 1;
            batch.push(write);
        } else {
            self.held.push_back(write);
        }
    }
}

/// Takes the requests that are waiting, batch by batch ([`Batches`]), stores each batch
/// together and answers each request; until the queue closes.
pub(crate) async fn write_batches(writer: SqlitePool, mut queue: mpsc::Receiver<Write>) {
    let mut loads = StimulusLoads::default();
    let mut batches = Batches::default();
    while let Some(batch) = batches.next(&mut queue).await {
        let (requests, replies): (Vec<Request>, Vec<_>) = batch.into_iter().map(|w| (w.request, w.reply)).unzip();
        match store(&writer, &mut loads, requests).await {
            Ok(outcomes) => {
                for (reply, outcome) in replies.into_iter().zip(outcomes) {
                    let _ = reply.send(outcome);
                }
            }
            Err(e) => {
                loads.forget();
                let message = e.to_string();
                for reply in replies {
                    let _ = reply.send(Err(DbError::Unavailable(message.clone())));
                }
            }
        }
    }
}

/// Runs `requests` in one transaction, each in its own savepoint, and commits. `Ok` holds each
/// request's own outcome; `Err` means the transaction failed and nothing was stored (then
/// `loads` must be forgotten: they count the batch's starts).
pub(crate) async fn store(writer: &SqlitePool, loads: &mut StimulusLoads, requests: Vec<Request>) -> Result<Vec<Result<Written, DbError>>, DbError> {
    let mut tx = writer.begin_with("BEGIN IMMEDIATE").await?;
    // One savepoint is always open: a request that succeeds is released and a new savepoint
    // opened (one statement), one that fails is rolled back to it (which keeps it open).
    sqlx::raw_sql("SAVEPOINT request").execute(&mut *tx).await?;
    let mut outcomes = Vec::with_capacity(requests.len());
    for request in requests {
        let outcome = in_sqlite::run(&mut tx, request, loads).await;
        let next = if outcome.is_ok() { "RELEASE request; SAVEPOINT request" } else { "ROLLBACK TO request" };
        sqlx::raw_sql(next).execute(&mut *tx).await?;
        outcomes.push(outcome);
    }
    tx.commit().await?;
    Ok(outcomes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::db::Db;
    use crate::db::participants::{SaveTiming, Saved};
    use crate::study::SessionState;
    use crate::db::studies::StudyStimulus;
    use crate::study::{Answer, StudyDesign};

    fn design(extra: &str) -> (String, StudyDesign) {
        let toml = format!(
            "slug = \"batch\"\ntitle = \"Batch\"\ntask = \"emotion\"\nstimuli = \"set\"\npractice_trials = 0\ndemographics = false\nconsent = \"ok\"\ninstructions = \"go\"\ndebrief = \"thanks\"\n{extra}"
        );
        let design = StudyDesign::from_toml(&toml).expect("design");
        (toml, design)
    }

    /// A database in `dir` with one open study of `stimuli` stimuli.
    async fn study(dir: &tempfile::TempDir, extra: &str, stimuli: usize) -> (Db, i64, StudyDesign) {
        let db = Db::open(&dir.path().join("batch.db")).await.expect("database");
        let (toml, design) = design(extra);
        let stimuli: Vec<StudyStimulus> = (0..stimuli)
            .map(|i| StudyStimulus::still(crate::stimuli::StimulusId::parse(&crate::stimuli::stimulus_id(1, i)).expect("id")))
            .collect();
        let id = db.create_study(&design, &toml, "set", &stimuli, true).await.expect("study");
        (db, id, design)
    }

    fn start(study: i64, design: &StudyDesign, worker: &str) -> Request {
        Request::Start(StartRequest::new(study, design, &design.sources[0], worker, "{}"))
    }

    fn started(outcome: &Result<Written, DbError>) -> Option<&Started> {
        match outcome {
            Ok(Written::Started(started)) => Some(started),
            _ => None,
        }
    }

    fn token(outcome: &Result<Written, DbError>) -> String {
        match started(outcome) {
            Some(Started::New(token)) => token.clone(),
            other => panic!("not new: {other:?}"),
        }
    }

    async fn main_trials_per_stimulus(db: &Db) -> Vec<i64> {
        sqlx::query_scalar("SELECT COUNT(*) FROM trials WHERE kind = 'trial' GROUP BY stimulus_id").fetch_all(&db.sqlite().reader).await.expect("counts")
    }

    #[tokio::test]
    async fn a_worker_starting_twice_in_one_batch_gets_one_participation() {
        let dir = tempfile::tempdir().expect("temp dir");
        let (db, id, design) = study(&dir, "", 4).await;
        let mut loads = StimulusLoads::default();
        let outcomes = store(&db.sqlite().writer, &mut loads, vec![start(id, &design, "w1"), start(id, &design, "w2"), start(id, &design, "w1")]).await.expect("batch");
        assert!(matches!(started(&outcomes[0]), Some(Started::New(_))));
        assert!(matches!(started(&outcomes[1]), Some(Started::New(_))));
        assert!(matches!(started(&outcomes[2]), Some(Started::Existing(_))));
        let Some(Started::Existing(existing)) = started(&outcomes[2]) else { panic!("not existing") };
        assert_eq!(*existing, super::super::token_sha256(&token(&outcomes[0])), "the first participation, by its token's hash");
        assert_ne!(token(&outcomes[1]), token(&outcomes[0]));
        let participations: i64 = sqlx::query_scalar("SELECT COUNT(*) FROM participants").fetch_one(&db.sqlite().reader).await.expect("count");
        assert_eq!(participations, 2);
    }

    #[tokio::test]
    async fn starts_in_one_batch_see_each_others_assignments() {
        let dir = tempfile::tempdir().expect("temp dir");
        let (db, id, design) = study(&dir, "trials_per_participant = 3", 10).await;
        let mut loads = StimulusLoads::default();
        // Ten shares of three over ten stimuli: least loaded first gives every stimulus three.
        let starts = (0..10).map(|w| start(id, &design, &format!("w{w}"))).collect();
        let outcomes = store(&db.sqlite().writer, &mut loads, starts).await.expect("batch");
        assert!(outcomes.iter().all(|o| matches!(started(o), Some(Started::New(_)))));
        assert_eq!(main_trials_per_stimulus(&db).await, vec![3; 10]);
    }

    #[tokio::test]
    async fn a_study_fills_up_within_a_batch() {
        let dir = tempfile::tempdir().expect("temp dir");
        let (db, id, design) = study(&dir, "trials_per_participant = 2\nratings_per_stimulus = 1", 4).await;
        let mut loads = StimulusLoads::default();
        let starts = (0..3).map(|w| start(id, &design, &format!("w{w}"))).collect();
        let outcomes = store(&db.sqlite().writer, &mut loads, starts).await.expect("batch");
        assert!(matches!(started(&outcomes[1]), Some(Started::New(_))));
        assert!(matches!(started(&outcomes[2]), Some(Started::Full)), "{:?}", outcomes[2]);
        assert_eq!(main_trials_per_stimulus(&db).await, vec![1; 4]);
    }

    #[tokio::test]
    async fn a_withdrawal_frees_its_stimuli_for_later_starts_in_the_batch() {
        let dir = tempfile::tempdir().expect("temp dir");
        let (db, id, design) = study(&dir, "trials_per_participant = 1\nratings_per_stimulus = 1", 2).await;
        let mut loads = StimulusLoads::default();
        let first = store(&db.sqlite().writer, &mut loads, vec![start(id, &design, "w1"), start(id, &design, "w2")]).await.expect("starts");
        let outcomes = store(&db.sqlite().writer, &mut loads, vec![start(id, &design, "w3"), Request::Withdraw { token: token(&first[0]) }, start(id, &design, "w3")]).await.expect("batch");
        assert!(matches!(started(&outcomes[0]), Some(Started::Full)), "{:?}", outcomes[0]);
        assert!(matches!(started(&outcomes[2]), Some(Started::New(_))), "{:?}", outcomes[2]);
    }

    #[tokio::test]
    async fn the_reaper_frees_expired_reservations_for_later_starts() {
        let dir = tempfile::tempdir().expect("temp dir");
        let (db, id, design) = study(&dir, "trials_per_participant = 1\nratings_per_stimulus = 1\nreservation_minutes = 30", 2).await;
        let mut loads = StimulusLoads::default();
        store(&db.sqlite().writer, &mut loads, vec![start(id, &design, "w1"), start(id, &design, "w2")]).await.expect("starts");
        let later = crate::db::now_ms() + 31 * 60_000;
        let outcomes = store(&db.sqlite().writer, &mut loads, vec![start(id, &design, "w3"), Request::Reap { now: later }, start(id, &design, "w3")]).await.expect("batch");
        assert!(matches!(started(&outcomes[0]), Some(Started::Full)), "{:?}", outcomes[0]);
        assert!(matches!(outcomes[1], Ok(Written::Reaped(2))), "{:?}", outcomes[1]);
        assert!(matches!(started(&outcomes[2]), Some(Started::New(_))), "{:?}", outcomes[2]);
    }

    #[tokio::test]
    async fn loads_are_kept_between_batches_and_counted_again_after_an_exclusion() {
        let dir = tempfile::tempdir().expect("temp dir");
        let (db, id, design) = study(&dir, "trials_per_participant = 1\nratings_per_stimulus = 1", 2).await;
        let mut loads = StimulusLoads::default();
        let first = store(&db.sqlite().writer, &mut loads, vec![start(id, &design, "w1")]).await.expect("start");
        let second = store(&db.sqlite().writer, &mut loads, vec![start(id, &design, "w2"), start(id, &design, "w3")]).await.expect("starts");
        assert!(matches!(started(&second[0]), Some(Started::New(_))), "the other stimulus: {:?}", second[0]);
        assert!(matches!(started(&second[1]), Some(Started::Full)), "{:?}", second[1]);
        assert_eq!(main_trials_per_stimulus(&db).await, vec![1, 1]);
        let public_id = db.participation(&token(&first[0])).await.expect("read").expect("participation").public_id;
        let exclude = Request::Exclude { study_id: id, public_id, excluded: true, reason: "test".into() };
        let third = store(&db.sqlite().writer, &mut loads, vec![exclude, start(id, &design, "w3")]).await.expect("batch");
        assert!(matches!(third[0], Ok(Written::Recorded)), "{:?}", third[0]);
        assert!(matches!(started(&third[1]), Some(Started::New(_))), "the excluded one's stimulus is free: {:?}", third[1]);
    }

    #[tokio::test]
    async fn a_failing_request_is_rolled_back_alone() {
        let dir = tempfile::tempdir().expect("temp dir");
        let (db, id, design) = study(&dir, "", 2).await;
        let mut loads = StimulusLoads::default();
        let first = store(&db.sqlite().writer, &mut loads, vec![start(id, &design, "w1"), start(id, &design, "w2"), start(id, &design, "w3")]).await.expect("starts");
        let (active, withdrawn, broken) = (token(&first[0]), token(&first[1]), token(&first[2]));
        db.withdraw(&withdrawn).await.expect("withdraw");
        // An SQL error part-way through a request: the consent of `broken` updates its row,
        // then logging the change fails.
        sqlx::raw_sql(sqlx::AssertSqlSafe(format!(
            "CREATE TRIGGER refuse BEFORE INSERT ON session_events WHEN NEW.participant_id = (SELECT id FROM participants WHERE token_sha256 = '{}')
             BEGIN SELECT RAISE(ABORT, 'refused'); END",
            super::super::token_sha256(&broken)
        )))
        .execute(&db.sqlite().writer)
        .await
        .expect("trigger");
        let answer = Answer::emotion("fear");
        let save = |key: &str| Request::Save(SaveRequest::new(&active, 0, key, &answer, SaveTiming::default(), &design));
        let consent = |token: &str| Request::Consent { token: token.to_string(), consent_sha256: design.consent_sha256() };
        let outcomes = store(&db.sqlite().writer, &mut loads, vec![consent(&active), consent(&broken), consent(&withdrawn), save("k1"), save("k2"), consent(&"0".repeat(32)), save("k1")])
            .await
            .expect("batch");
        assert!(matches!(outcomes[0], Ok(Written::Recorded)));
        assert!(matches!(outcomes[1], Err(DbError::Sql(_))), "{:?}", outcomes[1]);
        assert!(matches!(outcomes[2], Err(DbError::Conflict(_))), "{:?}", outcomes[2]);
        assert!(matches!(outcomes[3], Ok(Written::Saved(SaveOutcome { saved: Saved::Stored, remaining: 1, .. }))), "{:?}", outcomes[3]);
        assert!(matches!(outcomes[4], Err(DbError::Conflict(_))), "answered already: {:?}", outcomes[4]);
        assert!(matches!(outcomes[5], Err(DbError::NotFound(_))), "{:?}", outcomes[5]);
        assert!(matches!(outcomes[6], Ok(Written::Saved(SaveOutcome { saved: Saved::Repeated, .. }))), "{:?}", outcomes[6]);
        let state = |token: String| {
            let db = db.clone();
            async move {
                let p = db.participation(&token).await.expect("read").expect("participation");
                (p.state, p.consented)
            }
        };
        assert_eq!(state(active.clone()).await, (SessionState::Active, true));
        assert_eq!(state(broken).await, (SessionState::Reserved, false), "the consent's update was rolled back");
        assert_eq!(state(withdrawn).await, (SessionState::Withdrawn, false));
    }

    #[tokio::test]
    async fn a_screen_is_stored_whole_or_not_at_all() {
        let dir = tempfile::tempdir().expect("temp dir");
        let (db, id, design) = study(&dir, "", 3).await;
        let mut loads = StimulusLoads::default();
        let first = store(&db.sqlite().writer, &mut loads, vec![start(id, &design, "w1")]).await.expect("start");
        let token = token(&first[0]);
        db.give_consent(&token, &design.consent_sha256()).await.expect("consent");
        let answer = Answer::emotion("fear");
        let save = |position: i64, key: &str| SaveRequest::new(&token, position, key, &answer, SaveTiming::default(), &design);
        // The screen's second trial does not exist: its first is not stored either.
        let refused = store(&db.sqlite().writer, &mut loads, vec![Request::SaveScreen(vec![save(0, "s-0"), save(9, "s-9")])]).await.expect("batch");
        assert!(matches!(refused[0], Err(DbError::NotFound(_))), "{:?}", refused[0]);
        let p = db.participation(&token).await.expect("read").expect("participation");
        assert!(db.trials(p.id).await.expect("trials").iter().all(|t| !t.answered), "nothing of the refused screen was stored");
        let screen = || Request::SaveScreen(vec![save(0, "s-0"), save(1, "s-1")]);
        let stored = store(&db.sqlite().writer, &mut loads, vec![screen(), screen()]).await.expect("batch");
        assert!(matches!(stored[0], Ok(Written::Saved(SaveOutcome { saved: Saved::Stored, remaining: 1, .. }))), "the last trial's outcome: {:?}", stored[0]);
        assert!(matches!(stored[1], Ok(Written::Saved(SaveOutcome { saved: Saved::Repeated, .. }))), "a repeated screen: {:?}", stored[1]);
        let answered: Vec<bool> = db.trials(p.id).await.expect("trials").iter().map(|t| t.answered).collect();
        assert_eq!(answered, [true, true, false]);
    }

    #[tokio::test]
    async fn saves_in_one_batch_complete_or_screen_out_their_participations() {
        let dir = tempfile::tempdir().expect("temp dir");
        let check = "[attention]\nmax_failures = 1\nchecks = [{ instruction = \"choose fear\", measure = \"emotion\", value = \"fear\" }]";
        let (db, id, design) = study(&dir, check, 2).await;
        let mut loads = StimulusLoads::default();
        let first = store(&db.sqlite().writer, &mut loads, vec![start(id, &design, "careful"), start(id, &design, "careless")]).await.expect("starts");
        let tokens = [token(&first[0]), token(&first[1])];
        for token in &tokens {
            db.give_consent(token, &design.consent_sha256()).await.expect("consent");
        }
        // Every trial of both in one batch: the careful one answers the check as asked.
        let mut saves = Vec::new();
        for (token, at_check) in tokens.iter().zip(["fear", "surprise"]) {
            let p = db.participation(token).await.expect("read").expect("participation");
            for trial in db.trials(p.id).await.expect("trials") {
                let emotion = if trial.check_index.is_some() { at_check } else { "anger" };
                let answer = Answer::emotion(emotion);
                saves.push(Request::Save(SaveRequest::new(token, trial.position, &format!("{token}-{}", trial.position), &answer, SaveTiming::default(), &design)));
            }
        }
        let outcomes = store(&db.sqlite().writer, &mut loads, saves).await.expect("saves");
        let states: Vec<_> = outcomes.iter().map(|o| match o {
            Ok(Written::Saved(saved)) => Ok(saved.state),
            other => Err(format!("{other:?}")),
        }).collect();
        // Three trials each (two stimuli and the check); the careless one is out at the check,
        // and its later saves are refused.
        assert_eq!(&states[..3], &[Ok(SessionState::Active), Ok(SessionState::Active), Ok(SessionState::Completed)][..]);
        assert!(states[3..].contains(&Ok(SessionState::ScreenedOut)), "{states:?}");
        let events: Vec<(String, String)> = sqlx::query_as("SELECT to_state, reason FROM session_events WHERE from_state = 'active' ORDER BY id")
            .fetch_all(&db.sqlite().reader)
            .await
            .expect("events");
        assert_eq!(events, vec![("completed".into(), "last trial saved".into()), ("screened_out".into(), "failed 1 attention checks".into())]);
    }

    #[tokio::test]
    async fn the_study_of_a_token_is_remembered() {
        let dir = tempfile::tempdir().expect("temp dir");
        let (db, id, design) = study(&dir, "", 2).await;
        let Started::New(token) = db.start_participation(id, &design, &design.sources[0], "w1", "{}").await.expect("start") else { panic!("not new") };
        assert_eq!(db.participation_study(&token).await.expect("lookup"), Some(id));
        assert_eq!(db.studies_of_tokens.lock().expect("cache").get(&super::super::token_sha256(&token)), Some(id));
        assert_eq!(db.participation_study(&"0".repeat(32)).await.expect("lookup"), None);
    }

    /// What a batch holds, by name: `s:WORKER` for starts, `c:TOKEN` for consents.
    fn names(batch: &[Write]) -> Vec<String> {
        batch
            .iter()
            .map(|w| match &w.request {
                Request::Start(start) => format!("s:{}", start.worker_id),
                Request::Consent { token, .. } => format!("c:{token}"),
                other => format!("{other:?}"),
            })
            .collect()
    }

    #[tokio::test]
    async fn steps_go_ahead_of_a_burst_of_starts_which_keep_their_order() {
        let (_, design) = design("");
        let (sender, mut queue) = mpsc::channel(QUEUE);
        let send = |request| {
            let (reply, _) = oneshot::channel();
            sender.try_send(Write { request, reply }).expect("queue has room");
        };
        for w in 0..20 {
            send(start(1, &design, &format!("w{w:02}")));
        }
        for t in 0..3 {
            send(Request::Consent { token: format!("t{t}"), consent_sha256: String::new() });
        }
        let mut batches = Batches::default();
        let first = names(&batches.next(&mut queue).await.expect("a batch"));
        let starts = |range: std::ops::Range<usize>| range.map(|w| format!("s:w{w:02}")).collect::<Vec<_>>();
        let mut expected = starts(0..8);
        expected.extend(["c:t0", "c:t1", "c:t2"].map(String::from));
        assert_eq!(first, expected);
        // A start arriving now queues behind the held ones.
        send(start(1, &design, "w20"));
        send(Request::Consent { token: "t3".into(), consent_sha256: String::new() });
        let second = names(&batches.next(&mut queue).await.expect("a batch"));
        let mut expected = starts(8..16);
        expected.push("c:t3".into());
        assert_eq!(second, expected);
        let third = names(&batches.next(&mut queue).await.expect("a batch"));
        assert_eq!(third, starts(16..21));
        drop(sender);
        assert!(batches.next(&mut queue).await.is_none());
    }
}
