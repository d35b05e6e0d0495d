//! The study database: one SQLite file, schema in `migrations/` (applied on open).
//!
//! In: study designs, participations, saves and admin actions from the web layer. Out: typed
//! rows and streams for pages and exports. Invariants (design.md §6.9): WAL journal, foreign keys
//! on, a busy timeout; every read-then-write runs in one `BEGIN IMMEDIATE` transaction on the
//! single writer connection, so balance counts and idempotency checks never race; every change
//! to participations (starts, consent, demographics, saves, withdrawals, exclusions, the reaper)
//! goes through the writer task ([`writer`]), which stores whatever is waiting in one such
//! transaction; readers use their own pool and never block the writer; WAL pages are copied into
//! the database file by a checkpoint on a connection of its own, so commits do not wait for that
//! I/O. Times are Unix milliseconds.

pub mod admin;
pub mod export;
pub mod psych_ds;
pub mod participants;
pub mod password;
mod recent;
pub mod studies;
mod writer;

use std::path::Path;
use std::str::FromStr;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use sqlx::sqlite::{SqliteConnectOptions, SqliteJournalMode, SqlitePool, SqlitePoolOptions, SqliteSynchronous};

/// What went wrong in the database layer.
#[derive(Debug, thiserror::Error)]
pub enum DbError {
    #[error("database: {0}")]
    Sql(#[from] sqlx::Error),
    #[error("database migrations: {0}")]
    Migrate(#[from] sqlx::migrate::MigrateError),
    /// The request clashes with what is stored (a second answer, a state that does not allow it).
    #[error("{0}")]
    Conflict(String),
    /// The request's content is not acceptable (a weak password, a bad manifest, a bound).
    #[error("{0}")]
    Invalid(String),
    /// Stored data that cannot be read back, or a failure of the system (randomness, hashing).
    #[error("{0}")]
    Internal(String),
    #[error("{0}")]
    NotFound(String),
    #[error("{0}")]
    Design(#[from] crate::study::DesignError),
    /// Nothing was written; the same request may be sent again.
    #[error("not saved, please retry: {0}")]
    Unavailable(String),
}

/// The two pools over one database file.
#[derive(Clone, Debug)]
pub struct Db {
    /// One connection: every write, serialised in the pool's fair queue.
    writer: SqlitePool,
    /// Several connections for pages, progress and exports.
    reader: SqlitePool,
    /// One connection that copies the WAL into the database file ([`checkpoint_forever`]).
    checkpointer: SqlitePool,
    /// Participant writes, stored by the writer task in group commits.
    writes: tokio::sync::mpsc::Sender<writer::Write>,
    /// Which study each recently seen participation token belongs to (this never changes).
    studies_of_tokens: Arc<Mutex<recent::Recent<String, i64>>>,
}

/// How many participation tokens [`Db::participation_study`] keeps in memory (per generation of
/// [`recent::Recent`]).
const TOKENS_KEPT: usize = 32_768;

/// WAL pages after which the writer checkpoints by itself (SQLite's default is 1,000): a
/// safety net, far above what the WAL holds between two runs of [`checkpoint_forever`] (about
/// 1,500 pages at 2,000 saves/s), because a checkpoint inside a commit holds up every write in
/// the batch (measured: 50 ms commits at the former 4,000).
const WRITER_CHECKPOINT_PAGES: &str = "16000";

/// How often [`checkpoint_forever`] copies the WAL into the database file: often, so that each
/// checkpoint's writes, which slow the writer's commits while they run, are short.
const CHECKPOINT_EVERY: Duration = Duration::from_millis(250);

/// Copies committed WAL pages into the database file on its own connection, so the writer's
/// commits do not wait for a checkpoint's writes and `fsync`s (`PASSIVE` takes no lock that
/// blocks the writer or readers). Ends when the database is closed or no [`Db`] is left (none
/// holds the writer's queue).
async fn checkpoint_forever(checkpointer: SqlitePool, writes: tokio::sync::mpsc::WeakSender<writer::Write>) {
    let mut tick = tokio::time::interval(CHECKPOINT_EVERY);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    loop {
        tick.tick().await;
        if checkpointer.is_closed() || writes.upgrade().is_none() {
            return;
        }
        if let Err(e) = sqlx::raw_sql("PRAGMA wal_checkpoint(PASSIVE)").execute(&checkpointer).await {
            tracing::warn!(error = %e, "WAL checkpoint failed");
        }
    }
}

static MIGRATOR: sqlx::migrate::Migrator = sqlx::migrate!("./migrations");

/// The data step of migration 0003: participation tokens still stored in clear (32 hex digits,
/// from databases made before it) are replaced by their SHA-256 (64 hex digits), in one
/// transaction; a database without such tokens is left as it is. Returns how many were hashed.
async fn hash_clear_tokens(writer: &SqlitePool) -> Result<usize, DbError> {
    let mut tx = writer.begin().await?;
    let clear: Vec<(i64, String)> = sqlx::query_as("SELECT id, token_sha256 FROM participants WHERE length(token_sha256) = 32").fetch_all(&mut *tx).await?;
    for (id, token) in &clear {
        sqlx::query("UPDATE participants SET token_sha256 = ? WHERE id = ?").bind(token_sha256(token)).bind(id).execute(&mut *tx).await?;
    }
    tx.commit().await?;
    Ok(clear.len())
}

impl Db {
    /// Opens (creating if needed) the database file and applies the migrations.
    pub async fn open(path: &Path) -> Result<Db, DbError> {
        let options = SqliteConnectOptions::from_str("sqlite:")?
            .filename(path)
            .create_if_missing(true)
            .journal_mode(SqliteJournalMode::Wal)
            .synchronous(SqliteSynchronous::Normal)
            .foreign_keys(true)
            .busy_timeout(Duration::from_secs(10));
        // No idle timeout or lifetime: SQLite connections do not go stale, and with either set
        // sqlx 0.9.0 runs a pool maintenance task that can spin at 100 % CPU under contention
        // (sqlx issue #3645).
        let pool = |connections| SqlitePoolOptions::new().max_connections(connections).test_before_acquire(false).idle_timeout(None).max_lifetime(None);
        let writer = pool(1).connect_with(options.clone().pragma("wal_autocheckpoint", WRITER_CHECKPOINT_PAGES)).await?;
        MIGRATOR.run(&writer).await?;
        hash_clear_tokens(&writer).await?;
        let checkpointer = pool(1).connect_with(options.clone()).await?;
        let reader = pool(4).connect_with(options.read_only(true)).await?;
        let (writes, queue) = tokio::sync::mpsc::channel(writer::QUEUE);
        tokio::spawn(writer::write_batches(writer.clone(), queue));
        tokio::spawn(checkpoint_forever(checkpointer.clone(), writes.downgrade()));
        Ok(Db { writer, reader, checkpointer, writes, studies_of_tokens: Arc::new(Mutex::new(recent::Recent::new(TOKENS_KEPT))) })
    }

    /// Writes a consistent copy of the database to `path` (`VACUUM INTO`, safe while serving).
    pub async fn backup(&self, path: &Path) -> Result<(), DbError> {
        sqlx::query("VACUUM INTO ?").bind(path.to_string_lossy().into_owned()).execute(&self.reader).await?;
        Ok(())
    }

    pub async fn close(&self) {
        self.writer.close().await;
        self.reader.close().await;
        self.checkpointer.close().await;
    }

    /// Hands `request` to the writer task and waits until its batch is committed.
    async fn write(&self, request: writer::Request) -> Result<writer::Written, DbError> {
        let closing = || DbError::Unavailable("the database is closing".into());
        let (reply, written) = tokio::sync::oneshot::channel();
        self.writes.send(writer::Write { request, reply }).await.map_err(|_| closing())?;
        written.await.map_err(|_| closing())?
    }

    /// Starts a read-then-write transaction that holds the write lock from its first statement.
    async fn immediate(&self) -> Result<sqlx::Transaction<'static, sqlx::Sqlite>, DbError> {
        Ok(self.writer.begin_with("BEGIN IMMEDIATE").await?)
    }
}

/// Now, in Unix milliseconds.
pub fn now_ms() -> i64 {
    std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_millis() as i64)
}

/// A fresh secret: 32 hex digits (128 bits) from the operating system.
pub fn secret_token() -> String {
    let mut bytes = [0u8; 16];
    // The OS generator only fails on platforms without one; there is nothing safe to fall back to.
    getrandom::fill(&mut bytes).expect("the operating system's random generator is unavailable");
    hex::encode(bytes)
}

/// SHA-256 of a token, as stored (tokens themselves are never stored).
pub fn token_sha256(token: &str) -> String {
    use sha2::Digest;
    hex::encode(sha2::Sha256::digest(token.as_bytes()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test]
    async fn the_checkpoint_task_copies_the_wal_into_the_database_file() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("checkpoint.db");
        let db = Db::open(&path).await.expect("database");
        let pages = |name: &'static str| {
            let reader = db.reader.clone();
            async move { sqlx::query_scalar::<_, i64>(name).fetch_one(&reader).await.expect("pragma") }
        };
        let size = pages("PRAGMA page_count").await * pages("PRAGMA page_size").await;
        tokio::time::sleep(CHECKPOINT_EVERY * 2).await;
        let on_disk = std::fs::metadata(&path).expect("database file").len();
        assert_eq!(on_disk as i64, size, "the migrations' pages are in the database file, not only in the WAL");
    }

