#pragma once
// How much a session's evidence about changes counts, from how well it was localized (issue #20
// item 2). A session whose poses are off by a metre or two sees the prior's surfaces shifted and
// reports changes that are not there; two such sessions from two vehicles would confirm them.
// So each session gets a weight in [0.25, 1], the smaller of:
//   registration (commit step 2): rejected -> 0.25 (its poses stayed as uploaded, unchecked);
//     accepted with fitness f -> 1 up to half of pipeline.gicp_max_fitness_m, then falling
//     linearly to 0.5 at the limit; skipped (no prior, GICP off) -> 1;
//   uploaded covariance: s = the median over keyframes of the largest position standard
//     deviation (translation block of the 6x6 [rotation, translation] covariance) -> 1 up to
//     kFullWeightSigmaM, falling linearly to 0.25 at kLowWeightSigmaM and beyond; no covariance
//     -> 1.
// A cluster's support and contradiction are sums of weights, and only sessions of weight >= 0.5
// count as distinct vehicles or days (change_evidence.hpp).
#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <vector>

#include "mapdelta/server/config.hpp"

namespace mapdelta::server {

inline constexpr double kMinSessionWeight = 0.25;
inline constexpr double kFullWeightSigmaM = 0.3;
inline constexpr double kLowWeightSigmaM = 1.0;
inline constexpr double kCredibleWeight = 0.5;  // counts as a vehicle / day of its own

struct LocalizationQuality {
  double weight = 1.0;
  std::string registration = "skipped";  // accepted | rejected | skipped
  std::optional<double> fitness_m;
  std::optional<double> position_sigma_m;
  nlohmann::json ToJson() const;
};

// registration: the commit's registration report ({"status", "fitness_m", ...});
// position_sigmas_m: one per keyframe that uploaded a covariance.
LocalizationQuality AssessLocalization(const nlohmann::json& registration,
                                       std::vector<double> position_sigmas_m,
                                       const PipelineConfig& pipeline);
// The largest position standard deviation of a 36-number covariance JSON (nullopt if null).
std::optional<double> PositionSigma(const std::string& covariance_json);

}  // namespace mapdelta::server
