-- 003 for PostgreSQL (see ../003_job_leases.sql): job leases for several worker processes.
ALTER TABLE jobs ADD COLUMN lease_owner TEXT;
ALTER TABLE jobs ADD COLUMN lease_expires_ms BIGINT;
