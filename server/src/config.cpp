#include "mapdelta/server/config.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <functional>
#include <map>
#include <sstream>
#include <vector>

#include "mapdelta/common/error.hpp"

namespace mapdelta::server {
namespace {

// Walks one YAML map, reading known keys and remembering every problem.
class Section {
 public:
  Section(const YAML::Node& node, std::string path, std::vector<std::string>* problems)
      : node_(node), path_(std::move(path)), problems_(problems) {
    if (node_ && !node_.IsMap()) problems_->push_back(path_ + ": expected a mapping");
  }
  ~Section() {
    if (!node_ || !node_.IsMap()) return;
    for (const auto& kv : node_) {
      // Never as<std::string>() here: a complex key ("? a: 1", found by fuzz_server_config)
      // made it throw, and a throwing destructor terminated the server instead of reporting.
      if (!kv.first.IsScalar()) {
        problems_->push_back(path_ + ": a key that is not a plain name");
        continue;
      }
      const std::string& key = kv.first.Scalar();
      if (!known_.count(key)) problems_->push_back(path_ + "." + key + ": unknown key");
    }
  }
  template <typename T>
  void Get(const std::string& key, T* value) {
    known_[key] = true;
    if (!node_ || !node_.IsMap() || !node_[key]) return;
    try {
      *value = node_[key].as<T>();
    } catch (const YAML::Exception&) {
      problems_->push_back(path_ + "." + key + ": wrong type (got '" + Scalar(node_[key]) + "')");
    }
  }
  Section Sub(const std::string& key) {
    known_[key] = true;
    return Section(node_ && node_.IsMap() ? node_[key] : YAML::Node(), path_ + "." + key, problems_);
  }

