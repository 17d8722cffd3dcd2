-- 003: job leases, so that several worker processes can share the jobs table (PostgreSQL;
-- SQLite has one process but the same schema). A claimed job belongs to lease_owner (a
-- worker's id: host, pid and a random part) until lease_expires_ms; the worker renews the
-- lease while it runs the job. A running job whose lease ran out (its worker was killed) is
-- claimed again by the next free worker and resumes from what is stored (job_tiles).
ALTER TABLE jobs ADD COLUMN lease_owner TEXT;
ALTER TABLE jobs ADD COLUMN lease_expires_ms INTEGER;
