#include "mapdelta/common/trajectory_io.hpp"

#include <cmath>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <vector>

#include "mapdelta/common/error.hpp"

namespace mapdelta {
namespace {

std::ifstream OpenForReading(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error(ErrorCode::kIo, path + ": cannot open trajectory file");
  return in;
}

bool IsCommentOrBlank(const std::string& line) {
  const size_t first = line.find_first_not_of(" \t\r");
  return first == std::string::npos || line[first] == '#';
}

// Splits on commas and/or whitespace and parses every field as a number.
bool ParseNumbers(const std::string& line, std::vector<double>* values) {
  values->clear();
  std::string normalized = line;
  for (char& c : normalized) {
    if (c == ',') c = ' ';
  }
  std::istringstream fields(normalized);
  std::string field;
  while (fields >> field) {
    char* end = nullptr;
    const double value = std::strtod(field.c_str(), &end);
    if (end != field.c_str() + field.size() || !std::isfinite(value)) return false;
    values->push_back(value);
  }
  return true;
}

[[noreturn]] void LineError(const std::string& path, int line_number, const std::string& what) {
  throw Error(ErrorCode::kParse, path + ":" + std::to_string(line_number) + ": " + what);
}

// int64 nanoseconds end at 9.22e9 s (year 2262).
constexpr double kMaxStampSeconds = 9.2e9;

// TUM seconds to ns without going through double (which keeps only ~16 digits: a 2014 epoch
// stamp would lose its last ~100 ns). Falls back to double for exponent forms like "1.4e9".
int64_t SecondsTextToNs(const std::string& line, double fallback_seconds) {
  const size_t begin = line.find_first_not_of(" \t");
  const size_t end = line.find_first_of(" \t,", begin);
  const std::string text = line.substr(begin, end - begin);
  const size_t dot = text.find('.');
  const std::string whole = text.substr(0, dot);
  const std::string frac = dot == std::string::npos ? "" : text.substr(dot + 1);
  const auto digits = [](const std::string& s) {
    return s.find_first_not_of("0123456789") == std::string::npos;
  };
  if (whole.empty() || whole.size() > 10 || !digits(whole) || !digits(frac)) {
    return static_cast<int64_t>(std::llround(fallback_seconds * 1e9));
  }
  int64_t ns = std::stoll(whole) * 1000000000LL;
  int64_t scale = 100000000LL;
  for (size_t i = 0; i < frac.size() && i < 9; ++i, scale /= 10) ns += (frac[i] - '0') * scale;
  if (frac.size() > 9 && frac[9] >= '5') ++ns;  // round the tenth fractional digit
  return ns;
}

// Real data repeats stamps now and then (TUM fr2/desk ground truth does once); evo accepts
// that, so only decreasing stamps are an error.
void CheckSorted(const std::string& path, const Trajectory& trajectory) {
  for (size_t i = 1; i < trajectory.size(); ++i) {
    if (trajectory[i].t_ns < trajectory[i - 1].t_ns) {
      throw Error(ErrorCode::kParse,
                  path + ": timestamps decrease at pose " + std::to_string(i + 1));
    }
  }
}

}  // namespace

Trajectory ReadTumTrajectory(const std::string& path) {
  std::ifstream in = OpenForReading(path);
  Trajectory trajectory;
  std::string line;
  std::vector<double> v;
  for (int n = 1; std::getline(in, line); ++n) {
    if (IsCommentOrBlank(line)) continue;
    if (!ParseNumbers(line, &v) || v.size() != 8) {
      LineError(path, n, "expected 8 numbers 't x y z qx qy qz qw'");
    }
    const Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
    if (std::abs(q.norm() - 1.0) > 1e-2) LineError(path, n, "quaternion is not unit length");
    // Found by fuzz_euroc_csv: 9311868164 s overflowed int64 nanoseconds (undefined).
    if (!(std::abs(v[0]) < kMaxStampSeconds)) {
      LineError(path, n, "time stamp beyond +-9.2e9 s (int64 ns)");
    }
    trajectory.push_back({SecondsTextToNs(line, v[0]), MakeSE3(q, {v[1], v[2], v[3]})});
  }
  CheckSorted(path, trajectory);
  return trajectory;
}

Trajectory ReadEurocTrajectory(const std::string& path) {
  std::ifstream in = OpenForReading(path);
  Trajectory trajectory;
  std::string line;
  std::vector<double> v;
  for (int n = 1; std::getline(in, line); ++n) {
    if (IsCommentOrBlank(line)) continue;
    // Timestamps in ns exceed double's exact range: parse the first field as an integer.
    const size_t comma = line.find(',');
    if (comma == std::string::npos) LineError(path, n, "expected comma-separated values");
    int64_t t_ns = 0;
    try {
      size_t used = 0;
      t_ns = std::stoll(line.substr(0, comma), &used);
    } catch (const std::exception&) {
      LineError(path, n, "first field must be an integer timestamp in ns");
    }
    if (!ParseNumbers(line.substr(comma + 1), &v) || v.size() < 7) {
      LineError(path, n, "expected 'timestamp, px, py, pz, qw, qx, qy, qz[, ...]'");
    }
    const Eigen::Quaterniond q(v[3], v[4], v[5], v[6]);
    if (std::abs(q.norm() - 1.0) > 1e-2) LineError(path, n, "quaternion is not unit length");
    trajectory.push_back({t_ns, MakeSE3(q, {v[0], v[1], v[2]})});
  }
  CheckSorted(path, trajectory);
  return trajectory;
}

Trajectory ReadTrajectory(const std::string& path, TrajectoryFormat format) {
  if (format == TrajectoryFormat::kTum) return ReadTumTrajectory(path);
  if (format == TrajectoryFormat::kEuroc) return ReadEurocTrajectory(path);
  if (path.size() >= 4 && path.substr(path.size() - 4) == ".csv") return ReadEurocTrajectory(path);
  std::ifstream in = OpenForReading(path);
  std::string line;
  while (std::getline(in, line)) {
    if (IsCommentOrBlank(line)) continue;
    return line.find(',') != std::string::npos ? ReadEurocTrajectory(path)
                                               : ReadTumTrajectory(path);
  }
  return {};
}

void WriteTumTrajectory(const std::string& path, const Trajectory& trajectory) {
  std::ofstream out(path);
  if (!out) throw Error(ErrorCode::kIo, path + ": cannot open for writing");
  out << "# t x y z qx qy qz qw\n" << std::setprecision(9) << std::fixed;
  for (const auto& pose : trajectory) {
    const Eigen::Quaterniond q(pose.T.linear());
    const Eigen::Vector3d& t = pose.T.translation();
    out << pose.t_ns / 1000000000 << '.' << std::setw(9) << std::setfill('0')
        << pose.t_ns % 1000000000 << std::setfill(' ') << ' ' << t.x() << ' ' << t.y() << ' '
        << t.z() << ' ' << q.x() << ' ' << q.y() << ' ' << q.z() << ' ' << q.w() << '\n';
  }
  if (!out) throw Error(ErrorCode::kIo, path + ": write failed");
}

}  // namespace mapdelta