 private:
  static std::string Scalar(const YAML::Node& n) { return n.IsScalar() ? n.Scalar() : "non-scalar"; }
  YAML::Node node_;
  std::string path_;
  std::vector<std::string>* problems_;
  std::map<std::string, bool> known_;
};

void Check(bool ok, const std::string& what, std::vector<std::string>* problems) {
  if (!ok) problems->push_back(what);
}

void CollectRangeProblems(const ServerConfig& c, std::vector<std::string>* p) {
  Check(c.http.port >= 0 && c.http.port <= 65535, "http.port: must be in [0, 65535] (0 = any free port)", p);
  Check(c.http.threads >= 1 && c.http.threads <= 256, "http.threads: must be in [1, 256]", p);
  Check(c.http.max_body_bytes >= 1024, "http.max_body_bytes: must be >= 1024", p);
  Check(c.http.max_keyframe_bytes >= 1024, "http.max_keyframe_bytes: must be >= 1024", p);
  Check(c.http.max_prior_bytes >= 1024, "http.max_prior_bytes: must be >= 1024", p);
  Check(c.http.read_timeout_s > 0 && c.http.write_timeout_s > 0, "http.*_timeout_s: must be > 0", p);
  Check(!c.storage.database.empty(), "storage.database: must not be empty", p);
  Check(std::isfinite(c.storage.tile_size_m) && c.storage.tile_size_m >= 1.0,
        "storage.tile_size_m: must be >= 1 m", p);
  Check(c.log.level == "debug" || c.log.level == "info" || c.log.level == "warn" || c.log.level == "error",
        "log.level: must be debug, info, warn or error", p);
  Check(c.log.format == "json" || c.log.format == "text", "log.format: must be json or text", p);
  Check(c.ingest.max_keyframes_per_session > 0, "ingest.max_keyframes_per_session: must be > 0", p);
  Check(c.ingest.max_image_width > 0 && c.ingest.max_image_height > 0, "ingest.max_image_*: must be > 0", p);
  const PipelineConfig& q = c.pipeline;
  Check(q.max_depth_m > 0 && q.max_depth_m <= 65.0, "pipeline.max_depth_m: must be in (0, 65]", p);
  Check(q.free_space_depth_m >= 0 && q.free_space_depth_m <= q.max_depth_m,
        "pipeline.free_space_depth_m: must be in [0, max_depth_m]", p);
  Check(q.free_ray_bound_px >= 0 && q.free_ray_bound_px <= 4096,
        "pipeline.free_ray_bound_px: must be in [0, 4096]", p);
  Check(q.session_voxel_m >= 0.05 && q.session_voxel_m <= 5, "pipeline.session_voxel_m: must be in [0.05, 5]", p);
  Check(q.octree_resolution_m >= 0.05 && q.octree_resolution_m <= 5,
        "pipeline.octree_resolution_m: must be in [0.05, 5]", p);
  Check(q.pixel_stride >= 1 && q.pixel_stride <= 16, "pipeline.pixel_stride: must be in [1, 16]", p);
  Check(q.gicp_max_correspondence_m > 0 && q.gicp_max_fitness_m > 0 && q.gicp_max_correction_m > 0,
        "pipeline.gicp_*: must be > 0", p);
  Check(q.threads >= 1 && q.threads <= 64, "pipeline.threads: must be in [1, 64]", p);
  Check(q.chunk_keyframes >= 1 && q.chunk_keyframes <= 100000,
        "pipeline.chunk_keyframes: must be in [1, 100000]", p);
  Check(c.classify.th_ch_m > 0 && c.classify.th_ch_m <= 50, "classify.th_ch_m: must be in (0, 50]", p);
  Check(c.classify.min_voxel_support >= 1, "classify.min_voxel_support: must be >= 1", p);
}

std::string JoinProblems(const std::string& where, const std::vector<std::string>& problems) {
  std::ostringstream os;
  os << where << ": " << problems.size() << " problem(s):";
  for (const auto& p : problems) os << "\n  - " << p;
  return os.str();
}

}  // namespace

void ValidateServerConfig(const ServerConfig& config) {
  std::vector<std::string> problems;
  CollectRangeProblems(config, &problems);
  if (!problems.empty()) throw Error(ErrorCode::kInvalidArgument, JoinProblems("config", problems));
}

ServerConfig LoadServerConfig(const std::string& path) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw Error(ErrorCode::kIo, path + ": cannot read config file");
  } catch (const YAML::Exception& e) {
    throw Error(ErrorCode::kParse, path + ": not valid YAML: " + e.what());
  }
  ServerConfig c;
  std::vector<std::string> problems;
  {
    Section top(root, "config", &problems);
    {
      Section s = top.Sub("http");
      s.Get("listen_address", &c.http.listen_address);
      s.Get("port", &c.http.port);
      s.Get("threads", &c.http.threads);
      s.Get("max_body_bytes", &c.http.max_body_bytes);
      s.Get("max_keyframe_bytes", &c.http.max_keyframe_bytes);
      s.Get("max_prior_bytes", &c.http.max_prior_bytes);
      s.Get("read_timeout_s", &c.http.read_timeout_s);
      s.Get("write_timeout_s", &c.http.write_timeout_s);
    }
    {
      Section s = top.Sub("storage");
      s.Get("database", &c.storage.database);
      s.Get("tile_size_m", &c.storage.tile_size_m);
    }
    {
      Section s = top.Sub("log");
      s.Get("level", &c.log.level);
      s.Get("format", &c.log.format);
    }
    {
      Section s = top.Sub("ingest");
      s.Get("max_keyframes_per_session", &c.ingest.max_keyframes_per_session);
      s.Get("max_image_width", &c.ingest.max_image_width);
      s.Get("max_image_height", &c.ingest.max_image_height);
    }
    {
      Section s = top.Sub("pipeline");
      PipelineConfig& q = c.pipeline;
      s.Get("max_depth_m", &q.max_depth_m);
      s.Get("free_space_depth_m", &q.free_space_depth_m);
      s.Get("free_ray_bound_px", &q.free_ray_bound_px);
      s.Get("session_voxel_m", &q.session_voxel_m);
      s.Get("octree_resolution_m", &q.octree_resolution_m);
      s.Get("pixel_stride", &q.pixel_stride);
      s.Get("gicp_enabled", &q.gicp_enabled);
      s.Get("gicp_max_correspondence_m", &q.gicp_max_correspondence_m);
      s.Get("gicp_max_fitness_m", &q.gicp_max_fitness_m);
      s.Get("gicp_max_correction_m", &q.gicp_max_correction_m);
      s.Get("threads", &q.threads);
      s.Get("chunk_keyframes", &q.chunk_keyframes);
    }
    {
      Section s = top.Sub("classify");
      s.Get("th_ch_m", &c.classify.th_ch_m);
      s.Get("min_voxel_support", &c.classify.min_voxel_support);
    }
  }
  CollectRangeProblems(c, &problems);
  if (!problems.empty()) throw Error(ErrorCode::kParse, JoinProblems(path, problems));
  return c;
}