    #[tokio::test]
    async fn clear_tokens_of_older_databases_are_hashed_on_open() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("old.db");
        // A database as the two first migrations left it, with a participation token in clear.
        let old_migrations = dir.path().join("migrations");
        std::fs::create_dir_all(&old_migrations).expect("dir");
        for name in ["0001_study_platform.sql", "0002_participants_index_without_expiry.sql"] {
            std::fs::copy(Path::new(env!("CARGO_MANIFEST_DIR")).join("migrations").join(name), old_migrations.join(name)).expect("copy");
        }
        let options = SqliteConnectOptions::from_str("sqlite:").expect("options").filename(&path).create_if_missing(true);
        let pool = SqlitePool::connect_with(options).await.expect("old database");
        sqlx::migrate::Migrator::new(old_migrations.as_path()).await.expect("migrator").run(&pool).await.expect("old schema");
        let token = secret_token();
        sqlx::raw_sql(sqlx::AssertSqlSafe(format!(
            "INSERT INTO studies VALUES (1, 's', 'S', '', 'set', 'open', 0);
             INSERT INTO participants (id, study_id, token, public_id, worker_id, platform, platform_params, grp, seed, state, created_at, updated_at, expires_at)
             VALUES (1, 1, '{token}', 'p1', 'w1', 'local', '{{}}', 'g', 1, 'active', 0, 0, 0);"
        )))
        .execute(&pool)
        .await
        .expect("old rows");
        pool.close().await;

        let db = Db::open(&path).await.expect("open with the new migrations");
        let stored: String = sqlx::query_scalar("SELECT token_sha256 FROM participants").fetch_one(&db.reader).await.expect("row");
        assert_eq!(stored, token_sha256(&token));
        assert_eq!(db.participation(&token).await.expect("read").map(|p| p.id), Some(1), "the participant's link still works");
        db.close().await;
        let again = Db::open(&path).await.expect("reopen");
        let stored: String = sqlx::query_scalar("SELECT token_sha256 FROM participants").fetch_one(&again.reader).await.expect("row");
        assert_eq!(stored, token_sha256(&token), "hashed once, not again");
    }
}
