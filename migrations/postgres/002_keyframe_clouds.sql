-- 002 for PostgreSQL (see ../002_keyframe_clouds.sql): the keyframe's cloud from upload time.
ALTER TABLE keyframes ADD COLUMN cloud BYTEA;
ALTER TABLE keyframes ADD COLUMN cloud_params TEXT;