std::string DumpServerConfig(const ServerConfig& c) {
  YAML::Emitter e;
  e << YAML::BeginMap;
  e << YAML::Key << "http" << YAML::Value << YAML::BeginMap
    << YAML::Key << "listen_address" << YAML::Value << c.http.listen_address
    << YAML::Key << "port" << YAML::Value << c.http.port
    << YAML::Key << "threads" << YAML::Value << c.http.threads
    << YAML::Key << "max_body_bytes" << YAML::Value << c.http.max_body_bytes
    << YAML::Key << "max_keyframe_bytes" << YAML::Value << c.http.max_keyframe_bytes
    << YAML::Key << "max_prior_bytes" << YAML::Value << c.http.max_prior_bytes
    << YAML::Key << "read_timeout_s" << YAML::Value << c.http.read_timeout_s
    << YAML::Key << "write_timeout_s" << YAML::Value << c.http.write_timeout_s << YAML::EndMap;
  e << YAML::Key << "storage" << YAML::Value << YAML::BeginMap
    << YAML::Key << "database" << YAML::Value << c.storage.database
    << YAML::Key << "tile_size_m" << YAML::Value << c.storage.tile_size_m << YAML::EndMap;
  e << YAML::Key << "log" << YAML::Value << YAML::BeginMap
    << YAML::Key << "level" << YAML::Value << c.log.level
    << YAML::Key << "format" << YAML::Value << c.log.format << YAML::EndMap;
  e << YAML::Key << "ingest" << YAML::Value << YAML::BeginMap
    << YAML::Key << "max_keyframes_per_session" << YAML::Value << c.ingest.max_keyframes_per_session
    << YAML::Key << "max_image_width" << YAML::Value << c.ingest.max_image_width
    << YAML::Key << "max_image_height" << YAML::Value << c.ingest.max_image_height << YAML::EndMap;
  const PipelineConfig& q = c.pipeline;
  e << YAML::Key << "pipeline" << YAML::Value << YAML::BeginMap
    << YAML::Key << "max_depth_m" << YAML::Value << q.max_depth_m
    << YAML::Key << "free_space_depth_m" << YAML::Value << q.free_space_depth_m
    << YAML::Key << "free_ray_bound_px" << YAML::Value << q.free_ray_bound_px
    << YAML::Key << "session_voxel_m" << YAML::Value << q.session_voxel_m
    << YAML::Key << "octree_resolution_m" << YAML::Value << q.octree_resolution_m
    << YAML::Key << "pixel_stride" << YAML::Value << q.pixel_stride
    << YAML::Key << "gicp_enabled" << YAML::Value << q.gicp_enabled
    << YAML::Key << "gicp_max_correspondence_m" << YAML::Value << q.gicp_max_correspondence_m
    << YAML::Key << "gicp_max_fitness_m" << YAML::Value << q.gicp_max_fitness_m
    << YAML::Key << "gicp_max_correction_m" << YAML::Value << q.gicp_max_correction_m
    << YAML::Key << "threads" << YAML::Value << q.threads
    << YAML::Key << "chunk_keyframes" << YAML::Value << q.chunk_keyframes << YAML::EndMap;
  e << YAML::Key << "classify" << YAML::Value << YAML::BeginMap
    << YAML::Key << "th_ch_m" << YAML::Value << c.classify.th_ch_m
    << YAML::Key << "min_voxel_support" << YAML::Value << c.classify.min_voxel_support << YAML::EndMap;
  e << YAML::EndMap;
  return e.c_str();
}

}  // namespace mapdelta::server
