//! The PostgreSQL backend: a pool shared by every request of this instance, with other
//! instances writing to the same database at the same time.
//!
//! In: a `postgres://` URL; participation changes ([`writer::Request`], as on SQLite). Out: what
//! each stored ([`writer::Written`]). Each request is one transaction of its own (no batching:
//! group commit is SQLite's answer to its single writer), run by the same step functions as on
//! SQLite (`participants::in_postgres`), which on this backend first lock the rows their
//! decision reads (see the module doc of [`super`]).
//!
//! Invariants: a request whose transaction fails with a unique violation (another instance
//! committed the same participation, answer or idempotency key first), a deadlock or a
//! serialization failure is rolled back and run again, up to [`ATTEMPTS`] times, so the new run
//! decides on what the other instance committed; any other failure answers
//! [`DbError::Unavailable`] when nothing was stored, or the request's own error.

use std::sync::Arc;
use std::time::Duration;

use sqlx::postgres::{PgPool, PgPoolOptions, Postgres};

use super::participants::StimulusLoads;
use super::steps::in_postgres;
use super::writer::{Request, Written};
use super::DbError;

static MIGRATOR: sqlx::migrate::Migrator = sqlx::migrate!("./migrations/postgres");

/// Connections one instance opens (PostgreSQL's default limit is 100 for all instances).
const CONNECTIONS: u32 = 16;

/// How many times a request is run when it clashes with another instance's transaction.
pub(crate) const ATTEMPTS: usize = 8;

/// The PostgreSQL pool; `reader` and `writer` are the same pool (named as on SQLite, so code
/// written once for both backends reads the same).
#[derive(Clone, Debug)]
pub struct PgBackend {
    pub(crate) reader: PgPool,
    pub(crate) writer: PgPool,
    /// This instance's starts wait here for their turn before they take a connection: starts of
    /// a study run one at a time anyway (its row lock), and waiting here leaves the pool's other
    /// connections to saves. It only orders this instance's starts; the row lock decides.
    starts: Arc<tokio::sync::Mutex<()>>,
}

impl PgBackend {
    /// Connects and applies the migrations (sqlx holds an advisory lock while it migrates, so
    /// instances starting together migrate once).
    pub(crate) async fn open(url: &str) -> Result<PgBackend, DbError> {
        let pool = PgPoolOptions::new().max_connections(CONNECTIONS).acquire_timeout(Duration::from_secs(30)).connect(url).await?;
        MIGRATOR.run(&pool).await?;
        Ok(PgBackend { reader: pool.clone(), writer: pool, starts: Arc::default() })
    }

    /// A read-then-write transaction (READ COMMITTED; the statements in it lock what they need).
    pub(crate) async fn immediate(&self) -> Result<sqlx::Transaction<'static, Postgres>, DbError> {
        Ok(self.writer.begin().await?)
    }

    /// Stores one participation change in a transaction of its own, running it again when it
    /// clashed with another transaction.
    pub(crate) async fn store(&self, request: Request) -> Result<Written, DbError> {
        let _turn = match request {
            Request::Start(_) => Some(self.starts.lock().await),
            _ => None,
        };
        let mut attempt = 1;
        loop {
            match self.attempt(&request).await {
                Err(DbError::Sql(e)) if attempt < ATTEMPTS && clashed(&e) => {
                    attempt += 1;
                    tokio::time::sleep(Duration::from_millis(2 * attempt as u64)).await;
                }
                Err(DbError::Sql(e)) if clashed(&e) => return Err(DbError::Unavailable(format!("still clashing after {ATTEMPTS} attempts: {e}"))),
                other => return other,
            }
        }
    }

    async fn attempt(&self, request: &Request) -> Result<Written, DbError> {
        let mut tx = self.writer.begin().await?;
        // Loads are counted in this transaction, under the study's lock, never kept.
        let written = in_postgres::run(&mut tx, request.clone(), &mut StimulusLoads::uncached()).await?;
        tx.commit().await.map_err(|e| if clashed(&e) { DbError::Sql(e) } else { DbError::Unavailable(e.to_string()) })?;
        Ok(written)
    }
}

/// Whether `e` says another transaction got there first: a unique violation (23505), a
/// serialization failure (40001) or a deadlock (40P01).
fn clashed(e: &sqlx::Error) -> bool {
    matches!(e.as_database_error().and_then(|d| d.code()).as_deref(), Some("23505" | "40001" | "40P01"))
}
