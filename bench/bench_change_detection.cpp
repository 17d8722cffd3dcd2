// Change classification at paper scale: a 1M-point prior, a 200k-point global cloud and an
// observed area from 20 keyframes of 800x450, time per stage, each beside a baseline:
//   observed area : ours (0.8 m end-point prefilter + parallel ray keys) vs OctoMap's own
//                   insertPointCloud of every pixel (serial, discretize=false as its default)
//   Alg. 1, Alg. 2: ours (nanoflann, common/parallel.hpp) vs PCL KdTreeFLANN, one thread
// The outputs must agree exactly (same points kept), which the program checks.
#include <octomap/OcTree.h>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_types.h>

#include <chrono>
#include <cstdio>
#include <random>

#include "../tests/common/box_scene.hpp"
#include "mapdelta/common/change_detection.hpp"
#include "mapdelta/common/cli.hpp"
#include "mapdelta/common/neighbor_index.hpp"

namespace {

using namespace mapdelta;
using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point since) {
  return std::chrono::duration<double>(Clock::now() - since).count();
}

PointCloud Subsample(const PointCloud& cloud, size_t n, std::mt19937& rng, float noise) {
  std::uniform_int_distribution<size_t> pick(0, cloud.size() - 1);
  std::normal_distribution<float> g(0.f, noise);
  PointCloud out(n);
  for (auto& p : out) p = cloud[pick(rng)] + Point(g(rng), g(rng), g(rng));
  return out;
}

pcl::PointCloud<pcl::PointXYZ>::Ptr ToPcl(const PointCloud& cloud) {
  auto out = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  for (const auto& p : cloud) out->push_back({p.x(), p.y(), p.z()});
  return out;
}

// Baseline Alg. 1 and 2 with PCL's FLANN k-d tree, serial.
size_t BaselineCount(const PointCloud& queries, const PointCloud& reference, double th, bool far,
                     const ObservedArea* observed) {
  pcl::KdTreeFLANN<pcl::PointXYZ> tree;
  tree.setInputCloud(ToPcl(reference));
  std::vector<int> index(1);
  std::vector<float> d2(1);
  size_t count = 0;
  for (const auto& p : queries) {
    if (observed && observed->IsObserved(p)) {
      ++count;
      continue;
    }
    const double d = tree.nearestKSearch(pcl::PointXYZ(p.x(), p.y(), p.z()), 1, index, d2) > 0
                         ? std::sqrt(d2[0])
                         : INFINITY;
    count += far ? (d >= th) : (d <= th);
  }
  return count;
}

}  // namespace

