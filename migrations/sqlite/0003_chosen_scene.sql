-- The scene a job's coordinator chose for its target error (issue #13: the mesh sizes of the
-- coarsest level that meets it), so that workers evaluating the job's tasks use it instead of
-- repeating the choice (several cold direct solves per worker). NULL without a target error.
ALTER TABLE jobs ADD COLUMN chosen_scene TEXT;
