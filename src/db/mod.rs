//! The study database: one SQLite file (the default), or a PostgreSQL database that several
//! server instances share. Schemas in `migrations/sqlite/` and `migrations/postgres/` (applied on
//! open).
//!
//! In: study designs, participations, saves and admin actions from the web layer; a [`DbUrl`]
//! (a file path or a `postgres://` URL) saying where the data live. Out: typed rows and streams
//! for pages and exports. Times are Unix milliseconds.
//!
//! One code base for both backends: every query is written once with numbered placeholders
//! (`$1`, which SQLite reads as well) in SQL both engines run, and compiled once per backend
//! ([`on_backend!`] for pool-level reads and admin writes, the `steps!` of [`participants`] for
//! the participation changes). Rows are read through [`Fields`], which both row types have.
//! What must differ is per backend and small: the lock statements of the participation steps
//! (none on SQLite), opening and maintenance (WAL checkpoints, `VACUUM INTO`: SQLite only).
//!
//! Invariants on SQLite (design.md §6.9): WAL journal, foreign keys on, a busy timeout; every
//! read-then-write runs in one `BEGIN IMMEDIATE` transaction on the single writer connection, so
//! balance counts and idempotency checks never race; every change to participations (starts,
//! consent, demographics, saves, withdrawals, exclusions, the reaper) goes through the writer
//! task ([`writer`]), which stores whatever is waiting in one such transaction; readers use their
//! own pool and never block the writer; WAL pages are copied into the database file by a
//! checkpoint on a connection of its own, so commits do not wait for that I/O.
//!
//! Invariants on PostgreSQL ([`postgres`]): there is no single writer (several instances write
//! at once), so each participation change is one transaction (READ COMMITTED) that first locks
//! the rows its decision reads: a start locks its study's row (`FOR UPDATE`), so the starts of
//! one study run one at a time across every instance and each counts the loads and arms that
//! the previous ones committed; consent, demographics, saves and withdrawals lock their
//! participation's row; the reaper takes the expired rows `FOR UPDATE SKIP LOCKED`. Unique
//! constraints (one participation per worker and study, one answer per trial, one use of an
//! idempotency key) back the locks: a unique violation, a deadlock or a serialization failure
//! runs the request again, and the new run sees what the other instance committed. No
//! in-process memory decides anything: stimulus loads are counted in every start's transaction,
//! and the only cache ([`recent`]: which study a participation token belongs to) holds a fact
//! that never changes once written.

pub mod admin;
pub mod export;
pub mod psych_ds;
pub mod participants;
pub mod password;
pub mod postgres;
mod steps;
mod recent;
pub mod studies;
mod writer;

use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use sqlx::postgres::{PgRow, Postgres};
use sqlx::sqlite::{Sqlite, SqliteConnectOptions, SqliteJournalMode, SqlitePool, SqlitePoolOptions, SqliteRow, SqliteSynchronous};

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

/// Where the study database lives, as given to `--db`: a `postgres://` (or `postgresql://`)
/// URL, or else the path of an SQLite file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum DbUrl {
    Sqlite(PathBuf),
    Postgres(String),
}

impl FromStr for DbUrl {
    type Err = std::convert::Infallible;

    fn from_str(text: &str) -> Result<DbUrl, Self::Err> {
        Ok(if text.starts_with("postgres://") || text.starts_with("postgresql://") { DbUrl::Postgres(text.to_string()) } else { DbUrl::Sqlite(PathBuf::from(text)) })
    }
}

impl std::fmt::Display for DbUrl {
    /// The path, or the URL without its password.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            DbUrl::Sqlite(path) => write!(f, "{}", path.display()),
            DbUrl::Postgres(url) => match (url.find("://"), url.rfind('@')) {
                (Some(scheme), Some(at)) if at > scheme => {
                    let user = &url[scheme + 3..at];
                    let user = user.split(':').next().unwrap_or_default();
                    write!(f, "{}{user}{}", &url[..scheme + 3], &url[at..])
                }
                _ => f.write_str(url),
            },
        }
    }
}

impl From<&Path> for DbUrl {
    fn from(path: &Path) -> DbUrl {
        DbUrl::Sqlite(path.to_path_buf())
    }
}

