//! Admin accounts (argon2 password hashes), login sessions with their CSRF token, and export
//! API tokens scoped to one study and a role until they expire. Secrets are stored as hashes
//! only: passwords as argon2 PHC strings, session and API tokens as SHA-256; a session's CSRF
//! token is derived from its cookie token ([`csrf_token`]) and not stored at all. Argon2 runs
//! on a blocking thread, never on the async runtime.

use argon2::password_hash::{PasswordHash, PasswordHasher, PasswordVerifier, SaltString};
use argon2::Argon2;
use super::{Db, DbError, now_ms, on_backend, secret_token, token_sha256};

/// What an admin may do.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Role {
    /// Sees progress and downloads exports.
    Viewer,
    /// Also creates, opens and closes studies and excludes participants.
    Researcher,
    /// Also manages admin accounts and API tokens.
    Admin,
}

impl Role {
    pub fn as_str(self) -> &'static str {
        match self {
            Role::Viewer => "viewer",
            Role::Researcher => "researcher",
            Role::Admin => "admin",
        }
    }

    pub fn parse(text: &str) -> Option<Role> {
        [Role::Viewer, Role::Researcher, Role::Admin].into_iter().find(|r| r.as_str() == text)
    }
}

/// A logged-in admin.
#[derive(Debug, Clone, serde::Serialize)]
pub struct AdminSession {
    pub admin_id: i64,
    pub username: String,
    pub role: Role,
    pub csrf_token: String,
}

/// How long a login lasts.
const SESSION_MS: i64 = 12 * 3600 * 1000;

/// Longest life of an export API token, in days.
pub const MAX_TOKEN_DAYS: u32 = 365;

/// What an export API token may reach.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ApiScope {
    pub study_id: i64,
    /// The token's role, never above its owner's role now.
    pub role: Role,
}

/// The CSRF token of the session whose cookie token is `session_token`: a SHA-256 of it under
/// its own label, so it can be put in forms without storing it and without revealing the
/// cookie (whose SHA-256 is what the sessions table holds).
pub fn csrf_token(session_token: &str) -> String {
    token_sha256(&format!("facslab csrf\0{session_token}"))
}

/// Argon2 on a blocking thread (it takes tens of milliseconds of CPU on purpose).
async fn blocking<T: Send + 'static>(work: impl FnOnce() -> T + Send + 'static) -> Result<T, DbError> {
    tokio::task::spawn_blocking(work).await.map_err(|e| DbError::Unavailable(format!("password check: {e}")))
}

/// Argon2id hash of a password (PHC string with a random salt).
pub fn hash_password(password: &str) -> Result<String, DbError> {
    let mut bytes = [0u8; 16];
    getrandom::fill(&mut bytes).map_err(|e| DbError::Internal(format!("no random salt: {e}")))?;
    let salt = SaltString::encode_b64(&bytes).map_err(|e| DbError::Internal(format!("salt: {e}")))?;
    Argon2::default().hash_password(password.as_bytes(), &salt).map(|h| h.to_string()).map_err(|e| DbError::Internal(format!("password hashing failed: {e}")))
}

fn verify_password(password: &str, phc: &str) -> bool {
    PasswordHash::new(phc).is_ok_and(|hash| Argon2::default().verify_password(password.as_bytes(), &hash).is_ok())
}

impl Db {
    /// Creates an admin account (usernames are unique; passwords need 10 characters).
    pub async fn create_admin(&self, username: &str, password: &str, role: Role) -> Result<(), DbError> {
        if username.trim().is_empty() || username.len() > 64 {
            return Err(DbError::Invalid("a username needs 1-64 characters".into()));
        }
        crate::db::password::check(username, password).map_err(|e| DbError::Invalid(e.to_string()))?;
        let hash = blocking({
            let password = password.to_string();
            move || hash_password(&password)
        })
        .await??;
        let sql = "INSERT INTO admins (username, password_hash, role, created_at) VALUES ($1, $2, $3, $4) ON CONFLICT (username) DO NOTHING";
        let done = on_backend!(self, b => sqlx::query(sql).bind(username).bind(&hash).bind(role.as_str()).bind(now_ms()).execute(&b.writer).await?.rows_affected());
        if done == 0 {
            return Err(DbError::Conflict(format!("an admin \"{username}\" exists already")));
        }
        Ok(())
    }

    pub async fn admin_count(&self) -> Result<i64, DbError> {
        Ok(on_backend!(self, b => sqlx::query_scalar("SELECT COUNT(*) FROM admins").fetch_one(&b.reader).await?))
    }

    /// Checks a password; on success opens a session and returns its cookie token.
    pub async fn login(&self, username: &str, password: &str) -> Result<Option<String>, DbError> {
        let sql = "SELECT id, password_hash FROM admins WHERE username = $1";
        let row: Option<(i64, String)> = on_backend!(self, b => sqlx::query_as(sql).bind(username).fetch_optional(&b.reader).await?);
        // Without the account, spend the same time on a stand-in hash, so timing does not
        // reveal usernames.
        let (admin, phc) = match row {
            Some((id, phc)) => (Some(id), phc),
            None => (None, "$argon2id$v=19$m=19456,t=2,p=1$c29tZXNhbHRzb21lc2FsdA$8S4kLqgpA4M5pyNCP3Gr7GOsAdsjvuyhVCoR33RUYAM".to_string()),
        };
        let password = password.to_string();
        let ok = blocking(move || verify_password(&password, &phc)).await?;
        let Some(admin) = admin.filter(|_| ok) else {
            return Ok(None);
        };
        let token = secret_token();
        let sql = "INSERT INTO admin_sessions (token_sha256, admin_id, expires_at) VALUES ($1, $2, $3)";
        on_backend!(self, b => sqlx::query(sql).bind(token_sha256(&token)).bind(admin).bind(now_ms() + SESSION_MS).execute(&b.writer).await?.rows_affected());
        Ok(Some(token))
    }

