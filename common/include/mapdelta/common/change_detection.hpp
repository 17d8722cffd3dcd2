#pragma once
// The paper's change detection (Lin et al., RA-L 2022, Sec. III-B): build the global cloud P_g
// from keyframes, optionally align it to the prior P_p, build the observed area A_obs, keep the
// observed prior cloud P_p^obs (Alg. 1) and classify new / removed points (Alg. 2).
// Parameter names follow the paper: th_ch, th_d, th_f, rho_o.
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "mapdelta/common/keyframes.hpp"
#include "mapdelta/common/observed_area.hpp"
#include "mapdelta/common/point_cloud.hpp"

namespace mapdelta {

struct ChangeDetectionParams {
  double th_ch_m = 3.2;         // change threshold (paper; the reference evaluation used 2.4)
  double cloud_voxel_m = 0.8;   // P_g and P_p are voxel-downsampled to this before comparing
  ObservedAreaParams observed;  // rho_o, th_d (also the global cloud's depth cut), th_f
  // Not in the paper (issue 21; the defaults are the paper's rule):
  // rays of pixels without depth end before the prior's surfaces (PriorSurfaces of the prior);
  bool free_rays_stop_at_prior = false;
  // a removed point's own voxel must be seen free by this many keyframes net of hits
  // (ObservedArea::IsSeenFree, 1-4); 0 = any known voxel (the paper's Alg. 1 test).
  int removed_min_free_keyframes = 0;
  // a new point must lie within this horizontal distance of some prior point
  // (WithinPriorFootprint); 0 = anywhere (the paper's Alg. 2).
  double new_footprint_radius_m = 0.0;
  // a new point's own voxel must not be seen free (ObservedArea::IsSeenFree, 1 keyframe net of
  // hits): where the session's rays passed through more often than they ended, its points are
  // depth noise, not a new surface (NotSeenFree); false = the paper's Alg. 2.
  bool new_not_seen_free = false;
  // With removed_min_free_keyframes > 0: a global point masks the prior points within th_ch of
  // it (Alg. 2) only when it lies within this distance of some prior point, i.e. re-observes a
  // prior surface, or outside the prior's footprint (MaskingPoints); 0 = every global point
  // masks (the paper). th_ch allows for the depth error of a surface seen again; a point of a
  // new object or of depth noise says nothing about the prior around it, yet masked a removed
  // building 3.2 m around it.
  double removed_mask_radius_m = 0.0;
  // With the mask radius: a global point masks only when at least this many keyframes put a
  // point in its voxel (ChangeDetectionResult::global_support): a surface seen again is seen
  // from several places, a stray depth once. 0 or 1 = off.
  int mask_min_keyframes = 0;
  // With mask_min_keyframes: a point with less support still masks when it lies within this
  // distance of a prior point (0 = never): on the prior surface, one keyframe's point is that
  // surface seen again (sparse depth sees a standing wall once), where a stray in a gone
  // building's volume lies further in. Measured on eight paper cells (docs/results.md, session
  // 26) against support alone: R_rm 0.916 -> 0.912, P_rm 0.867 -> 0.918 (S1_dark big 0.668 ->
  // 0.765); 0.3 m and 0.8 m each did worse on one side.
  double mask_weak_radius_m = 0.0;
  // Threads for every step of DetectChanges, the observed area's rays included (it overrides
  // observed.threads there); 0 = every hardware thread (parallel.hpp).
  int threads = 0;
};

// The named rules of the free space behind P_rm (th_f, th_d, rho_o and the free-ray bound stay
// as the caller sets them):
//   "paper"     - the paper's Alg. 1-2: a pixel without depth sees th_f, a hit ray is free to
//                 its end, any known voxel makes a prior point observed, new points anywhere;
//   "confident" - the method's rule (issue 21): a removed point's own voxel must be seen free
//                 by 3 keyframes net of hits, and hit rays end 3 sigma(d) before the hit
//                 (sigma = 0.5e-3 d^2: 0.2 px disparity at the paper rig's fx * B = 400 m px;
//                 measured against rendered ground-truth depth, 3 sigma at 20 m = 0.6 m is
//                 the 95th percentile of the keyframe depth's overshoot there, 0.4-0.7 m at
//                 10-30 m; 1.25e-3 cut 0.03 of R_rm on 12 paper cells for 0.013 of P_rm).
//                 New points only within the prior's footprint (1.6 m: two cloud voxels) and
//                 only where the session's own rays did not pass through more than end.
//                 Removals are masked only by global points within 1.6 m (two cloud voxels)
//                 of the prior (removed_mask_radius_m; measured on six paper cells: R_rm
//                 +0.02-0.12 at the same or better P_rm, docs/results.md), and only when two
//                 keyframes put a point in their voxel (mask_min_keyframes; on seven paper
//                 cells R_rm +0.00-0.09, mean +0.04, for P_rm -0.02-0.14, mean -0.06; sparse
//                 dark depth loses most: S1_dark big P_rm 0.81 -> 0.67, docs/results.md) or
//                 lie within 0.5 m of a prior point (mask_weak_radius_m: P_rm back to 0.77
//                 there, eight cells' mean R_rm -0.005 for P_rm +0.05 against the count alone).
//                 Rays without depth are not stopped at prior surfaces: measured on paper
//                 S1_01 (docs/results.md), that part lowered R_rm by 0.036 and added no
//                 precision once the voxel test was on (free_rays_stop_at_prior stays an option).
// Throws Error(kInvalidArgument) for any other name.
void ApplyFreeSpaceRule(const std::string& rule, ChangeDetectionParams* params);

// Alg. 1: the points of `prior` that lie in A_obs or within th_ch of `global`.
PointCloud ObservedPriorCloud(const PointCloud& prior, const PointCloud& global,
                              const ObservedArea& observed, double th_ch_m, int threads);

struct Changes {
  PointCloud new_points;      // P_new: global points >= th_ch from the observed prior
  PointCloud removed_points;  // P_rm: observed prior points >= th_ch from the global cloud
};
// The points whose horizontal distance to some point of `prior` is at most radius_m (all of
// them for radius_m <= 0). Past the prior's footprint the prior claims nothing, so nothing there
// is a change of it: ground seen beyond the mapped area's edge is unmapped, not new (on paper
// S2_02, 744 of the false new points of a smoothed-stereo run and no true one lay there).
PointCloud WithinPriorFootprint(const PointCloud& points, const PointCloud& prior, double radius_m,
                                int threads);

// The points whose own voxel `observed` has not seen free net of hits (IsSeenFree with one
// keyframe): a new surface is where rays end, not where they pass. Measured on 9 of the paper
// reproduction's cells (issue 21, docs/results.md 2026-12-06), applied to the whole global
// cloud: P_new up in every cell (e.g. S1_02 big 0.824 -> 0.902), R_new within 0.006, but removed
// precision in sparse depth fell (S1_dark big P_rm 0.828 -> 0.659: its few surface points lie in
// voxels rays also cross), so it judges new points only and removals keep the whole cloud.
PointCloud NotSeenFree(const PointCloud& points, const ObservedArea& observed, int threads);

// The indices (ascending) of the points of `global` that may mask a removal under the mask
// radius (ChangeDetectionParams::removed_mask_radius_m): those within reobserve_radius_m of some
// point of `prior` (they see a prior surface again) and those outside the prior's footprint
// (unmapped surfaces, as WithinPriorFootprint; footprint_radius_m 0 = no such test). A point
// inside the footprint but near no prior point is a new object or depth noise.
// With `support` (ChangeDetectionParams::mask_min_keyframes, mask_weak_radius_m): of those, a
// point whose support (keyframes with a point in its voxel, one per point of `global`; 0 =
// unknown, masks as before) is below min_keyframes masks only within weak_radius_m of a prior
// point.
struct MaskingSupport {
  const std::vector<uint32_t>* keyframes = nullptr;  // nullptr: no support test
  int min_keyframes = 0;
  double weak_radius_m = 0.0;
};
std::vector<size_t> MaskingPoints(const PointCloud& global, const PointCloud& prior,
                                  double reobserve_radius_m, double footprint_radius_m, int threads,
                                  const MaskingSupport& support = {});

// Alg. 2. `threads` as ChangeDetectionParams::threads. `masking`: the points that keep a prior
// point from being removed (within th_ch of it); nullptr = all of `global`, as in the paper.
Changes ClassifyChanges(const PointCloud& global, const PointCloud& observed_prior, double th_ch_m,
                        int threads, const PointCloud* masking = nullptr);

// Every keyframe's depths below max_depth_m back-projected into the map frame, voxel-downsampled
// to voxel_m (per keyframe and once more at the end, so memory stays bounded).
PointCloud BuildGlobalCloud(const KeyframeFolder& keyframes, double max_depth_m, double voxel_m,
                            int threads);

// Optional step 2 of the pipeline: returns T_prior_global, the correction that maps the global
// cloud onto the prior (e.g. wraps AlignGicp(prior, global, Identity, params).T_target_source).
using AlignFunction = std::function<SE3(const PointCloud& prior, const PointCloud& global)>;
// Progress of the pipeline: a stage name and the fraction done in [0, 1].
using ProgressFunction = std::function<void(const std::string& stage, double fraction)>;

struct ChangeDetectionResult {
  PointCloud global;  // P_g in the prior's frame (after alignment)
  // Per point of `global`: the keyframes that put a point in its voxel.
  std::vector<uint32_t> global_support;
  SE3 T_prior_global = SE3::Identity();
  ObservedArea observed;      // A_obs built with the aligned keyframe poses
  PointCloud prior;           // P_p, downsampled to cloud_voxel_m
  PointCloud observed_prior;  // P_p^obs
  Changes changes;
};

// Steps 1-4 of the paper. Throws Error(kInvalidArgument) on bad parameters or no keyframes.
ChangeDetectionResult DetectChanges(const KeyframeFolder& keyframes, const PointCloud& prior,
                                    const ChangeDetectionParams& params,
                                    const AlignFunction& align = nullptr,
                                    const ProgressFunction& progress = nullptr);
// The same, reading each keyframe's depth from the folder only when needed (twice: for the
// global cloud and for the observed area), so memory does not grow with the session length.
ChangeDetectionResult DetectChangesInFolder(const std::string& keyframe_dir,
                                            const PointCloud& prior,
                                            const ChangeDetectionParams& params,
                                            const AlignFunction& align = nullptr,
                                            const ProgressFunction& progress = nullptr);

}  // namespace mapdelta
