#pragma once
// The two per-keyframe passes of a commit job, run on pipeline.threads workers over fixed
// chunks of pipeline.chunk_keyframes keyframes. Chunks are combined in keyframe order, so the
// output is the same for any thread count and schedule (and equal to a one-thread,
// one-octree run: tests/server compares them).
#include <vector>

#include "jobs.hpp"
#include "mapdelta/common/camera.hpp"
#include "mapdelta/common/change_detection.hpp"
#include "mapdelta/common/observed_area.hpp"
#include "mapdelta/common/point_cloud.hpp"

namespace mapdelta::server {

// The detector's parameters of the pipeline config: th_d, th_f, rho_o, free-ray bound, stride
// and the free-space rule (pipeline.free_space through ApplyFreeSpaceRule, so the commit job
// runs the same rule as mapdelta-detect --free-space). Throws Error(kInvalidArgument) for a
// rule that stops rays at the prior's surfaces (mapdelta-detect's --stop-at-prior ablation;
// no named rule does, and the commit job does not implement it).
ChangeDetectionParams PipelineDetectionParams(const PipelineConfig& pc);

struct SessionCloud {
  PointCloud cloud;  // all keyframes' clouds in seq order, voxel-filtered again
  // Per point of `cloud`: the keyframes with a point in its voxel (each keyframe's cloud is
  // filtered on the session voxel first, as mapdelta-detect's global cloud).
  std::vector<uint32_t> keyframe_support;
  int64_t recomputed = 0;  // keyframes whose stored cloud was missing or stale
};

// Pass 1: the session cloud from the clouds stored at upload (PNG decoded only for keyframes
// without a matching stored cloud). Progress from progress0 to progress1.
SessionCloud BuildSessionCloud(JobContext& ctx, const SessionRecord& session,
                               const PinholeCamera& camera, double progress0, double progress1);

struct SessionObserved {
  ObservedArea area;
  std::vector<Eigen::Vector3d> camera_centres;  // corrected, in seq order
};

// Pass 2: the session's observed octree with poses T_correction * T_map_cam: one octree per
// chunk (each PNG decoded once here), merged pairwise in chunk order.
SessionObserved BuildSessionObserved(JobContext& ctx, const SessionRecord& session,
                                     const PinholeCamera& camera, const SE3& T_correction,
                                     double progress0, double progress1);

}  // namespace mapdelta::server
