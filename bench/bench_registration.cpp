// bench_registration: our GICP (common/registration) against PCL's
// pcl::GeneralizedIterativeClosestPoint on the same real LiDAR pair, same downsampled clouds,
// same correspondence distance / iteration cap / k neighbours, in one run. Reports the median
// wall time of each and the error against the pair's reference transform.
//
// PCL 1.13's GICP has no thread setting (single-threaded), so ours is timed with 1 thread (the
// like-for-like ratio) and with --threads.
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/registration/gicp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <functional>
#include <iostream>
#include <string>
#include <vector>

#include "mapdelta/common/cli.hpp"
#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/common/registration/gicp.hpp"
#include "mapdelta/common/voxel_grid.hpp"

namespace {

using mapdelta::SE3;

struct Options {
  std::string data_dir = std::string(MAPDELTA_TEST_DATA_DIR) + "/registration/lidar_pair";
  double voxel_m = 0.25;
  int threads = 2;
  int repeats = 3;
};

void DeclareOptions(mapdelta::cli::Parser* cli, Options* o, bool* verbose) {
  cli->Option("data", &o->data_dir,
              "folder with source.ply, target.ply, T_target_source.txt (default: the test pair)",
              "DIR")
      .Option("voxel", &o->voxel_m, "downsampling leaf for both clouds, both methods [m]", "M")
      .Option("threads", &o->threads, "threads for our GICP's second run")
      .Option("repeats", &o->repeats, "timed runs per method; the median is reported")
      .Flag("verbose", verbose, "debug log lines (stderr)")
      .Footer(mapdelta::cli::kExitCodesFooter);
}

SE3 ReadTransform(const std::string& path) {
  std::ifstream in(path);
  Eigen::Matrix4d M;
  for (int k = 0; k < 16; ++k) in >> M(k / 4, k % 4);
  if (!in) {
    throw mapdelta::Error(mapdelta::ErrorCode::kParse, path + ": expected 16 numbers (4x4)");
  }
  SE3 T;
  T.matrix() = M;
  T.linear() = Eigen::Quaterniond(M.topLeftCorner<3, 3>()).normalized().toRotationMatrix();
  return T;
}

pcl::PointCloud<pcl::PointXYZ>::Ptr ToPcl(const mapdelta::PointCloud& cloud) {
  pcl::PointCloud<pcl::PointXYZ>::Ptr out(new pcl::PointCloud<pcl::PointXYZ>);
  out->reserve(cloud.size());
  for (const auto& p : cloud) out->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  return out;
}

// CPU time of this thread: robust on a shared, loaded machine for single-threaded runs.
double CpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

struct Run {
  double seconds = 0;      // median wall time
  double cpu_seconds = 0;  // median CPU time of the calling thread (single-threaded runs)
  SE3 T = SE3::Identity();
  bool converged = false;
};

// Median time of `repeats` runs of f (the pose of the last run).
Run Median(int repeats, const std::function<Run()>& f) {
  std::vector<double> times, cpu_times;
  Run last;
  for (int i = 0; i < repeats; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    const double c0 = CpuSeconds();
    last = f();
    cpu_times.push_back(CpuSeconds() - c0);
    times.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  std::sort(times.begin(), times.end());
  std::sort(cpu_times.begin(), cpu_times.end());
  last.seconds = times[times.size() / 2];
  last.cpu_seconds = cpu_times[cpu_times.size() / 2];
  return last;
}

// Speed-up by wall time; for single-threaded runs also by CPU time (what a loaded machine
// cannot distort). Multi-threaded runs report wall time only.
void Report(const char* name, const Run& r, const SE3& reference, const Run& baseline,
            bool single_thread) {
  const double dt = (r.T.translation() - reference.translation()).norm();
  const double dr = mapdelta::RotationAngle(r.T, reference) * 180.0 / M_PI;
  char cpu[64] = "        -            -";
  if (single_thread) {
    std::snprintf(cpu, sizeof(cpu), "%8.1f ms  %8.1fx", 1e3 * r.cpu_seconds,
                  baseline.cpu_seconds / r.cpu_seconds);
  }
  std::printf("%-24s %8.1f ms  %8.1fx  %s  %9.4f m  %8.4f deg  %s\n", name, 1e3 * r.seconds,
              baseline.seconds / r.seconds, cpu, dt, dr, r.converged ? "yes" : "NO");
}

}  // namespace

int main(int argc, char** argv) {
  mapdelta::log::SetLevel(mapdelta::log::Level::kWarn);
  Options o;
  bool verbose = false;
  mapdelta::cli::Parser cli("bench_registration",
                            "Our GICP beside PCL's on a real scan pair (bench/README.md).");
  DeclareOptions(&cli, &o, &verbose);
  if (const auto exit_code = mapdelta::cli::ParseMain(cli, argc, argv, [&] {
        if (!(o.voxel_m > 0) || o.threads < 1 || o.repeats < 1) {
          mapdelta::cli::FailUsage(cli.program(),
                                   "--voxel must be > 0, --threads and --repeats >= 1");
        }
      })) {
    return *exit_code;
  }
  if (verbose) mapdelta::log::SetLevel(mapdelta::log::Level::kDebug);
  try {
    const SE3 reference = ReadTransform(o.data_dir + "/T_target_source.txt");
    const auto voxel = static_cast<float>(o.voxel_m);
    const mapdelta::PointCloud raw_target = mapdelta::ReadCloud(o.data_dir + "/target.ply");
    const mapdelta::PointCloud raw_source = mapdelta::ReadCloud(o.data_dir + "/source.ply");
    // Both methods get the same voxelized clouds. Ours is also given voxel_m (its covariance
    // neighbourhood follows it); re-voxelizing at the same leaf leaves the clouds unchanged,
    // since each centroid lies inside its own cell (checked below).
    const mapdelta::PointCloud target = mapdelta::VoxelDownsample(raw_target, voxel);
    const mapdelta::PointCloud source = mapdelta::VoxelDownsample(raw_source, voxel);
    std::printf("clouds after %.2f m voxel: target %zu, source %zu points; %d repeats (median)\n",
                o.voxel_m, target.size(), source.size(), o.repeats);

    mapdelta::GicpParams params;  // max_correspondence 2 m, 64 iterations, k = 20
    params.voxel_m = o.voxel_m;
    // PCL's GICP stops when no rotation-matrix element changes by 2e-3 and no translation
    // element by 5e-4 (its defaults); ours uses the same thresholds on the step here.
    params.rotation_eps_rad = 2e-3;
    params.translation_eps_m = 5e-4;
    auto ours = [&](int threads) {
      mapdelta::GicpParams p = params;
      p.num_threads = threads;
      return [&, p]() {
        // Timed from the voxelized clouds: voxels, covariances, k-d tree, alignment.
        const auto r = mapdelta::AlignGicp(target, source, SE3::Identity(), p);
        return Run{0, 0, r.T_target_source, r.converged};
      };
    };
    const auto pcl_target = ToPcl(target);
    const auto pcl_source = ToPcl(source);
    auto pcl_gicp = [&]() {
      pcl::GeneralizedIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> gicp;
      gicp.setMaxCorrespondenceDistance(params.max_correspondence_m);
      gicp.setMaximumIterations(params.max_iterations);
      gicp.setCorrespondenceRandomness(params.k_neighbors);
      gicp.setInputSource(pcl_source);
      gicp.setInputTarget(pcl_target);
      pcl::PointCloud<pcl::PointXYZ> aligned;
      gicp.align(aligned, Eigen::Matrix4f::Identity());
      SE3 T;
      T.matrix() = gicp.getFinalTransformation().cast<double>();
      return Run{0, 0, T, gicp.hasConverged()};
    };

    std::fprintf(stderr, "running PCL GICP ...\n");
    const Run pcl_run = Median(o.repeats, pcl_gicp);
    std::fprintf(stderr, "running mapdelta GICP ...\n");
    const Run ours_1 = Median(o.repeats, ours(1));
    const Run ours_n = Median(o.repeats, ours(o.threads));

    // Where our time goes: preparing the clouds (voxels, covariances) vs the alignment, which
    // includes building the target's k-d tree (on first use; the source needs none).
    {
      mapdelta::GicpParams p = params;
      p.num_threads = 1;
      const double t0 = CpuSeconds();
      const mapdelta::GicpCloud gicp_target(target, p), gicp_source(source, p);
      const double t1 = CpuSeconds();
      const auto r = mapdelta::AlignGicp(gicp_target, gicp_source, SE3::Identity(), p);
      const double t2 = CpuSeconds();
      std::printf(
          "mapdelta 1 thread, CPU time: prepare both clouds (voxels, covariances) %.1f ms, "
          "align %.1f ms (target k-d tree, %d iterations)\n",
          1e3 * (t1 - t0), 1e3 * (t2 - t1), r.iterations);
      if (gicp_target.size() != target.size() || gicp_source.size() != source.size()) {
        std::fprintf(stderr, "warning: re-voxelizing changed the clouds (%zu/%zu, %zu/%zu)\n",
                     gicp_target.size(), target.size(), gicp_source.size(), source.size());
      }
    }
    std::printf("%-24s %11s  %9s  %11s  %9s  %11s  %12s  %s\n", "method", "wall", "speed-up", "cpu",
                "speed-up", "err transl", "err rot", "converged");
    Report("pcl GICP (1 thread)", pcl_run, reference, pcl_run, true);
    Report("mapdelta GICP 1 thread", ours_1, reference, pcl_run, true);
    const std::string name = "mapdelta GICP " + std::to_string(o.threads) + " threads";
    Report(name.c_str(), ours_n, reference, pcl_run, o.threads == 1);
  } catch (const std::exception& e) {
    std::cerr << "bench_registration: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
