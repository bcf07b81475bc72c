-- What a task asks for (issue #24, scale-out of the accuracy statement): 0 for evaluations of
-- search points on the run's mesh (stored in the job's evaluations), k > 0 for the accuracy
-- statement's solves on the run's mesh refined k times (criteria values only, in `results`).
ALTER TABLE tasks ADD COLUMN refinement INTEGER NOT NULL DEFAULT 0;
