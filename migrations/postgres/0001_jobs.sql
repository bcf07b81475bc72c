-- The job store of `wsm serve` and `wsm worker` on PostgreSQL (SPEC §5.4, issue #14): the same
-- tables as migrations/sqlite, with PostgreSQL types. Times are Unix seconds (DOUBLE PRECISION)
-- from the database clock; flags are 0/1 integers as on SQLite.

CREATE TABLE jobs (
    id               TEXT PRIMARY KEY,
    state            TEXT NOT NULL CHECK (state IN ('queued', 'running', 'succeeded', 'failed', 'cancelled')),
    scene            TEXT NOT NULL,
    settings         TEXT NOT NULL,
    scene_name       TEXT NOT NULL,
    criteria         TEXT NOT NULL,
    budget           BIGINT NOT NULL,
    run_hash         TEXT NOT NULL,
    created_at       DOUBLE PRECISION NOT NULL,
    started_at       DOUBLE PRECISION,
    finished_at      DOUBLE PRECISION,
    lease_owner      TEXT,
    lease_expires_at DOUBLE PRECISION,
    attempts         BIGINT NOT NULL DEFAULT 0,
    cancel_requested BIGINT NOT NULL DEFAULT 0,
    progress         TEXT,
    evaluations      BIGINT NOT NULL DEFAULT 0,
    result           TEXT,
    error            TEXT,
    error_kind       TEXT
);

CREATE INDEX jobs_by_state ON jobs (state, created_at);

CREATE TABLE evaluations (
    job_id     TEXT NOT NULL REFERENCES jobs (id) ON DELETE CASCADE,
    seq        BIGINT NOT NULL,
    body       TEXT NOT NULL,
    worker     TEXT NOT NULL,
    created_at DOUBLE PRECISION NOT NULL,
    PRIMARY KEY (job_id, seq)
);
