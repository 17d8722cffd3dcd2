#include "mapdelta/client/config.hpp"

#include "mapdelta/common/config_reader.hpp"

namespace mapdelta::client {
namespace {

// Every field once: the reader rejects what is not here, and ToYaml echoes all of it.
ConfigSchema Schema(ClientConfig& c) {
  auto& s = c.stereo;
  auto& t = c.temporal_filter;
  auto& k = c.keyframes;
  auto& l = c.local_cloud;
  auto& r = c.registration;
  auto& f = c.fusion;
  auto& u = c.upload;
  ConfigSchema schema;
  schema.Field("vio.smooth_sigma_px", &c.vio.smooth_sigma_px, -1.0, 20.0)
      .Field("stereo.num_disparities", &s.num_disparities, 16, 1024)
      .Field("stereo.reference_width", &s.reference_width, 1, 100000)
      .Field("stereo.min_disparity", &s.min_disparity, -1024, 1024)
      .Field("stereo.block_size", &s.block_size, 1, 31)
      .Field("stereo.uniqueness_ratio", &s.uniqueness_ratio, 0, 100)
      .Field("stereo.disp12_max_diff", &s.disp12_max_diff, -1, 1024)
      .Field("stereo.speckle_window_size", &s.speckle_window_size, 0, 100000)
      .Field("stereo.speckle_range", &s.speckle_range, 0, 1024)
      .Field("stereo.pre_filter_cap", &s.pre_filter_cap, 0, 1023)
      .Field("stereo.max_depth_m", &s.max_depth_m, 1e-3, 1e6)
      .Field("stereo.denoise_sigma_px", &s.denoise_sigma_px, -1.0, 20.0)
      .Field("temporal_filter.half_window", &t.half_window, 0, 10)
      .Field("temporal_filter.delta_d_m", &t.delta_d_m, 1e-6, 1e6)
      .Field("temporal_filter.alpha", &t.alpha, 0, 20)
      .Field("temporal_filter.registration_alpha", &t.registration_alpha, 0, 20)
      .Field("keyframes.min_translation_m", &k.min_translation_m, 0, 1e6)
      .Field("keyframes.min_rotation_deg", &k.min_rotation_deg, 0, 360)
      .Field("keyframes.max_interval_s", &k.max_interval_s, 1e-3, 1e6)
      .Field("local_cloud.keyframes", &l.keyframes, 1, 1000)
      .Field("local_cloud.every_keyframes", &l.every_keyframes, 0, 1000)
      .Field("local_cloud.min_points", &l.min_points, 0, 10000000)
      .Field("local_cloud.max_keyframes", &l.max_keyframes, 1, 1000)
      .Field("local_cloud.voxel_m", &l.voxel_m, 1e-3, 100)
      .Field("local_cloud.max_depth_m", &l.max_depth_m, 1e-3, 1e6)
      .Field("local_cloud.pixel_stride", &l.pixel_stride, 1, 64)
      .Field("registration.max_fitness_m", &r.max_fitness_m, 1e-6, 1e6)
      .Field("registration.max_correction_m", &r.max_correction_m, 0, 1e6)
      .Field("registration.max_correction_deg", &r.max_correction_deg, 0, 180)
      .Field("registration.max_correspondence_m", &r.max_correspondence_m, 1e-6, 1e6)
      .Field("registration.max_iterations", &r.max_iterations, 1, 10000)
      .Field("registration.prior_radius_m", &r.prior_radius_m, 1, 1e6)
      .Field("registration.prior_voxel_m", &r.prior_voxel_m, 0, 100)
      .Field("registration.covariance_scale", &r.covariance_scale, 1e-12, 1e12)
      .Field("registration.covariance_full_points", &r.covariance_full_points, 1.0, 1e9)
      .Field("registration.source_as_points", &r.source_as_points)
      .Field("registration.ambiguity_probe_m", &r.ambiguity_probe_m, 0.0, 100.0)
      .Field("registration.ambiguity_probe_ratio", &r.ambiguity_probe_ratio, 0.0, 1.0)
      .Field("registration.relocalize_after_rejections", &r.relocalize_after_rejections, 1, 1000000)
      .Field("registration.relocalize_max_correction_m", &r.relocalize_max_correction_m, 0, 1e6)
      .Field("registration.relocalize_max_correction_deg", &r.relocalize_max_correction_deg, 0, 180)
      .Field("registration.reanchor_yaw_hypotheses", &r.reanchor_yaw_hypotheses, 1, 360)
      .Field("registration.max_tilt_deg", &r.max_tilt_deg, 0, 180)
      .Field("fusion.odom_sigma_rot_rad", &f.odom_sigma_rot_rad, 1e-9, 10)
      .Field("fusion.odom_sigma_trans_m", &f.odom_sigma_trans_m, 1e-9, 1e6)
      .Field("fusion.odom_sigma_trans_per_m", &f.odom_sigma_trans_per_m, 0, 10)
      .Field("fusion.huber_delta", &f.huber_delta, 1e-6, 1e6)
      .Field("fusion.odom_scale_sigma_per_sqrt_s", &f.odom_scale_sigma_per_sqrt_s, 0, 10)
      .Field("fusion.odom_scale_sigma", &f.odom_scale_sigma, 1e-6, 10)
      .Field("fusion.incremental_iterations", &f.incremental_iterations, 0, 10000)
      .Field("fusion.final_iterations", &f.final_iterations, 0, 100000)
      .Field("fusion.final_lag_keyframes", &f.final_lag_keyframes, 1, 1000000)
      .Field("fusion.init_sigma_rot_rad", &f.init_sigma_rot_rad, 1e-9, 10)
      .Field("fusion.init_sigma_trans_m", &f.init_sigma_trans_m, 1e-9, 1e6)
      .Field("fusion.reset_sigma_rot_rad", &f.reset_sigma_rot_rad, 1e-9, 10)
      .Field("fusion.reset_sigma_rot_per_s", &f.reset_sigma_rot_per_s, 0, 10)
      .Field("fusion.reset_sigma_trans_m", &f.reset_sigma_trans_m, 1e-9, 1e6)
      .Field("fusion.reset_sigma_trans_per_s", &f.reset_sigma_trans_per_s, 0, 1e6)
      .Field("upload.vehicle_id", &u.vehicle_id)
      .Field("upload.retry_initial_s", &u.retry_initial_s, 1e-3, 3600)
      .Field("upload.retry_max_s", &u.retry_max_s, 1e-3, 86400)
      .Field("upload.timeout_s", &u.timeout_s, 1e-3, 3600)
      .Field("upload.give_up_after_s", &u.give_up_after_s, 0, 1e7)
      .Field("upload.depth_scale", &u.depth_scale, 1, 1e6)
      .Rule([&s] { return s.block_size % 2 == 0 ? "stereo.block_size: must be odd" : ""; })
      .Rule([&l] {
        return l.min_points > 0 && l.max_keyframes < l.keyframes
                   ? "local_cloud.max_keyframes: must be >= local_cloud.keyframes when "
                     "local_cloud.min_points is set"
                   : "";
      })
      .Rule([&u] {
        return u.retry_max_s < u.retry_initial_s
                   ? "upload.retry_max_s: must be >= upload.retry_initial_s"
                   : "";
      });
  return schema;
}

}  // namespace

ClientConfig ParseClientConfig(const std::string& yaml_text, const std::string& what) {
  ClientConfig config;
  ReadConfigYaml(yaml_text, what, Schema(config));
  return config;
}

ClientConfig LoadClientConfig(const std::string& path) {
  ClientConfig config;
  ReadConfigFile(path, Schema(config));
  return config;
}

std::string ToYaml(const ClientConfig& config) {
  ClientConfig copy = config;  // the schema binds mutable fields
  return ConfigToYaml(Schema(copy));
}

}  // namespace mapdelta::client
