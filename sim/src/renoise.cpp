#include "mapdelta/sim/renoise.hpp"

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/common/parallel.hpp"
#include "mapdelta/sim/dataset_writer.hpp"
#include "mapdelta/sim/generator.hpp"
#include "mapdelta/sim/imu.hpp"
#include "mapdelta/sim/random.hpp"
#include "mapdelta/sim/renderer.hpp"

namespace mapdelta::sim {
namespace fs = std::filesystem;

namespace {

void MakeDirs(const fs::path& p) {
  std::error_code ec;
  fs::create_directories(p, ec);
  if (ec) throw Error(ErrorCode::kIo, p.string() + ": cannot create directory: " + ec.message());
}

// Unchanged files are hard links (a paper sequence's depth is ~1 GB), copies across devices.
void LinkOrCopy(const fs::path& from, const fs::path& to) {
  std::error_code ec;
  fs::remove(to, ec);
  fs::create_hard_link(from, to, ec);
  if (!ec) return;
  fs::copy_file(from, to, fs::copy_options::overwrite_existing, ec);
  if (ec)
    throw Error(ErrorCode::kIo,
                to.string() + ": cannot copy from " + from.string() + ": " + ec.message());
}

void LinkTree(const fs::path& from, const fs::path& to) {
  MakeDirs(to);
  for (const auto& e : fs::recursive_directory_iterator(from)) {
    const fs::path target = to / fs::relative(e.path(), from);
    if (e.is_directory()) {
      MakeDirs(target);
    } else if (e.is_regular_file()) {
      LinkOrCopy(e.path(), target);
    }
  }
}

std::vector<std::string> ReadLines(const fs::path& p) {
  std::ifstream in(p);
  if (!in) throw Error(ErrorCode::kIo, p.string() + ": cannot open");
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (!line.empty()) lines.push_back(line);
  }
  return lines;
}

std::vector<std::string> Split(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream ss(line);
  for (std::string f; std::getline(ss, f, ',');) out.push_back(f);
  return out;
}

double ParseNumber(const std::string& s, const fs::path& file, size_t row) {
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (s.empty() || end != s.c_str() + s.size() || !std::isfinite(v)) {
    throw Error(ErrorCode::kParse,
                file.string() + ": row " + std::to_string(row) + ": '" + s + "' is not a number");
  }
  return v;
}

int64_t ParseStamp(const std::string& s, const fs::path& file, size_t row) {
  char* end = nullptr;
  const long long v = std::strtoll(s.c_str(), &end, 10);
  if (s.empty() || end != s.c_str() + s.size()) {
    throw Error(ErrorCode::kParse, file.string() + ": row " + std::to_string(row) + ": '" + s +
                                       "' is not a timestamp");
  }
  return v;
}

// Image file names of a camera's data.csv, in row (= frame index) order.
std::vector<std::string> ImageFiles(const fs::path& csv) {
  std::vector<std::string> files;
  size_t row = 0;
  for (const std::string& line : ReadLines(csv)) {
    ++row;
    if (line[0] == '#') continue;
    const auto f = Split(line);
    if (f.size() != 2)
      throw Error(ErrorCode::kParse, csv.string() + ": row " + std::to_string(row) +
                                         ": expected 'timestamp,filename'");
    files.push_back(f[1]);
  }
  return files;
}

std::vector<ImuSample> ReadCleanImu(const fs::path& csv) {
  std::vector<ImuSample> imu;
  size_t row = 0;
  for (const std::string& line : ReadLines(csv)) {
    ++row;
    if (line[0] == '#') continue;
    const auto f = Split(line);
    if (f.size() != 7)
      throw Error(ErrorCode::kParse, csv.string() + ": row " + std::to_string(row) +
                                         ": expected 7 fields, got " + std::to_string(f.size()));
    ImuSample s;
    s.t_ns = ParseStamp(f[0], csv, row);
    for (int i = 0; i < 3; ++i) {
      s.gyro[i] = ParseNumber(f[static_cast<size_t>(1 + i)], csv, row);
      s.accel[i] = ParseNumber(f[static_cast<size_t>(4 + i)], csv, row);
    }
    imu.push_back(s);
  }
  if (imu.empty()) throw Error(ErrorCode::kParse, csv.string() + ": no IMU samples");
  return imu;
}

// The clean ground truth with the noisy run's biases: poses and velocities are kept as text
// (the generator prints the same values), the six bias columns come from `imu`.
void WriteGroundTruthWithBiases(const fs::path& from, const fs::path& to,
                                const std::vector<ImuSample>& imu) {
  const auto lines = ReadLines(from);
  std::ofstream out(to);
  if (!out) throw Error(ErrorCode::kIo, to.string() + ": cannot open for writing");
  size_t k = 0;
  for (size_t row = 0; row < lines.size(); ++row) {
    if (lines[row][0] == '#') {
      out << lines[row] << '\n';
      continue;
    }
    const auto f = Split(lines[row]);
    if (f.size() != 17)
      throw Error(ErrorCode::kParse,
                  from.string() + ": row " + std::to_string(row + 1) + ": expected 17 fields");
    if (k >= imu.size() || ParseStamp(f[0], from, row + 1) != imu[k].t_ns) {
      throw Error(ErrorCode::kParse, from.string() + ": row " + std::to_string(row + 1) +
                                         ": does not match imu0/data.csv sample " +
                                         std::to_string(k));
    }
    for (size_t i = 0; i < 11; ++i) out << (i ? "," : "") << f[i];
    for (int i = 0; i < 3; ++i) out << ',' << FormatCsvNumber(imu[k].bias_gyro[i]);
    for (int i = 0; i < 3; ++i) out << ',' << FormatCsvNumber(imu[k].bias_accel[i]);
    out << '\n';
    ++k;
  }
  if (k != imu.size())
    throw Error(ErrorCode::kParse, from.string() + ": " + std::to_string(k) + " rows for " +
                                       std::to_string(imu.size()) + " IMU samples");
  out.close();
  if (!out) throw Error(ErrorCode::kIo, to.string() + ": write failed");
}

std::vector<uint8_t> ReadGrey(const fs::path& p, int* width, int* height) {
  const cv::Mat img = cv::imread(p.string(), cv::IMREAD_UNCHANGED);
  if (img.empty()) throw Error(ErrorCode::kIo, p.string() + ": cannot read PNG");
  if (img.type() != CV_8UC1)
    throw Error(ErrorCode::kParse, p.string() + ": expected an 8-bit grey image");
  *width = img.cols;
  *height = img.rows;
  std::vector<uint8_t> pixels(static_cast<size_t>(img.cols) * static_cast<size_t>(img.rows));
  for (int r = 0; r < img.rows; ++r)
    std::copy(img.ptr<uint8_t>(r), img.ptr<uint8_t>(r) + img.cols,
              pixels.begin() + static_cast<long>(r) * img.cols);
  return pixels;
}

void RenoiseSequence(const RenoiseOptions& o, const std::string& name, const ProgressFn& progress) {
  const fs::path from = fs::path(o.from_dir) / "sequences" / name,
                 to = fs::path(o.out_dir) / "sequences" / name;
  const fs::path info_path = from / "info.json";
  std::ifstream info_in(info_path);
  if (!info_in)
    throw Error(ErrorCode::kIo, info_path.string() + ": cannot open (is " + o.from_dir +
                                    " a mapdelta-sim dataset?)");
  nlohmann::json info;
  try {
    info = nlohmann::json::parse(info_in);
  } catch (const nlohmann::json::exception& e) {
    throw Error(ErrorCode::kParse, info_path.string() + ": " + e.what());
  }
  if (info.value("noise", std::string()) != "none") {
    throw Error(ErrorCode::kInvalidArgument,
                info_path.string() + ": noise is '" + info.value("noise", std::string("?")) +
                    "': renoise needs a dataset generated with --noise none");
  }
  // The euroc rig rotates noisy IMU samples into its IMU axes after the noise: not reproducible
  // from the clean CSV, so only the ideal rig (tiny, paper) is supported.
  if (info.value("rig", std::string("ideal")) != "ideal") {
    throw Error(ErrorCode::kUnsupported,
                info_path.string() + ": rig '" + info.value("rig", std::string()) +
                    "': renoise supports only the ideal rig (tiny, paper presets)");
  }
  if (!info.contains("imu_rate_hz") || !info["imu_rate_hz"].is_number()) {
    throw Error(ErrorCode::kParse, info_path.string() + ": missing number imu_rate_hz");
  }
  const double imu_rate = info["imu_rate_hz"].get<double>();
  const NoiseParams noise = NoiseFor(o.noise);
  const uint64_t key = SequenceNoiseKey(o.seed, name);
  const fs::path fmav = from / "mav0", tmav = to / "mav0";
  for (const char* d : {"cam0/data", "cam1/data", "imu0", "state_groundtruth_estimate0"})
    MakeDirs(tmav / d);
  for (const char* f : {"cam0/sensor.yaml", "cam1/sensor.yaml", "cam0/data.csv", "cam1/data.csv"})
    LinkOrCopy(fmav / f, tmav / f);
  if (fs::exists(fmav / "depth0")) LinkTree(fmav / "depth0", tmav / "depth0");

  // Images: frame k's camera c gets the noise key HashCombine(key, 2k + c), as in the generator.
  const std::vector<std::string> files[2] = {ImageFiles(fmav / "cam0/data.csv"),
                                             ImageFiles(fmav / "cam1/data.csv")};
  if (files[0].size() != files[1].size())
    throw Error(ErrorCode::kParse,
                (fmav / "cam1/data.csv").string() + ": frame count differs from cam0");
  ParallelFor(files[0].size(), ResolveThreads(o.threads), name + " renoise", progress,
              [&](size_t k) {
                thread_local std::vector<uint8_t> noisy;
                for (int ci = 0; ci < 2; ++ci) {
                  const char* cam = ci == 0 ? "cam0/data" : "cam1/data";
                  int w = 0, h = 0;
                  const auto clean = ReadGrey(fmav / cam / files[ci][k], &w, &h);
                  AddImageNoise(clean, noise.image_sigma,
                                HashCombine(key, 2 * k + static_cast<size_t>(ci)), &noisy);
                  WriteGreyPng((tmav / cam / files[ci][k]).string(), w, h, noisy);
                }
              });

  const auto imu = AddImuNoise(ReadCleanImu(fmav / "imu0/data.csv"), imu_rate, noise, key);
  WriteImuYaml((tmav / "imu0/sensor.yaml").string(), imu_rate, noise);
  WriteImuCsv((tmav / "imu0/data.csv").string(), imu);
  WriteGroundTruthWithBiases(fmav / "state_groundtruth_estimate0/data.csv",
                             tmav / "state_groundtruth_estimate0/data.csv", imu);

  double max_rate = 0;
  for (const ImuSample& s : imu)
    max_rate = std::max(max_rate, std::abs(s.gyro.z() - s.bias_gyro.z()));
  info["noise"] = ToString(o.noise);
  info["noise_seed"] = o.seed;
  info["image_noise_sigma"] = noise.image_sigma;
  info["max_yaw_rate_rad_s"] = max_rate;
  std::ofstream out(to / "info.json");
  out << info.dump(1) << '\n';
  if (!out) throw Error(ErrorCode::kIo, (to / "info.json").string() + ": write failed");
  MD_LOG(kInfo, "sequence " << name << ": " << files[0].size() << " stereo frames renoised ("
                            << ToString(o.noise) << ", noise seed " << o.seed << ")");
}

}  // namespace

void RenoiseDataset(const RenoiseOptions& o, const ProgressFn& progress) {
  const fs::path seqs = fs::path(o.from_dir) / "sequences";
  if (!fs::is_directory(seqs))
    throw Error(ErrorCode::kIo,
                seqs.string() + ": not a directory (expected a mapdelta-sim dataset)");
  std::error_code ec;
  if (fs::exists(o.out_dir) && fs::equivalent(o.from_dir, o.out_dir, ec)) {
    throw Error(ErrorCode::kInvalidArgument, o.out_dir + ": --out must differ from --from");
  }
  std::vector<std::string> names = o.sequences;
  if (names.empty()) {
    for (const auto& e : fs::directory_iterator(seqs)) {
      if (e.is_directory()) names.push_back(e.path().filename().string());
    }
    std::sort(names.begin(), names.end());
  }
  if (names.empty()) throw Error(ErrorCode::kInvalidArgument, seqs.string() + ": no sequences");
  if (fs::is_directory(fs::path(o.from_dir) / "scenes"))
    LinkTree(fs::path(o.from_dir) / "scenes", fs::path(o.out_dir) / "scenes");
  for (const std::string& name : names) RenoiseSequence(o, name, progress);
}

}  // namespace mapdelta::sim
