-- Fan-out of a job's evaluation batches (issue #14): the coordinator of a job posts each batch of
-- points as tasks; any worker leases a task, evaluates its points and stores the evaluations with
-- the task's results in one transaction. Workers announce themselves (threads, last heartbeat) so
-- that a coordinator can size its batches. Times are Unix seconds (REAL) from the database clock.

CREATE TABLE tasks (
    job_id           TEXT NOT NULL REFERENCES jobs (id) ON DELETE CASCADE,
    attempt          INTEGER NOT NULL,   -- the job's lease attempt that posted the task
    batch            INTEGER NOT NULL,   -- the coordinator's batch number within the attempt
    part             INTEGER NOT NULL,   -- the task's place in its batch
    points           TEXT NOT NULL,      -- JSON list of parameter points
    state            TEXT NOT NULL CHECK (state IN ('queued', 'running', 'done')),
    lease_owner      TEXT,
    lease_expires_at REAL,
    results          TEXT,               -- JSON list of evaluations, in point order
    created_at       REAL NOT NULL,
    finished_at      REAL,
    PRIMARY KEY (job_id, attempt, batch, part)
);

CREATE INDEX tasks_by_state ON tasks (state, created_at);

CREATE TABLE workers (
    owner      TEXT PRIMARY KEY,
    threads    INTEGER NOT NULL,
    started_at REAL NOT NULL,
    last_seen  REAL NOT NULL
);
