#include "localization_quality.hpp"

#include <algorithm>
#include <cmath>

namespace mapdelta::server {
namespace {

// 1 at or below full, `low` at or beyond zero_at, linear in between.
double Ramp(double value, double full, double zero_at, double low) {
  if (value <= full) return 1.0;
  if (value >= zero_at) return low;
  return 1.0 - (1.0 - low) * (value - full) / (zero_at - full);
}

}  // namespace

nlohmann::json LocalizationQuality::ToJson() const {
  nlohmann::json j{{"weight", weight}, {"registration", registration}};
  j["fitness_m"] = fitness_m ? nlohmann::json(*fitness_m) : nlohmann::json();
  j["position_sigma_m"] = position_sigma_m ? nlohmann::json(*position_sigma_m) : nlohmann::json();
  return j;
}

std::optional<double> PositionSigma(const std::string& covariance_json) {
  const nlohmann::json c = nlohmann::json::parse(covariance_json, nullptr, false);
  if (!c.is_array() || c.size() != 36) return std::nullopt;
  double variance = 0;
  for (int i = 3; i < 6; ++i) {
    if (!c[i * 6 + i].is_number()) return std::nullopt;
    variance = std::max(variance, c[i * 6 + i].get<double>());
  }
  return std::sqrt(variance);
}

LocalizationQuality AssessLocalization(const nlohmann::json& registration,
                                       std::vector<double> position_sigmas_m,
                                       const PipelineConfig& pipeline) {
  LocalizationQuality q;
  q.registration = registration.value("status", std::string("skipped"));
  double from_registration = 1.0;
  if (q.registration == "rejected") {
    from_registration = kMinSessionWeight;
  } else if (q.registration == "accepted" && registration.contains("fitness_m")) {
    q.fitness_m = registration["fitness_m"].get<double>();
    const double limit = pipeline.gicp_max_fitness_m;
    from_registration = Ramp(*q.fitness_m, limit / 2, limit, 0.5);
  }
  double from_covariance = 1.0;
  if (!position_sigmas_m.empty()) {
    auto mid = position_sigmas_m.begin() + static_cast<long>(position_sigmas_m.size() / 2);
    std::nth_element(position_sigmas_m.begin(), mid, position_sigmas_m.end());
    q.position_sigma_m = *mid;
    from_covariance = Ramp(*mid, kFullWeightSigmaM, kLowWeightSigmaM, kMinSessionWeight);
  }
  q.weight = std::min(from_registration, from_covariance);
  return q;
}

}  // namespace mapdelta::server
