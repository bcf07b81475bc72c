-- The job store of `wsm serve` on SQLite (SPEC §5.4): jobs with their lease, progress and
-- result, and every evaluation of every job as it completed (what a resumed job replays).
-- Times are Unix seconds (REAL).

CREATE TABLE jobs (
    id               TEXT PRIMARY KEY,
    state            TEXT NOT NULL CHECK (state IN ('queued', 'running', 'succeeded', 'failed', 'cancelled')),
    scene            TEXT NOT NULL,   -- the scene document (JSON)
    settings         TEXT NOT NULL,   -- the worst-scenario request (JSON)
    scene_name       TEXT NOT NULL,
    criteria         TEXT NOT NULL,   -- JSON list of criterion names
    budget           INTEGER NOT NULL,
    run_hash         TEXT NOT NULL,
    created_at       REAL NOT NULL,
    started_at       REAL,
    finished_at      REAL,
    lease_owner      TEXT,
    lease_expires_at REAL,
    attempts         INTEGER NOT NULL DEFAULT 0,
    cancel_requested INTEGER NOT NULL DEFAULT 0,
    progress         TEXT,            -- the last progress event (JSON)
    evaluations      INTEGER NOT NULL DEFAULT 0,
    result           TEXT,            -- the outcome (JSON), also for cancelled and timed-out runs
    error            TEXT,
    error_kind       TEXT
);

CREATE INDEX jobs_by_state ON jobs (state, created_at);

CREATE TABLE evaluations (
    job_id     TEXT NOT NULL REFERENCES jobs (id) ON DELETE CASCADE,
    seq        INTEGER NOT NULL,      -- 1-based, in order of completion
    body       TEXT NOT NULL,         -- the evaluation (JSON, exact round trip of every number)
    worker     TEXT NOT NULL,
    created_at REAL NOT NULL,
    PRIMARY KEY (job_id, seq)
);
