#pragma once
// Voxel consensus (classify.voxel_consensus, with the confident free-space rule): which of a
// tile neighbourhood's aggregated voxels the global cloud keeps.
//
// A voxel that k sessions filled is left out when at least k other sessions were there and did
// not fill it. A session was there when its observed octree knows the voxel (seen free or
// occupied) or when it filled a voxel within `reach_m` of it: its surface passes right beside
// (the default 1.2 m reaches a 0.8 m session voxel's face and edge neighbours).
// Such a voxel is one session's depth noise, a misplaced session or a passing object; kept, it
// would mask every removal within th_ch and be reported as new. With one session nothing
// changes; a surface two sessions share keeps the voxels both filled.
//
// A tie goes to the newer sessions (higher ids: committed later): the voxel stays when its newest
// filler is newer than every session that was there without filling it. Evidence split evenly
// is most often the world having changed between the drives (a building back after a refresh
// applied its removal: the lifecycle's expiry needs the two new drives to outweigh the two
// before). Among drives of an unchanged scene it keeps a newer session's stray voxel against
// one older session; what counts is that a voxel one session filled is left out once two others
// were there. (The main job's two vehicles drive different changed scenes, so they disagree by
// design: its server reports 267 new points in its busiest tile where it reported 463.)
//
// Why "were there" and not "saw it free": in issue 20's four-upload run most masking voxels lay
// where the other sessions had no free evidence at all, just behind or beside the surfaces they
// saw (overshooting depth). Measured on that run's replay (docs/results.md, 2026-12-06):
// confirmed R_rm at 4 uploads 0.778 (more sessions saw it free, 3 keyframes) -> 0.821 (their
// octree knows it) -> 0.826 / 0.880 / 0.887 / 0.893 (or filled within 0.8 / 1.0 / 1.2 / 2.0 m;
// ties against the voxel), precision 0.98 throughout; every tie kept: 0.816; a tie to the newer
// sessions (this rule): 0.877. At 2 m new objects two sessions share thinned out (2 uploads:
// confirmed R_new 0.985 -> 0.69; 0.973 at 1.2 m).
#include <cstdint>
#include <functional>
#include <vector>

#include "blob_codec.hpp"

namespace mapdelta::server {

// Whether `session`'s observed octree knows the place (free or occupied).
using SessionObserves = std::function<bool(int64_t session, const Point& p)>;

// keep[i] for voxels[i], whose centroids are centroids[i] (the tile neighbourhood's global cloud);
// `sessions` are all sessions that may have been there (sorted or not).
std::vector<char> VoxelsWithConsensus(const std::vector<const AggregateVoxel*>& voxels,
                                      const PointCloud& centroids,
                                      const std::vector<int64_t>& sessions,
                                      const SessionObserves& observes, double reach_m, int threads);

}  // namespace mapdelta::server
