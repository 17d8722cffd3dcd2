-- 004 for PostgreSQL (see ../004_rollback_job.sql): the 'rollback' job type. PostgreSQL alters
-- the CHECK constraint in place (its default name, from 001's column constraint).
ALTER TABLE jobs DROP CONSTRAINT jobs_type_check;
ALTER TABLE jobs ADD CONSTRAINT jobs_type_check
  CHECK (type IN ('commit', 'refresh', 'reclassify', 'rollback'));
