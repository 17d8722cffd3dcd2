#include "mapdelta/client/prior_registration.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <optional>

#include "mapdelta/common/log.hpp"
#include "mapdelta/common/registration/gicp.hpp"
#include "mapdelta/common/registration/registration_gate.hpp"

namespace mapdelta::client {

struct PriorRegistrar::Impl {
  RegistrationConfig config;
  PriorSource* prior = nullptr;
  int num_threads = 2;
  std::string target_key;
  std::optional<GicpCloud> target;  // prepared once per prior neighbourhood

  GicpParams Params(double max_correspondence_m) const {
    GicpParams p;
    p.max_iterations = config.max_iterations;
    p.max_correspondence_m = max_correspondence_m;
    p.num_threads = num_threads;
    p.covariance_scale = config.covariance_scale;
    p.source_as_points = config.source_as_points;
    // voxel_m stays 0 (k-NN covariances): both clouds are already voxelized at 0.4 m, and the
    // voxel-block covariances (voxel_m = 0.4) were measured no faster per registration here
    // (prior rebuilds dominate) and worse on sim S2_01 (fused ATE 0.15 -> 0.18 m).
    return p;
  }

  RegistrationGate Gate(const std::optional<Eigen::Vector3d>& odometry_up) const {
    RegistrationGate gate;
    gate.max_fitness_m = config.max_fitness_m;
    gate.source_up = odometry_up;
    gate.max_tilt_rad = config.max_tilt_deg * M_PI / 180.0;
    return gate;
  }

  // The prior around (x, y), rebuilt only when the neighbourhood (its tiles) changes.
  const GicpCloud* Target(const Eigen::Vector3d& position) {
    const double r = config.prior_radius_m;
    const std::string key = prior->Key(position.x(), position.y(), r);
    if (!target || key != target_key) {
      const PointCloud points = prior->CloudAround(position.x(), position.y(), r);
      if (points.size() < 10) return nullptr;
      target.emplace(points, Params(config.max_correspondence_m));
      target_key = key;
    }
    return &*target;
  }

  // Share of the local cloud's points within radius_m of a prior point at T: a sharper test of
  // "the surfaces coincide" than the gate's inlier fraction at the wide correspondence radius.
  double CloseFraction(const PointCloud& local, const SE3& T, double radius_m) {
    const GicpCloud* tgt = Target(T.translation());
    return tgt == nullptr ? 0.0 : CloseFraction(*tgt, local, T, radius_m);
  }
  static double CloseFraction(const GicpCloud& tgt, const PointCloud& local, const SE3& T,
                              double radius_m) {
    if (local.empty()) return 0.0;
    const Eigen::Isometry3f Tf = T.cast<float>();
    size_t close = 0, index = 0;
    float distance = 0;
    for (const auto& p : local) {
      close += tgt.NearestWithin(Tf * p, static_cast<float>(radius_m), &index, &distance);
    }
    return static_cast<double>(close) / static_cast<double>(local.size());
  }

  // Multi-start check of the accepted pose T: GICP again from T shifted by +-d along the
  // body's x and y axes. A start that converges to another pose (more than d / 2 from T along
  // that axis) whose share of local points within max_fitness_m / 2 of the prior is at least
  // ambiguity_probe_ratio of T's is a second minimum of the cost: the variance along the axis
  // is raised to the square of the two minima's separation. GICP's covariance describes the
  // curvature of one minimum only; sparse, noisy clouds on facades with repeating structure
  // have several (paper S1_dark, big noise: registrations 1-1.5 m off along the track at 5-10
  // sigma, converging backwards or forwards depending on the start).
  void ProbeSecondMinima(const GicpCloud& tgt, const GicpCloud& source, const PointCloud& local,
                         const SE3& T, Matrix6d* covariance) {
    const double d = config.ambiguity_probe_m;
    if (d <= 0) return;
    const double radius = 0.5 * config.max_fitness_m;
    const double at_pose = CloseFraction(tgt, local, T, radius);
    if (at_pose <= 0) return;
    const GicpParams params = Params(config.max_correspondence_m);
    for (int axis = 0; axis < 2; ++axis) {
      double separation = 0;
      for (const double sign : {-1.0, 1.0}) {
        SE3 shift = SE3::Identity();
        shift.translation()(axis) = sign * d;
        const RegistrationResult other = AlignGicp(tgt, source, T * shift, params);
        if (!other.converged) continue;
        const double along = (T.inverse() * other.T_target_source).translation()(axis);
        if (std::abs(along) <= 0.5 * d) continue;  // back to T: one minimum
        if (CloseFraction(tgt, local, other.T_target_source, radius) >=
            config.ambiguity_probe_ratio * at_pose) {
          separation = std::max(separation, std::abs(along));
        }
      }
      const int i = 3 + axis;
      (*covariance)(i, i) = std::max((*covariance)(i, i), separation * separation);
    }
  }

