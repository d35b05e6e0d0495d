-- The study platform's tables. Times are Unix milliseconds (UTC).

-- A study: a design (the TOML it was created from) over one built stimulus set.
CREATE TABLE studies (
    id          INTEGER PRIMARY KEY,
    slug        TEXT    NOT NULL UNIQUE,
    title       TEXT    NOT NULL,
    spec_toml   TEXT    NOT NULL,
    set_dir     TEXT    NOT NULL,
    status      TEXT    NOT NULL CHECK (status IN ('draft', 'open', 'closed')),
    created_at  INTEGER NOT NULL
);

-- The stimuli a study shows (copied from the set's manifest when the study is created).
CREATE TABLE stimuli (
    study_id     INTEGER NOT NULL REFERENCES studies (id),
    stimulus_id  TEXT    NOT NULL,
    media        TEXT    NOT NULL CHECK (media IN ('image', 'video')),
    file         TEXT    NOT NULL,
    emotion      TEXT    NOT NULL,
    PRIMARY KEY (study_id, stimulus_id)
);

-- One participation (session) per worker per study.
CREATE TABLE participants (
    id                  INTEGER PRIMARY KEY,
    study_id            INTEGER NOT NULL REFERENCES studies (id),
    token               TEXT    NOT NULL UNIQUE,
    public_id           TEXT    NOT NULL UNIQUE,
    worker_id           TEXT    NOT NULL,
    platform            TEXT    NOT NULL,
    platform_params     TEXT    NOT NULL,
    grp                 TEXT    NOT NULL,
    seed                INTEGER NOT NULL,
    state               TEXT    NOT NULL CHECK (state IN ('reserved', 'active', 'completed', 'abandoned', 'withdrawn', 'screened_out')),
    consent_sha256      TEXT,
    attention_failures  INTEGER NOT NULL DEFAULT 0,
    excluded            INTEGER NOT NULL DEFAULT 0,
    exclusion_reason    TEXT,
    created_at          INTEGER NOT NULL,
    updated_at          INTEGER NOT NULL,
    expires_at          INTEGER NOT NULL,
    UNIQUE (study_id, worker_id)
);
CREATE INDEX participants_by_study_state ON participants (study_id, state, expires_at);

-- Every state change of a participation, with its reason.
CREATE TABLE session_events (
    id              INTEGER PRIMARY KEY,
    participant_id  INTEGER NOT NULL REFERENCES participants (id),
    from_state      TEXT,
    to_state        TEXT    NOT NULL,
    reason          TEXT    NOT NULL,
    at              INTEGER NOT NULL
);

-- A participant's trials in their presentation order.
CREATE TABLE trials (
    participant_id  INTEGER NOT NULL REFERENCES participants (id),
    position        INTEGER NOT NULL,
    kind            TEXT    NOT NULL CHECK (kind IN ('practice', 'trial', 'attention')),
    stimulus_id     TEXT    NOT NULL,
    check_index     INTEGER,
    PRIMARY KEY (participant_id, position)
);
CREATE INDEX trials_by_stimulus ON trials (stimulus_id, kind);

-- One saved answer per trial; the idempotency key makes a repeated save a no-op.
CREATE TABLE responses (
    id               INTEGER PRIMARY KEY,
    participant_id   INTEGER NOT NULL,
    position         INTEGER NOT NULL,
    idempotency_key  TEXT    NOT NULL UNIQUE,
    answers          TEXT    NOT NULL,
    rt_ms            REAL,
    video_ended      INTEGER,
    load_failed      INTEGER NOT NULL DEFAULT 0,
    received_at      INTEGER NOT NULL,
    UNIQUE (participant_id, position),
    FOREIGN KEY (participant_id, position) REFERENCES trials (participant_id, position)
);

CREATE TABLE demographics (
    participant_id  INTEGER PRIMARY KEY REFERENCES participants (id),
    age             INTEGER,
    gender          TEXT    NOT NULL,
    ethnicity       TEXT    NOT NULL,
    education       TEXT    NOT NULL
);

CREATE TABLE admins (
    id             INTEGER PRIMARY KEY,
    username       TEXT    NOT NULL UNIQUE,
    password_hash  TEXT    NOT NULL,
    role           TEXT    NOT NULL CHECK (role IN ('admin', 'researcher', 'viewer')),
    created_at     INTEGER NOT NULL
);

-- Admin logins; the cookie holds the token, the table its SHA-256.
CREATE TABLE admin_sessions (
    token_sha256  TEXT    PRIMARY KEY,
    admin_id      INTEGER NOT NULL REFERENCES admins (id),
    csrf_token    TEXT    NOT NULL,
    expires_at    INTEGER NOT NULL
);

-- Tokens for the export API (stored as SHA-256).
CREATE TABLE api_tokens (
    token_sha256  TEXT    PRIMARY KEY,
    admin_id      INTEGER NOT NULL REFERENCES admins (id),
    label         TEXT    NOT NULL,
    created_at    INTEGER NOT NULL
);