impl From<&PathBuf> for DbUrl {
    fn from(path: &PathBuf) -> DbUrl {
        DbUrl::Sqlite(path.clone())
    }
}

impl From<&DbUrl> for DbUrl {
    fn from(url: &DbUrl) -> DbUrl {
        url.clone()
    }
}

/// A value both backends read and write (the Rust types the schema's columns map to).
pub(crate) trait Value: for<'r> sqlx::Decode<'r, Sqlite> + sqlx::Type<Sqlite> + for<'r> sqlx::Decode<'r, Postgres> + sqlx::Type<Postgres> {}
impl<T> Value for T where T: for<'r> sqlx::Decode<'r, Sqlite> + sqlx::Type<Sqlite> + for<'r> sqlx::Decode<'r, Postgres> + sqlx::Type<Postgres> {}

/// A column index (position or name) of both backends' rows.
pub(crate) trait Column: sqlx::ColumnIndex<SqliteRow> + sqlx::ColumnIndex<PgRow> {}
impl<T> Column for T where T: sqlx::ColumnIndex<SqliteRow> + sqlx::ColumnIndex<PgRow> {}

/// A row of either backend, read the same way (so row readers are written once).
pub(crate) trait Fields {
    /// The value of `column`; panics when the column is missing or of another type, as
    /// `sqlx::Row::get` does (the queries and the schema are ours).
    fn get<T: Value, I: Column>(&self, column: I) -> T;
}

impl Fields for SqliteRow {
    fn get<T: Value, I: Column>(&self, column: I) -> T {
        sqlx::Row::get(self, column)
    }
}

impl Fields for PgRow {
    fn get<T: Value, I: Column>(&self, column: I) -> T {
        sqlx::Row::get(self, column)
    }
}

/// Runs `$body` once per backend with `$backend` bound to it ([`SqliteBackend`] or
/// [`postgres::PgBackend`], which both have a `reader` and a `writer` pool and `immediate()`):
/// the body is written once and compiled for each.
macro_rules! on_backend {
    ($db:expr, $backend:ident => $body:expr) => {
        match &$db.backend {
            $crate::db::Backend::Sqlite($backend) => $body,
            $crate::db::Backend::Postgres($backend) => $body,
        }
    };
}
pub(crate) use on_backend;

/// The database behind a [`Db`].
#[derive(Clone, Debug)]
pub(crate) enum Backend {
    Sqlite(SqliteBackend),
    Postgres(postgres::PgBackend),
}

/// The three pools over one SQLite file, and the writer task's queue.
#[derive(Clone, Debug)]
pub(crate) struct SqliteBackend {
    /// One connection: every write, serialised in the pool's fair queue.
    pub(crate) writer: SqlitePool,
    /// Several connections for pages, progress and exports.
    pub(crate) reader: SqlitePool,
    /// One connection that copies the WAL into the database file ([`checkpoint_forever`]).
    checkpointer: SqlitePool,
    /// Participant writes, stored by the writer task in group commits.
    writes: tokio::sync::mpsc::Sender<writer::Write>,
}

impl SqliteBackend {
    /// Starts a read-then-write transaction that holds the write lock from its first statement.
    pub(crate) async fn immediate(&self) -> Result<sqlx::Transaction<'static, Sqlite>, DbError> {
        Ok(self.writer.begin_with("BEGIN IMMEDIATE").await?)
    }
}

/// The study database, on either backend.
#[derive(Clone, Debug)]
pub struct Db {
    pub(crate) backend: Backend,
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

static MIGRATOR: sqlx::migrate::Migrator = sqlx::migrate!("./migrations/sqlite");

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

impl SqliteBackend {
    /// Opens (creating if needed) the database file, applies the migrations and starts the
    /// writer and checkpoint tasks.
    async fn open(path: &Path) -> Result<SqliteBackend, DbError> {
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
        Ok(SqliteBackend { writer, reader, checkpointer, writes })
    }
}

impl Db {
    /// Opens the database at `url` (an SQLite file is created if needed) and applies the
    /// migrations.
    pub async fn open(url: impl Into<DbUrl>) -> Result<Db, DbError> {
        let backend = match url.into() {
            DbUrl::Sqlite(path) => Backend::Sqlite(SqliteBackend::open(&path).await?),
            DbUrl::Postgres(url) => Backend::Postgres(postgres::PgBackend::open(&url).await?),
        };
        Ok(Db { backend, studies_of_tokens: Arc::new(Mutex::new(recent::Recent::new(TOKENS_KEPT))) })
    }