  // ProbeSecondMinima for an outcome computed without it (the winner of a search).
  void ProbeSecondMinima(const PointCloud& local, RegistrationOutcome* out) {
    const GicpCloud* tgt = Target(out->T_map_body.translation());
    if (tgt == nullptr) return;
    const GicpCloud source(local, Params(config.max_correspondence_m));
    ProbeSecondMinima(*tgt, source, local, out->T_map_body, &out->covariance);
  }

  // probe: ProbeSecondMinima on an accepted result (off for each hypothesis of a search, whose
  // winner alone is probed).
  RegistrationOutcome Run(const PointCloud& local, const SE3& guess, double coarse_corr_m,
                          const RegistrationGate& gate, bool probe) {
    const auto start = std::chrono::steady_clock::now();
    RegistrationOutcome out;
    out.source_points = local.size();
    const GicpCloud* tgt = Target(guess.translation());
    if (tgt == nullptr) {
      out.reason = "no prior points within " + std::to_string(config.prior_radius_m) + " m";
      return out;
    }
    out.prior_points = tgt->size();
    SE3 init = guess;
    if (coarse_corr_m > config.max_correspondence_m) {
      // 1. Coarse pass: wide correspondences pull a far-off guess onto the surfaces.
      const RegistrationResult coarse = AlignGicp(*tgt, local, guess, Params(coarse_corr_m));
      if (coarse.converged || coarse.iterations > 0) init = coarse.T_target_source;
    }
    // 2. Fine pass with the production radius; its Hessian gives the covariance.
    const GicpParams fine = Params(config.max_correspondence_m);
    const GicpCloud source(local, fine);
    const RegistrationResult result = AlignGicp(*tgt, source, init, fine);
    const GateDecision decision = CheckRegistration(result, guess, gate);
    out.accepted = decision.accepted;
    out.reason = decision.reason;
    out.T_map_body = result.T_target_source;
    // Correlated cloud errors do not average out over more points (see covariance_full_points).
    out.covariance = result.covariance * std::max(1.0, static_cast<double>(result.num_inliers) /
                                                           config.covariance_full_points);
    if (out.accepted && probe) {
      ProbeSecondMinima(*tgt, source, local, out.T_map_body, &out.covariance);
    }
    out.fitness_m = result.fitness_m;
    out.inlier_fraction = result.num_source_points == 0
                              ? 0.0
                              : static_cast<double>(result.num_inliers) /
                                    static_cast<double>(result.num_source_points);
    out.correction_m = decision.correction_m;
    out.correction_rad = decision.correction_rad;
    out.iterations = result.iterations;
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return out;
  }

