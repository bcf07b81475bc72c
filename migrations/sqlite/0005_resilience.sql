-- Issue #44. `lost_leases`: how often a job's lease expired while it ran (its worker process
-- died — killed, out of memory — or hung); a job is not leased again after `max_attempts` of
-- them (it fails naming the cause). `store_probe`: the row the health probe writes and commits
-- every few seconds, so that `/healthz` sees a database that no longer takes writes.
ALTER TABLE jobs ADD COLUMN lost_leases INTEGER NOT NULL DEFAULT 0;

CREATE TABLE store_probe (
    id        INTEGER PRIMARY KEY,
    probed_at DOUBLE PRECISION NOT NULL
);