int main(int argc, char** argv) {
  // No options; the command line is still checked, and --help says what this measures.
  mapdelta::cli::Parser cli(
      "bench_change_detection",
      "Alg. 1 and 2 (ours, nanoflann + threads) beside a serial PCL FLANN baseline on a\n"
      "generated 250 x 250 m town (bench/README.md).");
  if (const auto exit_code = mapdelta::cli::ParseMain(cli, argc, argv)) return *exit_code;
  std::mt19937 rng(2024);
  // 1. A 250 x 250 m town: ground and 40 buildings; the changed scene drops 4 buildings in
  //    front of the cameras (y in -10..40) and adds 4 elsewhere.
  std::vector<testing::Box> original{{{-125, -125, -1}, {125, 125, 0}}}, changed;
  std::uniform_real_distribution<double> pos(-110, 100), size(6, 15), height(5, 40);
  for (int i = 0; i < 40; ++i) {
    const Eigen::Vector3d min(pos(rng), pos(rng), 0);
    original.push_back({min, min + Eigen::Vector3d(size(rng), size(rng), height(rng))});
  }
  int removed = 0;
  for (const auto& box : original) {
    const bool in_view =
        box.min.z() >= 0 && box.min.y() > -10 && box.max.y() < 40 && box.min.x() > -90;
    if (in_view && removed < 4)
      ++removed;
    else
      changed.push_back(box);
  }
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector3d min(-80 + 40 * i, 5, 0);
    changed.push_back({min, min + Eigen::Vector3d(10, 10, 20)});
  }
  const PointCloud prior =
      Subsample(testing::SampleBoxSurfaces(original, 0.25), 1'000'000, rng, 0.f);
  const PointCloud global =
      Subsample(testing::SampleBoxSurfaces(changed, 0.25), 200'000, rng, 0.05f);
  PinholeCamera camera;  // 800 x 450, fx 400 (the paper's camera)
  std::vector<std::pair<SE3, DepthImage>> frames;
  for (int k = 0; k < 20; ++k) {
    const Eigen::Vector3d eye(-100 + 10 * k, -20, 15);
    const SE3 T = testing::LookAt(eye, eye + Eigen::Vector3d(10, 10, -5));
    frames.emplace_back(T, testing::RenderDepth(camera, T, changed));
  }
  std::printf("prior %zu points, global %zu points, %zu keyframes of %dx%d\n\n", prior.size(),
              global.size(), frames.size(), camera.width, camera.height);
  std::printf("%-34s %12s %12s %8s\n", "stage", "mapdelta [s]", "baseline [s]", "speed-up");
  const auto row = [](const char* stage, double ours, double base) {
    std::printf("%-34s %12.3f %12.3f %7.1fx\n", stage, ours, base, base / ours);
  };

  // 2. Observed area (rho_o 0.8, th_d 50, th_f 20).
  const ChangeDetectionParams params;
  auto t = Clock::now();
  ObservedArea observed(params.observed.resolution_m);
  for (const auto& [T, depth] : frames) observed.InsertKeyframe(camera, T, depth, params.observed);
  const double ours_octree = Seconds(t);
  t = Clock::now();
  octomap::OcTree baseline_tree(params.observed.resolution_m);
  for (const auto& [T, depth] : frames) {
    octomap::Pointcloud hits;  // OctoMap's own path: every valid pixel, free rays to th_f too
    for (int v = 0; v < camera.height; ++v)
      for (int u = 0; u < camera.width; ++u) {
        const float d = depth.at(u, v);
        const double z = d > 0 && d < params.observed.max_depth_m ? d : params.observed.free_ray_m;
        const Eigen::Vector3d p = T * camera.BackProject(u, v, z);
        hits.push_back(p.x(), p.y(), p.z());
      }
    const Eigen::Vector3d o = T.translation();
    baseline_tree.insertPointCloud(hits, octomap::point3d(o.x(), o.y(), o.z()), -1, false, false);
  }
  const double base_octree = Seconds(t);
  row("observed area, 20 frames", ours_octree, base_octree);
  std::printf("%-34s %12zu %12zu\n", "  known leaves", observed.NumKnownLeaves(),
              baseline_tree.getNumLeafNodes());

  // 3. Alg. 1 and Alg. 2 (th_ch 3.2), each with its k-d tree build.
  t = Clock::now();
  const PointCloud observed_prior =
      ObservedPriorCloud(prior, global, observed, params.th_ch_m, params.threads);
  const double ours_alg1 = Seconds(t);
  t = Clock::now();
  const size_t base_observed = BaselineCount(prior, global, params.th_ch_m, false, &observed);
  const double base_alg1 = Seconds(t);
  row("Alg. 1 observed prior (1M vs 200k)", ours_alg1, base_alg1);
  t = Clock::now();
  const Changes changes = ClassifyChanges(global, observed_prior, params.th_ch_m, params.threads);
  const double ours_alg2 = Seconds(t);
  t = Clock::now();
  const size_t base_new = BaselineCount(global, observed_prior, params.th_ch_m, true, nullptr);
  const size_t base_removed = BaselineCount(observed_prior, global, params.th_ch_m, true, nullptr);
  const double base_alg2 = Seconds(t);
  row("Alg. 2 classification", ours_alg2, base_alg2);
  row("total classification (Alg. 1+2)", ours_alg1 + ours_alg2, base_alg1 + base_alg2);
  std::printf("\nobserved prior %zu, new %zu, removed %zu\n", observed_prior.size(),
              changes.new_points.size(), changes.removed_points.size());
  const bool agree = base_observed == observed_prior.size() &&
                     base_new == changes.new_points.size() &&
                     base_removed == changes.removed_points.size();
  std::printf("baseline agrees on every count: %s\n", agree ? "yes" : "NO");
  return agree ? 0 : 1;
}
