-- Secrets are stored only as their SHA-256.
-- Participation tokens: the column keeps its UNIQUE constraint under its new name; the values
-- still in clear (32 hex digits) are replaced by their SHA-256 when the database is opened
-- (`Db::open`, right after the migrations), since SQLite has no SHA-256 of its own.
ALTER TABLE participants RENAME COLUMN token TO token_sha256;

-- An admin session's CSRF token is derived from its cookie token, so nothing is stored for it.
ALTER TABLE admin_sessions DROP COLUMN csrf_token;
CREATE INDEX admin_sessions_by_expiry ON admin_sessions (expires_at);

-- Export API tokens reach one study with one role until they expire. Tokens made before had
-- neither, so they are revoked (`facslab admin token` makes scoped ones).
DROP TABLE api_tokens;
CREATE TABLE api_tokens (
    token_sha256  TEXT    PRIMARY KEY,
    admin_id      INTEGER NOT NULL REFERENCES admins (id),
    study_id      INTEGER NOT NULL REFERENCES studies (id),
    role          TEXT    NOT NULL CHECK (role IN ('researcher', 'viewer')),
    label         TEXT    NOT NULL,
    created_at    INTEGER NOT NULL,
    expires_at    INTEGER NOT NULL
);