  RegistrationOutcome RefineInitialPose(const PointCloud& local, const SE3& guess,
                                        double max_guess_error_m, double max_guess_error_rad,
                                        const std::optional<Eigen::Vector3d>& odometry_up,
                                        bool probe) {
    RegistrationGate gate = Gate(odometry_up);
    gate.max_correction_m = max_guess_error_m;
    gate.max_correction_rad = max_guess_error_rad;
    const double coarse = std::max(2.5 * config.max_correspondence_m, 2.0 * max_guess_error_m);
    return Run(local, guess, coarse, gate, probe);
  }
};

PriorRegistrar::PriorRegistrar(const RegistrationConfig& config, PriorSource* prior,
                               int num_threads)
    : impl_(std::make_unique<Impl>()) {
  impl_->config = config;
  impl_->prior = prior;
  impl_->num_threads = std::max(1, num_threads);
}
PriorRegistrar::~PriorRegistrar() = default;

RegistrationOutcome PriorRegistrar::Register(const PointCloud& local_body, const SE3& guess,
                                             const std::optional<Eigen::Vector3d>& odometry_up) {
  RegistrationGate gate = impl_->Gate(odometry_up);
  gate.max_correction_m = impl_->config.max_correction_m;
  gate.max_correction_rad = impl_->config.max_correction_deg * M_PI / 180.0;
  return impl_->Run(local_body, guess, 0.0, gate, /*probe=*/true);
}

RegistrationOutcome PriorRegistrar::RefineInitialPose(
    const PointCloud& local_body, const SE3& guess, double max_guess_error_m,
    double max_guess_error_rad, const std::optional<Eigen::Vector3d>& odometry_up) {
  return impl_->RefineInitialPose(local_body, guess, max_guess_error_m, max_guess_error_rad,
                                  odometry_up, /*probe=*/true);
}

RegistrationOutcome PriorRegistrar::RefineAmongGuesses(
    const PointCloud& local_body, const std::vector<SE3>& guesses, double max_guess_error_m,
    double max_guess_error_rad, const std::optional<Eigen::Vector3d>& odometry_up,
    double ambiguity_ratio) {
  std::vector<std::pair<double, RegistrationOutcome>> accepted;  // (close fraction, outcome)
  RegistrationOutcome first_rejected;
  const double close_radius = 0.5 * impl_->config.max_fitness_m;
  for (const SE3& guess : guesses) {
    RegistrationOutcome r = impl_->RefineInitialPose(local_body, guess, max_guess_error_m,
                                                     max_guess_error_rad, odometry_up,
                                                     /*probe=*/false);
    const double close =
        r.accepted ? impl_->CloseFraction(local_body, r.T_map_body, close_radius) : 0.0;
    MD_LOG(kDebug, "re-anchor hypothesis at ("
                       << guess.translation().transpose() << "): " << r.reason << ", within "
                       << close_radius << " m " << close << ", fitness " << r.fitness_m
                       << " m, result (" << r.T_map_body.translation().transpose() << ")");
    if (r.accepted) {
      accepted.emplace_back(close, std::move(r));
    } else if (first_rejected.reason.empty()) {
      first_rejected = std::move(r);
    }
  }
  if (accepted.empty()) {
    first_rejected.reason = "none of " + std::to_string(guesses.size()) +
                            " guesses accepted (first: " + first_rejected.reason + ")";
    return first_rejected;
  }
  std::sort(accepted.begin(), accepted.end(),
            [](const auto& a, const auto& b) { return a.first > b.first; });
  const double best_close = accepted.front().first;
  RegistrationOutcome best = accepted.front().second;
  for (size_t i = 1; i < accepted.size(); ++i) {
    const auto& [close, other] = accepted[i];
    const bool elsewhere =
        (other.T_map_body.translation() - best.T_map_body.translation()).norm() > 1.0 ||
        RotationAngle(other.T_map_body, best.T_map_body) > 5.0 * M_PI / 180.0;
    if (elsewhere && close >= ambiguity_ratio * best_close) {
      best.accepted = false;
      best.reason = "ambiguous: two of " + std::to_string(guesses.size()) +
                    " guesses converged to different poses with " + std::to_string(best_close) +
                    " and " + std::to_string(close) + " of the points within " +
                    std::to_string(close_radius) + " m";
      return best;
    }
  }
  best.reason = "accepted (" + std::to_string(accepted.size()) + " of " +
                std::to_string(guesses.size()) + " guesses)";
  impl_->ProbeSecondMinima(local_body, &best);
  return best;
}

}  // namespace mapdelta::client