    /// The row `sql` finds for a secret that is live now (`sql` takes the secret's SHA-256 and
    /// now; its columns are an integer and two texts).
    async fn live_secret(&self, sql: &'static str, token: &str) -> Result<Option<(i64, String, String)>, DbError> {
        Ok(on_backend!(self, b => sqlx::query_as(sql).bind(token_sha256(token)).bind(now_ms()).fetch_optional(&b.reader).await?))
    }

    /// The admin behind a session cookie, if the session is live.
    pub async fn admin_session(&self, token: &str) -> Result<Option<AdminSession>, DbError> {
        let sql = "SELECT a.id, a.username, a.role FROM admin_sessions s JOIN admins a ON a.id = s.admin_id WHERE s.token_sha256 = $1 AND s.expires_at > $2";
        Ok(self.live_secret(sql, token).await?.and_then(|r| {
            Some(AdminSession { admin_id: r.0, username: r.1, role: Role::parse(&r.2)?, csrf_token: csrf_token(token) })
        }))
    }

    pub async fn logout(&self, token: &str) -> Result<(), DbError> {
        on_backend!(self, b => sqlx::query("DELETE FROM admin_sessions WHERE token_sha256 = $1").bind(token_sha256(token)).execute(&b.writer).await?.rows_affected());
        Ok(())
    }

    /// Deletes the login sessions that expired before `now`; returns how many.
    pub async fn purge_expired_sessions(&self, now: i64) -> Result<u64, DbError> {
        Ok(on_backend!(self, b => sqlx::query("DELETE FROM admin_sessions WHERE expires_at <= $1").bind(now).execute(&b.writer).await?.rows_affected()))
    }

    /// Creates an export API token for an admin (by username) that reaches study `slug` with
    /// `role` (viewer or researcher, at most the admin's own) for `days` days; returns it
    /// (shown once).
    pub async fn create_api_token(&self, username: &str, slug: &str, role: Role, days: u32, label: &str) -> Result<String, DbError> {
        if !(1..=MAX_TOKEN_DAYS).contains(&days) {
            return Err(DbError::Invalid(format!("a token lasts 1 to {MAX_TOKEN_DAYS} days, not {days}")));
        }
        let sql = "SELECT id, role FROM admins WHERE username = $1";
        let admin: Option<(i64, String)> = on_backend!(self, b => sqlx::query_as(sql).bind(username).fetch_optional(&b.reader).await?);
        let (admin_id, owner) = admin.ok_or_else(|| DbError::NotFound(format!("no admin \"{username}\"")))?;
        let owner = Role::parse(&owner).unwrap_or(Role::Viewer);
        if role == Role::Admin || role > owner {
            return Err(DbError::Invalid(format!("a token's role is viewer or researcher, at most its owner's ({})", owner.as_str())));
        }
        let study = self.study_by_slug(slug).await?.ok_or_else(|| DbError::NotFound(format!("no study \"{slug}\"")))?;
        let token = format!("fl_{}", secret_token());
        let now = now_ms();
        let sql = "INSERT INTO api_tokens (token_sha256, admin_id, study_id, role, label, created_at, expires_at) VALUES ($1, $2, $3, $4, $5, $6, $7)";
        let expires = now + i64::from(days) * 86_400_000;
        on_backend!(self, b => sqlx::query(sql).bind(token_sha256(&token)).bind(admin_id).bind(study.id).bind(role.as_str()).bind(label).bind(now).bind(expires).execute(&b.writer).await?.rows_affected());
        Ok(token)
    }

    /// What an API token reaches now: `None` when it is unknown or expired. Its role is capped
    /// by its owner's role now.
    pub async fn api_token_scope(&self, token: &str) -> Result<Option<ApiScope>, DbError> {
        let sql = "SELECT t.study_id, t.role, a.role FROM api_tokens t JOIN admins a ON a.id = t.admin_id WHERE t.token_sha256 = $1 AND t.expires_at > $2";
        Ok(self.live_secret(sql, token).await?.and_then(|r| {
            let role = Role::parse(&r.1)?.min(Role::parse(&r.2)?);
            Some(ApiScope { study_id: r.0, role })
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test]
    async fn expired_sessions_are_purged_and_live_ones_kept() {
        let dir = tempfile::tempdir().expect("temp dir");
        let db = Db::open(&dir.path().join("admin.db")).await.expect("database");
        db.create_admin("alice", "correct horse battery", Role::Admin).await.expect("admin");
        let token = db.login("alice", "correct horse battery").await.expect("login").expect("session");
        assert_eq!(db.purge_expired_sessions(now_ms()).await.expect("purge"), 0);
        assert!(db.admin_session(&token).await.expect("read").is_some());
        assert_eq!(db.purge_expired_sessions(now_ms() + SESSION_MS + 1).await.expect("purge"), 1);
        assert!(db.admin_session(&token).await.expect("read").is_none());
    }

    #[test]
    fn the_csrf_token_is_not_the_stored_hash() {
        let token = secret_token();
        assert_ne!(csrf_token(&token), token_sha256(&token));
        assert_eq!(csrf_token(&token), csrf_token(&token));
    }
}
