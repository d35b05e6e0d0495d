//! The study databases the server tests run against: SQLite always, and PostgreSQL when
//! `FACSLAB_TEST_POSTGRES` holds the URL of a server the tests may create databases on (`.ci/run`
//! starts a throwaway one). Without it the PostgreSQL runs are skipped with a notice, unless
//! `FACSLAB_REQUIRE_TOOLS=1` (set in CI), where a missing server fails the test.
//!
//! Each test gets a database of its own ([`TestDb`]: an SQLite file in its temporary directory,
//! or a PostgreSQL database with a unique name, dropped afterwards), so tests run in parallel.

use std::path::Path;

use sqlx::Connection;

/// A database engine a test runs on.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Backend {
    Sqlite,
    /// The URL of a PostgreSQL server (any database on it; tests make their own).
    Postgres(String),
}

impl Backend {
    pub fn name(&self) -> &'static str {
        match self {
            Backend::Sqlite => "SQLite",
            Backend::Postgres(_) => "PostgreSQL",
        }
    }
}

/// The PostgreSQL server of `FACSLAB_TEST_POSTGRES`; `None` (after a notice) without one,
/// a failure under `FACSLAB_REQUIRE_TOOLS=1`.
pub fn postgres() -> Option<Backend> {
    match std::env::var("FACSLAB_TEST_POSTGRES") {
        Ok(url) if !url.is_empty() => Some(Backend::Postgres(url)),
        _ => {
            assert!(std::env::var("FACSLAB_REQUIRE_TOOLS").as_deref() != Ok("1"), "FACSLAB_TEST_POSTGRES is not set, and FACSLAB_REQUIRE_TOOLS=1 requires the PostgreSQL tests (.ci/run starts a server)");
            eprintln!("skipping the PostgreSQL run: set FACSLAB_TEST_POSTGRES=postgres://user@host:port/db (see .ci/postgres)");
            None
        }
    }
}

/// The backends to run a server test on: SQLite, and PostgreSQL when there is one.
pub fn backends() -> Vec<Backend> {
    std::iter::once(Backend::Sqlite).chain(postgres()).collect()
}

/// One test's database: `--db` takes [`TestDb::url`].
pub struct TestDb {
    pub url: String,
    /// The server's URL and the database's name, to drop it afterwards.
    made: Option<(String, String)>,
}

impl TestDb {
    /// A new, empty database on `backend` (SQLite: `lab.db` in `dir`).
    pub fn new(backend: &Backend, dir: &Path) -> TestDb {
        match backend {
            Backend::Sqlite => TestDb { url: dir.join("lab.db").to_string_lossy().into_owned(), made: None },
            Backend::Postgres(server) => {
                let name = format!("facslab_test_{}_{}", std::process::id(), random_hex());
                on_server(server, format!("CREATE DATABASE {name}"));
                TestDb { url: with_database(server, &name), made: Some((server.clone(), name)) }
            }
        }
    }
}

impl Drop for TestDb {
    fn drop(&mut self) {
        if let Some((server, name)) = self.made.take() {
            on_server(&server, format!("DROP DATABASE IF EXISTS {name} WITH (FORCE)"));
        }
    }
}

fn random_hex() -> String {
    let mut bytes = [0u8; 6];
    getrandom::fill(&mut bytes).unwrap();
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// `server` with its database name replaced by `name`.
fn with_database(server: &str, name: &str) -> String {
    let (base, query) = server.split_once('?').map_or((server, None), |(b, q)| (b, Some(q)));
    let authority_end = base.find("://").map_or(0, |i| i + 3);
    let root = match base[authority_end..].find('/') {
        Some(slash) => &base[..authority_end + slash],
        None => base,
    };
    match query {
        Some(q) => format!("{root}/{name}?{q}"),
        None => format!("{root}/{name}"),
    }
}

/// Runs one statement on the server's own database, on a thread of its own (tests may be inside
/// a runtime already).
fn on_server(server: &str, statement: String) {
    let server = server.to_string();
    std::thread::spawn(move || {
        let runtime = tokio::runtime::Builder::new_current_thread().enable_all().build().unwrap();
        runtime.block_on(async {
            let mut conn = sqlx::PgConnection::connect(&server).await.unwrap_or_else(|e| panic!("connecting to {server}: {e}"));
            sqlx::raw_sql(sqlx::AssertSqlSafe(statement.clone())).execute(&mut conn).await.unwrap_or_else(|e| panic!("{statement}: {e}"));
        })
    })
    .join()
    .unwrap();
}
