#include "mapdelta/server/config.hpp"

#include "mapdelta/common/config_reader.hpp"
#include "mapdelta/server/storage.hpp"

namespace mapdelta::server {
namespace {

// Every key once, with its range: the reader rejects what is not here, the echo prints all.
ConfigSchema Schema(ServerConfig& c) {
  HttpConfig& h = c.http;
  PipelineConfig& q = c.pipeline;
  ConfigSchema schema;
  schema.Field("http.listen_address", &h.listen_address)
      .Field("http.port", &h.port, 0, 65535)  // 0 = any free port
      .Field("http.threads", &h.threads, 1, 256)
      .Field("http.max_body_bytes", &h.max_body_bytes, 1024, INT64_MAX)
      .Field("http.max_keyframe_bytes", &h.max_keyframe_bytes, 1024, INT64_MAX)
      .Field("http.max_prior_bytes", &h.max_prior_bytes, 1024, INT64_MAX)
      .Field("http.read_timeout_s", &h.read_timeout_s, 1, 86400)
      .Field("http.write_timeout_s", &h.write_timeout_s, 1, 86400)
      .Field("http.observed_cache_bytes", &h.observed_cache_bytes, 0, INT64_MAX)
      .Field("http.web_root", &h.web_root)
      .Field("storage.backend", &c.storage.backend, {"sqlite", "postgres"})
      .OptionalField("storage.database", &c.storage.database)  // the rule below
      .OptionalField("storage.postgres_url", &c.storage.postgres_url)
      .Field("storage.tile_size_m", &c.storage.tile_size_m, 1.0, 1e6)
      .Field("jobs.lease_s", &c.jobs.lease_s, 1, 3600)
      .Field("log.level", &c.log.level, {"debug", "info", "warn", "error"})
      .Field("log.format", &c.log.format, {"json", "text"})
      .Field("ingest.max_keyframes_per_session", &c.ingest.max_keyframes_per_session, 1, INT64_MAX)
      .Field("ingest.max_image_width", &c.ingest.max_image_width, 1, 1 << 20)
      .Field("ingest.max_image_height", &c.ingest.max_image_height, 1, 1 << 20)
      .Field("pipeline.max_depth_m", &q.max_depth_m, 1e-3, 65.0)
      .Field("pipeline.free_space_depth_m", &q.free_space_depth_m, 0, 65.0)
      .Field("pipeline.free_ray_bound_px", &q.free_ray_bound_px, 0, 4096)
      .Field("pipeline.free_space", &q.free_space, {"paper", "confident"})
      .Field("pipeline.mask_min_keyframes", &q.mask_min_keyframes, 0, 100)
      .Field("pipeline.mask_weak_radius_m", &q.mask_weak_radius_m, 0, 5)
      .Field("pipeline.session_voxel_m", &q.session_voxel_m, 0.05, 5)
      .Field("pipeline.octree_resolution_m", &q.octree_resolution_m, 0.05, 5)
      .Field("pipeline.pixel_stride", &q.pixel_stride, 1, 16)
      .Field("pipeline.gicp_enabled", &q.gicp_enabled)
      .Field("pipeline.gicp_max_correspondence_m", &q.gicp_max_correspondence_m, 1e-6, 1e6)
      .Field("pipeline.gicp_max_fitness_m", &q.gicp_max_fitness_m, 1e-6, 1e6)
      .Field("pipeline.gicp_max_correction_m", &q.gicp_max_correction_m, 1e-6, 1e6)
      .Field("pipeline.threads", &q.threads, 1, 64)
      .Field("pipeline.chunk_keyframes", &q.chunk_keyframes, 1, 100000)
      .Field("classify.th_ch_m", &c.classify.th_ch_m, 1e-6, 50)
      .Field("classify.min_voxel_support", &c.classify.min_voxel_support, 1, 1000000)
      .Field("classify.voxel_consensus", &c.classify.voxel_consensus)
      .Field("classify.consensus_reach_m", &c.classify.consensus_reach_m, 0, 10)
      .Field("lifecycle.confirm_sessions", &c.lifecycle.confirm_sessions, 1, 1000)
      .Field("lifecycle.confirm_vehicles", &c.lifecycle.confirm_vehicles, 1, 1000)
      .Field("lifecycle.cluster_link_m", &c.lifecycle.cluster_link_m, 0.05, 50)
      .Field("lifecycle.cluster_voxel_m", &c.lifecycle.cluster_voxel_m, 0.05, 50)
      .Rule([&c] {
        if (c.storage.backend == "sqlite" && c.storage.database.empty())
          return "storage.database: must not be empty (backend sqlite)";
        if (c.storage.backend == "postgres" && c.storage.postgres_url.empty())
          return "storage.postgres_url: must be set for backend postgres (a libpq URL)";
        return "";
      })
      .Rule([&c] {
        return c.lifecycle.confirm_vehicles > c.lifecycle.confirm_sessions
                   ? "lifecycle.confirm_vehicles: must be <= lifecycle.confirm_sessions"
                   : "";
      })
      .Rule([&q] {
        return q.free_space_depth_m > q.max_depth_m
                   ? "pipeline.free_space_depth_m: must be <= pipeline.max_depth_m"
                   : "";
      });
  return schema;
}

}  // namespace

void ValidateServerConfig(const ServerConfig& config) {
  ServerConfig copy = config;  // the schema binds mutable fields
  ThrowIfInvalid(Schema(copy), "config");
}

ServerConfig LoadServerConfig(const std::string& path) {
  ServerConfig config;
  ReadConfigFile(path, Schema(config));
  return config;
}

std::string DumpServerConfig(const ServerConfig& config) {
  ServerConfig copy = config;
  copy.storage.postgres_url =
      RedactPostgresUrl(config.storage.postgres_url);  // no password in logs
  return ConfigToYaml(Schema(copy));
}

}  // namespace mapdelta::server
