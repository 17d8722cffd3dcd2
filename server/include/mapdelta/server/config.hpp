#pragma once
// The server's one configuration file (YAML). Every key has a default and a unit here;
// config/server.example.yaml documents each, src/config.cpp gives its range. Read by common's
// strict reader (config_reader.hpp): unknown keys are errors, and all problems are reported at
// once in one Error(kInvalidArgument) whose message lists them (exit code 2).
#include <cstdint>
#include <string>

namespace mapdelta::server {

struct HttpConfig {
  std::string listen_address = "127.0.0.1";
  int port = 8080;
  int threads = 8;                             // HTTP worker threads
  int64_t max_body_bytes = 1 << 20;            // JSON bodies
  int64_t max_keyframe_bytes = 8 << 20;        // one multipart keyframe upload
  int64_t max_prior_bytes = int64_t{1} << 30;  // a prior map import
  int read_timeout_s = 30;
  int write_timeout_s = 60;
  // The served observed octrees (GET /v1/observed/tiles/{t}.bt) kept per tile state, bytes;
  // least recently used out. 0 = off (every request merges the tile's session octrees).
  int64_t observed_cache_bytes = int64_t{64} << 20;
  // The web map's static files, served at /: "auto" (next to an installed binary in
  // ../share/mapdelta/web, or the source tree's web/dist for a binary in its build tree),
  // "off", or a folder. --web-root overrides it.
  std::string web_root = "auto";
};

struct StorageConfig {
  std::string backend = "sqlite";        // sqlite (embedded, one process) | postgres
  std::string database = "mapdelta.db";  // SQLite file (WAL files beside it); backend sqlite
  // libpq connection string for backend postgres ("postgresql://user@host:5432/mapdelta" or
  // "host=... dbname=..."); its password is never logged (PGPASSWORD / ~/.pgpass work too).
  std::string postgres_url;
  double tile_size_m = 50.0;
};

// The job worker. Its claim on a running job is a lease it renews every lease_s / 3: a
// worker that dies (SIGKILL, lost host) leaves its job to another worker once lease_s passed.
struct JobsConfig {
  int lease_s = 30;
};

struct LogConfig {
  std::string level = "info";   // debug | info | warn | error
  std::string format = "json";  // json | text
};

struct IngestConfig {
  int64_t max_keyframes_per_session = 20000;
  int max_image_width = 4096;
  int max_image_height = 4096;
};

// Parameters of the commit pipeline (paper section III-C and the reference config).
struct PipelineConfig {
  double max_depth_m = 50.0;         // th_d: pixels deeper than this are not used
  double free_space_depth_m = 15.0;  // th_f: free-space ray length for pixels without depth
  // Not in the paper: a no-depth pixel's free ray ends at the nearest valid depth within +-N px
  // (ObservedAreaParams::free_ray_bound_window_px; 0 = the paper's rule, always th_f). Sparse
  // stereo depth otherwise lets th_f rays pass through near walls: removed-point precision on
  // the simulator's tiny set (400 px wide, th_f 15) 0.14 -> 0.45 and 0.17 -> 0.74, recall
  // within 0.015 (docs in config/server.example.yaml).
  int free_ray_bound_px = 128;
  // The rule for the free space behind removed points, as mapdelta-detect --free-space
  // (ApplyFreeSpaceRule in common/change_detection.hpp): "paper" (Alg. 1-2 as published) or
  // "confident" (hit rays end 3 sigma(d) before the hit, a removed point's voxel must be seen
  // free by 3 keyframes net of hits, only voxels near the prior mask a removal).
  std::string free_space = "confident";
  // Under "confident": a voxel masks a removal only when one session put points of this many
  // keyframes in it (ChangeDetectionParams::mask_min_keyframes; 0 = off), or lies within
  // mask_weak_radius_m of a prior point (0 = only the count). Both as the detector's confident
  // rule: on eight paper cells R_rm 0.889 -> 0.912 for P_rm 0.927 -> 0.918 (docs/results.md).
  int mask_min_keyframes = 2;
  double mask_weak_radius_m = 0.5;
  double session_voxel_m = 0.8;      // voxel of the session cloud (0.4 - 0.8)
  double octree_resolution_m = 0.8;  // rho_o
  int pixel_stride = 2;              // every n-th pixel in u and v (session cloud and rays)
  bool gicp_enabled = true;          // paper step 2: align the session cloud to the prior
  double gicp_max_correspondence_m = 2.0;
  double gicp_max_fitness_m = 1.0;
  double gicp_max_correction_m = 4.0;
  int threads = 2;  // worker threads inside one job
  // Keyframes per unit of commit work: each unit builds its own observed octree, units are
  // merged in keyframe order, so the result does not depend on threads or scheduling. Smaller
  // units keep OctoMap's per-keyframe inner-node update cheap (it walks the whole tree).
  int chunk_keyframes = 32;
};

// Classification (paper Alg. 1 and 2) on each tile's aggregate; changeable by a reclassify job.
struct ClassifyConfig {
  double th_ch_m = 3.2;       // change distance threshold
  int min_voxel_support = 1;  // aggregated voxels seen by fewer sessions are ignored
  // With the confident free-space rule: an aggregated voxel that k sessions filled is ignored when
  // k other sessions were there without filling it: their octree knows it, or they filled a voxel
  // within consensus_reach_m (server/src/voxel_consensus.hpp).
  bool voxel_consensus = true;
  // The face and edge neighbours of a 0.8 m session voxel (0.8, 1.13 m); 0 = the octree alone.
  double consensus_reach_m = 1.2;
};

// Change clusters' lifecycle (issue #20; server/src/change_lifecycle.hpp has the rules).
struct LifecycleConfig {
  // A candidate is confirmed when at least confirm_sessions sessions support it (more than
  // contradict it) and those come from at least confirm_vehicles distinct vehicles, or were
  // recorded on at least confirm_vehicles distinct UTC days (independent noise: another drive).
  // As many contradicting sessions (more than support it) reject a candidate or expire a
  // confirmed cluster.
  int confirm_sessions = 2;
  int confirm_vehicles = 2;
  double cluster_link_m = 1.5;   // change points of one kind closer than this are one cluster
  double cluster_voxel_m = 1.0;  // voxel edge of a cluster's keys (matching across commits)
};

struct ServerConfig {
  HttpConfig http;
  StorageConfig storage;
  JobsConfig jobs;
  LogConfig log;
  IngestConfig ingest;
  PipelineConfig pipeline;
  ClassifyConfig classify;
  LifecycleConfig lifecycle;
};

// Throws Error(kInvalidArgument) if unreadable or listing every problem (unknown keys, types,
// out-of-range values) with its key path.
ServerConfig LoadServerConfig(const std::string& path);
// Validates ranges of an in-memory config (used by the loader and by tests).
void ValidateServerConfig(const ServerConfig& config);
// The effective configuration as YAML text (logged at start-up).
std::string DumpServerConfig(const ServerConfig& config);

}  // namespace mapdelta::server
