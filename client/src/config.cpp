#include "mapdelta/client/config.hpp"

#include <yaml-cpp/yaml.h>

#include <functional>
#include <map>
#include <sstream>
#include <variant>
#include <vector>

#include "mapdelta/common/error.hpp"

namespace mapdelta::client {
namespace {

// One table of every field: lets the parser reject unknown keys and lets ToYaml echo all.
struct Field {
  std::string section, key;
  std::variant<int*, double*, std::string*> value;
  double min = -1e300, max = 1e300;
};

std::vector<Field> Fields(ClientConfig& c) {
  auto& s = c.stereo;
  auto& t = c.temporal_filter;
  auto& k = c.keyframes;
  auto& l = c.local_cloud;
  auto& r = c.registration;
  auto& f = c.fusion;
  auto& u = c.upload;
  return {
      {"stereo", "num_disparities", &s.num_disparities, 16, 1024},
      {"stereo", "reference_width", &s.reference_width, 1, 100000},
      {"stereo", "min_disparity", &s.min_disparity, -1024, 1024},
      {"stereo", "block_size", &s.block_size, 1, 31},
      {"stereo", "uniqueness_ratio", &s.uniqueness_ratio, 0, 100},
      {"stereo", "disp12_max_diff", &s.disp12_max_diff, -1, 1024},
      {"stereo", "speckle_window_size", &s.speckle_window_size, 0, 100000},
      {"stereo", "speckle_range", &s.speckle_range, 0, 1024},
      {"stereo", "pre_filter_cap", &s.pre_filter_cap, 0, 1023},
      {"stereo", "max_depth_m", &s.max_depth_m, 1e-3, 1e6},
      {"temporal_filter", "half_window", &t.half_window, 0, 10},
      {"temporal_filter", "delta_d_m", &t.delta_d_m, 1e-6, 1e6},
      {"temporal_filter", "alpha", &t.alpha, 0, 20},
      {"temporal_filter", "registration_alpha", &t.registration_alpha, 0, 20},
      {"keyframes", "min_translation_m", &k.min_translation_m, 0, 1e6},
      {"keyframes", "min_rotation_deg", &k.min_rotation_deg, 0, 360},
      {"keyframes", "max_interval_s", &k.max_interval_s, 1e-3, 1e6},
      {"local_cloud", "keyframes", &l.keyframes, 1, 1000},
      {"local_cloud", "voxel_m", &l.voxel_m, 1e-3, 100},
      {"local_cloud", "max_depth_m", &l.max_depth_m, 1e-3, 1e6},
      {"local_cloud", "pixel_stride", &l.pixel_stride, 1, 64},
      {"registration", "max_fitness_m", &r.max_fitness_m, 1e-6, 1e6},
      {"registration", "max_correction_m", &r.max_correction_m, 0, 1e6},
      {"registration", "max_correction_deg", &r.max_correction_deg, 0, 180},
      {"registration", "max_correspondence_m", &r.max_correspondence_m, 1e-6, 1e6},
      {"registration", "max_iterations", &r.max_iterations, 1, 10000},
      {"registration", "prior_radius_m", &r.prior_radius_m, 1, 1e6},
      {"registration", "prior_voxel_m", &r.prior_voxel_m, 0, 100},
      {"registration", "covariance_scale", &r.covariance_scale, 1e-12, 1e12},
      {"registration", "relocalize_after_rejections", &r.relocalize_after_rejections, 1, 1000000},
      {"registration", "relocalize_max_correction_m", &r.relocalize_max_correction_m, 0, 1e6},
      {"registration", "relocalize_max_correction_deg", &r.relocalize_max_correction_deg, 0, 180},
      {"registration", "reanchor_yaw_hypotheses", &r.reanchor_yaw_hypotheses, 1, 360},
      {"registration", "max_tilt_deg", &r.max_tilt_deg, 0, 180},
      {"fusion", "odom_sigma_rot_rad", &f.odom_sigma_rot_rad, 1e-9, 10},
      {"fusion", "odom_sigma_trans_m", &f.odom_sigma_trans_m, 1e-9, 1e6},
      {"fusion", "odom_sigma_trans_per_m", &f.odom_sigma_trans_per_m, 0, 10},
      {"fusion", "huber_delta", &f.huber_delta, 1e-6, 1e6},
      {"fusion", "incremental_iterations", &f.incremental_iterations, 0, 10000},
      {"fusion", "final_iterations", &f.final_iterations, 0, 100000},
      {"fusion", "final_lag_keyframes", &f.final_lag_keyframes, 1, 1000000},
      {"fusion", "init_sigma_rot_rad", &f.init_sigma_rot_rad, 1e-9, 10},
      {"fusion", "init_sigma_trans_m", &f.init_sigma_trans_m, 1e-9, 1e6},
      {"fusion", "reset_sigma_rot_rad", &f.reset_sigma_rot_rad, 1e-9, 10},
      {"fusion", "reset_sigma_rot_per_s", &f.reset_sigma_rot_per_s, 0, 10},
      {"fusion", "reset_sigma_trans_m", &f.reset_sigma_trans_m, 1e-9, 1e6},
      {"fusion", "reset_sigma_trans_per_s", &f.reset_sigma_trans_per_s, 0, 1e6},
      {"upload", "vehicle_id", &u.vehicle_id},
      {"upload", "retry_initial_s", &u.retry_initial_s, 1e-3, 3600},
      {"upload", "retry_max_s", &u.retry_max_s, 1e-3, 86400},
      {"upload", "timeout_s", &u.timeout_s, 1e-3, 3600},
      {"upload", "depth_scale", &u.depth_scale, 1, 1e6},
  };
}

void ParseField(const Field& field, const YAML::Node& node, std::vector<std::string>* problems) {
  const std::string name = field.section + "." + field.key;
  try {
    double number = 0;
    if (auto* p = std::get_if<std::string*>(&field.value)) {
      **p = node.as<std::string>();
      return;
    } else if (auto* pi = std::get_if<int*>(&field.value)) {
      **pi = node.as<int>();
      number = **pi;
    } else {
      auto* pd = std::get<double*>(field.value);
      *pd = node.as<double>();
      number = *pd;
    }
    if (!(number >= field.min && number <= field.max)) {
      std::ostringstream msg;
      msg << name << ": " << number << " is outside [" << field.min << ", " << field.max << "]";
      problems->push_back(msg.str());
    }
  } catch (const YAML::Exception&) {
    const bool is_int = std::holds_alternative<int*>(field.value);
    problems->push_back(name + ": expected " + (is_int ? "an integer" : "a number"));
  }
}

}  // namespace

ClientConfig ParseClientConfig(const std::string& yaml_text, const std::string& what) {
  ClientConfig config;
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw Error(ErrorCode::kParse, what + ": " + e.what());
  }
  if (root.IsNull()) return config;
  if (!root.IsMap()) throw Error(ErrorCode::kParse, what + ": top level must be a map of sections");
  auto fields = Fields(config);
  std::map<std::string, std::map<std::string, const Field*>> by_section;
  for (const auto& f : fields) by_section[f.section][f.key] = &f;

