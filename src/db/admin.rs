//! Admin accounts (argon2 password hashes), login sessions with their CSRF token, and export
//! API tokens. Secrets are stored as hashes only: passwords as argon2 PHC strings, session and
//! API tokens as SHA-256.

use argon2::password_hash::{PasswordHash, PasswordHasher, PasswordVerifier, SaltString};
use argon2::Argon2;
use sqlx::Row;

use super::{Db, DbError, now_ms, secret_token, token_sha256};

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

/// Argon2id hash of a password (PHC string with a random salt).
pub fn hash_password(password: &str) -> Result<String, DbError> {
    let mut bytes = [0u8; 16];
    getrandom::fill(&mut bytes).map_err(|e| DbError::Conflict(format!("no random salt: {e}")))?;
    let salt = SaltString::encode_b64(&bytes).map_err(|e| DbError::Conflict(format!("salt: {e}")))?;
    Argon2::default().hash_password(password.as_bytes(), &salt).map(|h| h.to_string()).map_err(|e| DbError::Conflict(format!("password hashing failed: {e}")))
}

fn verify_password(password: &str, phc: &str) -> bool {
    PasswordHash::new(phc).is_ok_and(|hash| Argon2::default().verify_password(password.as_bytes(), &hash).is_ok())
}

impl Db {
    /// Creates an admin account (usernames are unique; passwords need 10 characters).
    pub async fn create_admin(&self, username: &str, password: &str, role: Role) -> Result<(), DbError> {
        if username.trim().is_empty() || username.len() > 64 {
            return Err(DbError::Conflict("a username needs 1-64 characters".into()));
        }
        if password.chars().count() < 10 {
            return Err(DbError::Conflict("a password needs at least 10 characters".into()));
        }
        let hash = hash_password(password)?;
        let done = sqlx::query("INSERT INTO admins (username, password_hash, role, created_at) VALUES (?, ?, ?, ?) ON CONFLICT (username) DO NOTHING")
            .bind(username)
            .bind(hash)
            .bind(role.as_str())
            .bind(now_ms())
            .execute(&self.writer)
            .await?;
        if done.rows_affected() == 0 {
            return Err(DbError::Conflict(format!("an admin \"{username}\" exists already")));
        }
        Ok(())
    }

    pub async fn admin_count(&self) -> Result<i64, DbError> {
        Ok(sqlx::query("SELECT COUNT(*) FROM admins").fetch_one(&self.reader).await?.get(0))
    }

    /// Checks a password; on success opens a session and returns its cookie token.
    pub async fn login(&self, username: &str, password: &str) -> Result<Option<String>, DbError> {
        let row = sqlx::query("SELECT id, password_hash FROM admins WHERE username = ?").bind(username).fetch_optional(&self.reader).await?;
        let Some(row) = row else {
            // Spend the same time as a real check, so timing does not reveal usernames.
            let _ = verify_password(password, "$argon2id$v=19$m=19456,t=2,p=1$c29tZXNhbHRzb21lc2FsdA$8S4kLqgpA4M5pyNCP3Gr7GOsAdsjvuyhVCoR33RUYAM");
            return Ok(None);
        };
        let phc: String = row.get(1);
        let ok = tokio::task::spawn_blocking({
            let password = password.to_string();
            move || verify_password(&password, &phc)
        })
        .await
        .unwrap_or(false);
        if !ok {
            return Ok(None);
        }
        let token = secret_token();
        sqlx::query("INSERT INTO admin_sessions (token_sha256, admin_id, csrf_token, expires_at) VALUES (?, ?, ?, ?)")
            .bind(token_sha256(&token))
            .bind(row.get::<i64, _>(0))
            .bind(secret_token())
            .bind(now_ms() + SESSION_MS)
            .execute(&self.writer)
            .await?;
        Ok(Some(token))
    }

    /// The admin behind a session cookie, if the session is live.
    pub async fn admin_session(&self, token: &str) -> Result<Option<AdminSession>, DbError> {
        let row = sqlx::query("SELECT a.id, a.username, a.role, s.csrf_token FROM admin_sessions s JOIN admins a ON a.id = s.admin_id WHERE s.token_sha256 = ? AND s.expires_at > ?")
            .bind(token_sha256(token))
            .bind(now_ms())
            .fetch_optional(&self.reader)
            .await?;
        Ok(row.and_then(|r| {
            Some(AdminSession { admin_id: r.get(0), username: r.get(1), role: Role::parse(r.get::<&str, _>(2))?, csrf_token: r.get(3) })
        }))
    }

    pub async fn logout(&self, token: &str) -> Result<(), DbError> {
        sqlx::query("DELETE FROM admin_sessions WHERE token_sha256 = ?").bind(token_sha256(token)).execute(&self.writer).await?;
        Ok(())
    }

    /// Creates an export API token for an admin (by username); returns it (shown once).
    pub async fn create_api_token(&self, username: &str, label: &str) -> Result<String, DbError> {
        let admin = sqlx::query("SELECT id FROM admins WHERE username = ?").bind(username).fetch_optional(&self.reader).await?;
        let admin: i64 = admin.ok_or_else(|| DbError::NotFound(format!("no admin \"{username}\"")))?.get(0);
        let token = format!("fl_{}", secret_token());
        sqlx::query("INSERT INTO api_tokens (token_sha256, admin_id, label, created_at) VALUES (?, ?, ?, ?)")
            .bind(token_sha256(&token))
            .bind(admin)
            .bind(label)
            .bind(now_ms())
            .execute(&self.writer)
            .await?;
        Ok(token)
    }

    /// Whether an API token is valid.
    pub async fn api_token_valid(&self, token: &str) -> Result<bool, DbError> {
        Ok(sqlx::query("SELECT 1 FROM api_tokens WHERE token_sha256 = ?").bind(token_sha256(token)).fetch_optional(&self.reader).await?.is_some())
    }
}
