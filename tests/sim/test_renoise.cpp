// mapdelta-sim renoise: clean render + noise equals the generator's noisy output byte for byte
// (same noise seed), another seed changes only the noise, with the preset's statistics.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "mapdelta/common/error.hpp"
#include "mapdelta/sim/generator.hpp"
#include "mapdelta/sim/renoise.hpp"
#include "support/temp_dir.hpp"

namespace mapdelta::sim {
namespace {
namespace fs = std::filesystem;

std::string TempDir(const std::string& name) {
  const auto dir = mapdelta::testing::FreshTempDir("mapdelta_test_sim_renoise_" + name);
  fs::remove_all(dir);
  return dir.string();
}

SimConfig Mini(NoiseLevel noise) {
  SimConfig c = PresetConfig("tiny");
  c.width = 80;
  c.height = 45;
  c.fx = c.fy = 40;
  c.cx = 40;
  c.cy = 22.5;
  c.duration_s = 1.5;
  c.length_m = 6;
  c.cloud_leaf = 0.6;
  c.noise = noise;
  c.seed = 3;
  c.sequences = {"S1_01"};
  return c;
}

std::string Slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::map<std::string, std::string> AllFiles(const std::string& root) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(root)) {
    if (e.is_regular_file()) files[fs::relative(e.path(), root).string()] = Slurp(e.path());
  }
  return files;
}

TEST(SimRenoise, CleanPlusRenoiseIsByteIdenticalToTheGeneratorAndSeedsOnlyChangeNoise) {
  const std::string clean = TempDir("clean"), direct = TempDir("direct"),
                    renoised = TempDir("renoised"), other = TempDir("other");
  GenerateDataset(Mini(NoiseLevel::kNone), clean, nullptr);
  GenerateDataset(Mini(NoiseLevel::kSmall), direct, nullptr);
  RenoiseOptions o;
  o.from_dir = clean;
  o.out_dir = renoised;
  o.noise = NoiseLevel::kSmall;
  o.seed = 3;
  RenoiseDataset(o, nullptr);

  const auto fd = AllFiles(direct), fr = AllFiles(renoised);
  ASSERT_GT(fd.size(), 60u);
  ASSERT_EQ(fd.size(), fr.size());
  for (const auto& [name, bytes] : fd) {
    ASSERT_TRUE(fr.count(name)) << name << " missing from the renoised dataset";
    EXPECT_TRUE(bytes == fr.at(name)) << name << " differs between generator and renoise";
  }

  // Another noise seed: same city and trajectory (GT poses), other noise with sigma 0.02.
  o.out_dir = other;
  o.seed = 4;
  RenoiseDataset(o, nullptr);
  const fs::path seq = fs::path("sequences") / "S1_01" / "mav0";
  const auto info = nlohmann::json::parse(Slurp(fs::path(other) / "sequences/S1_01/info.json"));
  EXPECT_EQ(info["seed"].get<uint64_t>(), 3u);
  EXPECT_EQ(info["noise_seed"].get<uint64_t>(), 4u);
  EXPECT_EQ(info["noise"].get<std::string>(), "small");
  EXPECT_NE(Slurp(fs::path(other) / seq / "imu0/data.csv"),
            Slurp(fs::path(renoised) / seq / "imu0/data.csv"));
  // GT: same poses (first 11 columns), different biases.
  std::ifstream a(fs::path(other) / seq / "state_groundtruth_estimate0/data.csv"),
      b(fs::path(renoised) / seq / "state_groundtruth_estimate0/data.csv");
  size_t rows = 0;
  for (std::string la, lb; std::getline(a, la) && std::getline(b, lb); ++rows) {
    auto prefix = [](const std::string& l) {
      size_t pos = 0;
      for (int i = 0; i < 11 && pos != std::string::npos; ++i) pos = l.find(',', pos + 1);
      return l.substr(0, pos);
    };
    ASSERT_EQ(prefix(la), prefix(lb)) << "row " << rows;
  }
  EXPECT_GT(rows, 250u);
  double sum = 0, sum2 = 0;
  size_t n = 0, differ = 0;
  for (const auto& e : fs::directory_iterator(fs::path(clean) / seq / "cam1/data")) {
    const cv::Mat c = cv::imread(e.path().string(), cv::IMREAD_UNCHANGED);
    const cv::Mat s4 = cv::imread(
        (fs::path(other) / seq / "cam1/data" / e.path().filename()).string(), cv::IMREAD_UNCHANGED);
    const cv::Mat s3 =
        cv::imread((fs::path(renoised) / seq / "cam1/data" / e.path().filename()).string(),
                   cv::IMREAD_UNCHANGED);
    ASSERT_EQ(c.size(), s4.size());
    for (int r = 0; r < c.rows; ++r) {
      for (int col = 0; col < c.cols; ++col) {
        const int v = c.at<uint8_t>(r, col);
        if (v < 30 || v > 225) continue;  // far from clipping
        const double d = s4.at<uint8_t>(r, col) - v;
        sum += d;
        sum2 += d * d;
        ++n;
        differ += s4.at<uint8_t>(r, col) != s3.at<uint8_t>(r, col);
      }
    }
  }
  ASSERT_GT(n, 50000u);
  const double mean = sum / static_cast<double>(n),
               sd = std::sqrt(sum2 / static_cast<double>(n) - mean * mean);
  EXPECT_NEAR(mean, 0.0, 0.1);
  // sigma 0.02 of full scale = 5.1 levels, plus 1/12 level^2 from rounding; ~10^5 samples.
  EXPECT_NEAR(sd, std::sqrt(5.1 * 5.1 + 1.0 / 12), 0.1);
  EXPECT_GT(static_cast<double>(differ) / static_cast<double>(n), 0.8);
}

TEST(SimRenoise, RefusesNoisyInputAndMissingFolders) {
  const std::string noisy = TempDir("noisy_in"), out = TempDir("noisy_out");
  SimConfig c = Mini(NoiseLevel::kSmall);
  c.duration_s = 0.2;
  GenerateDataset(c, noisy, nullptr);
  RenoiseOptions o;
  o.from_dir = noisy;
  o.out_dir = out;
  try {
    RenoiseDataset(o, nullptr);
    FAIL() << "renoise accepted a noisy dataset";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--noise none"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("info.json"), std::string::npos) << e.what();
  }
  o.from_dir = out + "/does-not-exist";
  EXPECT_THROW(RenoiseDataset(o, nullptr), Error);
  bool help = false, quiet = false;
  EXPECT_THROW(ParseRenoiseArgs({"--from", "x"}, &help, &quiet), Error);  // --out missing
  EXPECT_THROW(ParseRenoiseArgs({"--from", "x", "--out", "y", "--noise", "loud"}, &help, &quiet),
               Error);
  const RenoiseOptions parsed = ParseRenoiseArgs(
      {"--from", "x", "--out", "y", "--noise", "big", "--seed", "7"}, &help, &quiet);
  EXPECT_EQ(parsed.noise, NoiseLevel::kBig);
  EXPECT_EQ(parsed.seed, 7u);
}

}  // namespace
}  // namespace mapdelta::sim