  std::vector<std::string> problems;
  for (const auto& section : root) {
    const auto name = section.first.as<std::string>();
    const auto it = by_section.find(name);
    if (it == by_section.end()) {
      problems.push_back("unknown section '" + name + "'");
      continue;
    }
    if (!section.second.IsMap()) {
      problems.push_back(name + ": must be a map");
      continue;
    }
    for (const auto& entry : section.second) {
      const auto key = entry.first.as<std::string>();
      const auto f = it->second.find(key);
      if (f == it->second.end()) {
        problems.push_back("unknown key '" + name + "." + key + "'");
        continue;
      }
      ParseField(*f->second, entry.second, &problems);
    }
  }
  if (config.stereo.block_size % 2 == 0) problems.push_back("stereo.block_size: must be odd");
  if (config.upload.retry_max_s < config.upload.retry_initial_s) {
    problems.push_back("upload.retry_max_s: must be >= upload.retry_initial_s");
  }
  if (!problems.empty()) {
    std::string message = what + ": " + std::to_string(problems.size()) + " problem(s):";
    for (const auto& p : problems) message += "\n  " + p;
    throw Error(ErrorCode::kParse, message);
  }
  return config;
}

ClientConfig LoadClientConfig(const std::string& path) {
  std::string text;
  try {
    text = YAML::Dump(YAML::LoadFile(path));
  } catch (const YAML::BadFile&) {
    throw Error(ErrorCode::kIo, path + ": cannot open config file");
  } catch (const YAML::Exception& e) {
    throw Error(ErrorCode::kParse, path + ": " + e.what());
  }
  return ParseClientConfig(text, path);
}

std::string ToYaml(const ClientConfig& config) {
  ClientConfig copy = config;
  std::ostringstream out;
  out.precision(12);
  std::string section;
  for (const auto& f : Fields(copy)) {
    if (f.section != section) {
      section = f.section;
      out << section << ":\n";
    }
    out << "  " << f.key << ": ";
    std::visit([&](auto* p) { out << *p; }, f.value);
    out << "\n";
  }
  return out.str();
}

}  // namespace mapdelta::client