    /// Writes a consistent copy of an SQLite database to `path` (`VACUUM INTO`, safe while
    /// serving). A PostgreSQL database is backed up with PostgreSQL's own tools.
    pub async fn backup(&self, path: &Path) -> Result<(), DbError> {
        match &self.backend {
            Backend::Sqlite(s) => {
                sqlx::query("VACUUM INTO ?").bind(path.to_string_lossy().into_owned()).execute(&s.reader).await?;
                Ok(())
            }
            Backend::Postgres(_) => Err(DbError::Invalid("a PostgreSQL database is backed up with pg_dump (for example: pg_dump -Fc -f lab.dump DATABASE_URL)".into())),
        }
    }

    pub async fn close(&self) {
        match &self.backend {
            Backend::Sqlite(s) => {
                s.writer.close().await;
                s.reader.close().await;
                s.checkpointer.close().await;
            }
            Backend::Postgres(p) => p.writer.close().await,
        }
    }

    /// Stores `request`: on SQLite through the writer task (waiting until its batch is
    /// committed), on PostgreSQL in a transaction of its own.
    async fn write(&self, request: writer::Request) -> Result<writer::Written, DbError> {
        let s = match &self.backend {
            Backend::Sqlite(s) => s,
            Backend::Postgres(p) => return p.store(request).await,
        };
        let closing = || DbError::Unavailable("the database is closing".into());
        let (reply, written) = tokio::sync::oneshot::channel();
        s.writes.send(writer::Write { request, reply }).await.map_err(|_| closing())?;
        written.await.map_err(|_| closing())?
    }

    /// The SQLite backend (tests look into the file).
    #[cfg(test)]
    pub(crate) fn sqlite(&self) -> &SqliteBackend {
        match &self.backend {
            Backend::Sqlite(s) => s,
            Backend::Postgres(_) => panic!("not an SQLite database"),
        }
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

    #[test]
    fn db_url_reads_a_postgres_url_or_a_path_and_never_shows_the_password() {
        let parse = |text: &str| text.parse::<DbUrl>().expect("infallible");
        assert_eq!(parse("lab.db"), DbUrl::Sqlite(PathBuf::from("lab.db")));
        assert_eq!(parse("/srv/postgres/lab.db"), DbUrl::Sqlite(PathBuf::from("/srv/postgres/lab.db")), "a path that mentions postgres is still a file");
        let url = "postgres://lab:s3cret@db.example.org:5432/facslab?sslmode=require";
        assert_eq!(parse(url), DbUrl::Postgres(url.to_string()));
        assert_eq!(parse(url).to_string(), "postgres://lab@db.example.org:5432/facslab?sslmode=require");
        assert_eq!(parse("postgresql://db/facslab").to_string(), "postgresql://db/facslab");
    }

    #[tokio::test]
    async fn the_checkpoint_task_copies_the_wal_into_the_database_file() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("checkpoint.db");
        let db = Db::open(&path).await.expect("database");
        let pages = |name: &'static str| {
            let reader = db.sqlite().reader.clone();
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
            std::fs::copy(Path::new(env!("CARGO_MANIFEST_DIR")).join("migrations/sqlite").join(name), old_migrations.join(name)).expect("copy");
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
        let stored: String = sqlx::query_scalar("SELECT token_sha256 FROM participants").fetch_one(&db.sqlite().reader).await.expect("row");
        assert_eq!(stored, token_sha256(&token));
        assert_eq!(db.participation(&token).await.expect("read").map(|p| p.id), Some(1), "the participant's link still works");
        db.close().await;
        let again = Db::open(&path).await.expect("reopen");
        let stored: String = sqlx::query_scalar("SELECT token_sha256 FROM participants").fetch_one(&again.sqlite().reader).await.expect("row");
        assert_eq!(stored, token_sha256(&token), "hashed once, not again");
    }
}
