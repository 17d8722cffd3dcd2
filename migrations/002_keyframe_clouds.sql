-- Per-keyframe back-projected cloud, computed at upload time (the upload already decodes the
-- PNG to validate it), so that a commit decodes each depth PNG once instead of twice.
-- cloud: EncodePoints blob (voxel-filtered, map frame, uploaded pose); cloud_params: the
-- pipeline parameters it was computed with. NULL (older rows) or different parameters: the
-- commit recomputes the cloud from depth_png.
ALTER TABLE keyframes ADD COLUMN cloud BLOB;
ALTER TABLE keyframes ADD COLUMN cloud_params TEXT;
