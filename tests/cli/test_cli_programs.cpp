// Every program's command line as a user meets it: --help exits 0 and lists the options, a
// bad option or value exits 2 with one line naming it, a bad config exits 2 naming file and
// key, an unreadable input file exits 1. Runs the real binaries (no server is started).
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "mapdelta/common/keyframes.hpp"
#include "support/temp_dir.hpp"

namespace mapdelta::testing {
namespace {

struct Outcome {
  int exit_code = -1;
  std::string out;  // stdout
  std::string err;  // stderr
};

// Runs `program args` with stdout and stderr captured into files in `dir`.
Outcome Run(const std::filesystem::path& dir, const std::string& program, const std::string& args) {
  const std::string out = (dir / "out.txt").string(), err = (dir / "err.txt").string();
  const std::string cmd = program + " " + args + " >" + out + " 2>" + err + " </dev/null";
  const int status = std::system(cmd.c_str());
  Outcome o;
  o.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  auto slurp = [](const std::string& path) {
    std::ifstream in(path);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  o.out = slurp(out);
  o.err = slurp(err);
  return o;
}

class CliPrograms : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = FreshTempDir("cli_programs"); }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  Outcome Run(const std::string& program, const std::string& args) {
    return testing::Run(dir_, program, args);
  }
  std::filesystem::path dir_;
};

TEST_F(CliPrograms, HelpEverywhere) {
  struct Case {
    std::string program, args, expected;
  } cases[] = {
      {MAPDELTA_SERVER_BIN, "--help", "token create"},
      {MAPDELTA_SERVER_BIN, "serve --help", "--web-root DIR"},
      {MAPDELTA_SERVER_BIN, "token create --help", "vehicle|reader|admin"},
      {MAPDELTA_CLIENT_BIN, "--help", "depth-eval"},
      {MAPDELTA_CLIENT_BIN, "run --help", "--inject-reset-at S"},
      {MAPDELTA_CLIENT_BIN, "upload --help", "--server URL"},
      {MAPDELTA_SIM_BIN, "--help", "--cam_rate_hz V"},
      {MAPDELTA_SIM_BIN, "renoise --help", "--from CLEAN"},
      {MAPDELTA_EVAL_BIN, "--help", "mapdelta-eval changes"},
      {MAPDELTA_EVAL_BIN, "ate --help", "se3|sim3|none"},
      {MAPDELTA_DETECT_BIN, "--help", "--free-ray-bound W"},
#ifdef MAPDELTA_VIO_BIN
      {MAPDELTA_VIO_BIN, "--help", "--set KEY=VALUE"},
#endif
  };
  for (const auto& c : cases) {
    const Outcome o = Run(c.program, c.args);
    EXPECT_EQ(o.exit_code, 0) << c.program << " " << c.args << ": " << o.err;
    EXPECT_NE(o.out.find(c.expected), std::string::npos) << c.program << " " << c.args << ":\n"
                                                         << o.out;
    EXPECT_NE(o.out.find("2 usage or configuration error"), std::string::npos)
        << c.program << " " << c.args;
  }
}

TEST_F(CliPrograms, UsageErrorsExit2AndNameTheOption) {
  std::ofstream(dir_ / "server.yaml")
      << "storage:\n  database: " << (dir_ / "db.sqlite").string() << "\n";
  const std::string config = (dir_ / "server.yaml").string();
  struct Case {
    std::string program, args, expected;
  } cases[] = {
      {MAPDELTA_SERVER_BIN, "serve --config " + config + " --port abc",
       "mapdelta-server serve: error: --port: expected an integer, got 'abc' (see 'mapdelta-server "
       "serve --help')\n"},
      {MAPDELTA_SERVER_BIN, "serve --config " + config + " --bogus",
       "mapdelta-server serve: error: unknown option --bogus (see 'mapdelta-server serve "
       "--help')\n"},
      {MAPDELTA_SERVER_BIN, "token create --config " + config + " --role pilot --name x",
       "--role: expected vehicle, reader, admin, got 'pilot'"},
      {MAPDELTA_SERVER_BIN, "token create --role admin", "missing --config, --name"},
      {MAPDELTA_SERVER_BIN, "frobnicate",
       "mapdelta-server frobnicate: error: unknown command 'frobnicate'"},
      {MAPDELTA_CLIENT_BIN, "upload dir --server http://x --token t --bogus",
       "unknown option --bogus"},
      {MAPDELTA_CLIENT_BIN, "run --sequence s --odometry gt --out o",
       "expected one of --prior and --server"},
      {MAPDELTA_CLIENT_BIN, "drift gt.txt out.txt --seed 1e3",
       "--seed: expected a non-negative integer, got '1e3'"},
      {MAPDELTA_CLIENT_BIN, "fly", "mapdelta-client: error: unknown command 'fly'"},
      {MAPDELTA_SIM_BIN, "--out d --widht 3", "mapdelta-sim: error: unknown option --widht"},
      {MAPDELTA_SIM_BIN, "--out d --fx abc --noise huge", "--fx: bad value 'abc'"},
      {MAPDELTA_SIM_BIN, "--out d --fx abc --noise huge", "--noise: bad value 'huge'"},
      {MAPDELTA_SIM_BIN, "renoise --from a", "missing --out"},
      {MAPDELTA_EVAL_BIN, "ate a.txt b.txt --align se4",
       "--align: expected se3, sim3, none, got 'se4'"},
      {MAPDELTA_EVAL_BIN, "ate a.txt", "missing EST"},
      {MAPDELTA_DETECT_BIN, "--prior p.pcd --keyframes k --out o --th-ch abc",
       "--th-ch: expected a number"},
#ifdef MAPDELTA_VIO_BIN
      {MAPDELTA_VIO_BIN, "--sequence s --out o --threads x",
       "--threads: expected an integer, got 'x'"},
#endif
  };
  for (const auto& c : cases) {
    const Outcome o = Run(c.program, c.args);
    EXPECT_EQ(o.exit_code, 2) << c.program << " " << c.args << ": " << o.err;
    EXPECT_NE(o.err.find(c.expected), std::string::npos) << c.program << " " << c.args << ":\n"
                                                         << o.err;
  }
}

TEST_F(CliPrograms, ConfigErrorsExit2AndUnreadableInputExits1) {
  std::ofstream(dir_ / "bad_server.yaml") << "http:\n  prot: 1\n";
  std::ofstream(dir_ / "bad_client.yaml") << "stereo:\n  block_size: 4\n";
  const Outcome server =
      Run(MAPDELTA_SERVER_BIN, "check-config --config " + (dir_ / "bad_server.yaml").string());
  EXPECT_EQ(server.exit_code, 2) << server.err;
  EXPECT_NE(server.err.find("bad_server.yaml: 1 problem(s):\n  - http.prot: unknown key"),
            std::string::npos)
      << server.err;
  const Outcome missing =
      Run(MAPDELTA_SERVER_BIN, "check-config --config " + (dir_ / "none.yaml").string());
  EXPECT_EQ(missing.exit_code, 2) << missing.err;
  const Outcome client =
      Run(MAPDELTA_CLIENT_BIN, "config --config " + (dir_ / "bad_client.yaml").string());
  EXPECT_EQ(client.exit_code, 2) << client.err;
  EXPECT_NE(client.err.find("stereo.block_size: must be odd"), std::string::npos) << client.err;
  // Every example config loads unchanged.
  const std::string source = MAPDELTA_SOURCE_DIR;
  EXPECT_EQ(
      Run(MAPDELTA_SERVER_BIN, "check-config --config " + source + "/config/server.example.yaml")
          .exit_code,
      0);
  const Outcome example =
      Run(MAPDELTA_CLIENT_BIN, "config --config " + source + "/config/client.example.yaml");
  EXPECT_EQ(example.exit_code, 0) << example.err;
  EXPECT_NE(example.out.find("temporal_filter:\n"), std::string::npos) << example.out;
  // A data file that is not there or not a trajectory: a runtime failure, exit 1.
  std::ofstream(dir_ / "bad.txt") << "1 2 3\n";
  const Outcome ate = Run(MAPDELTA_EVAL_BIN,
                          "ate " + (dir_ / "bad.txt").string() + " " + (dir_ / "bad.txt").string());
  EXPECT_EQ(ate.exit_code, 1) << ate.err;
  EXPECT_NE(ate.err.find("bad.txt:1"), std::string::npos) << ate.err;
}

TEST_F(CliPrograms, UploadGivesUpOnADeadServerWithProgressLinesAndKeepsTheQueue) {
  // Two small keyframes; port 9 on loopback (discard) has no listener here: connection refused.
  KeyframeFolder folder;
  folder.camera.width = 8;
  folder.camera.height = 6;
  folder.camera.fx = folder.camera.fy = 10;
  folder.camera.cx = 4;
  folder.camera.cy = 3;
  for (int i = 0; i < 2; ++i) {
    Keyframe k;
    k.t_ns = 1'000'000'000LL + i * 100'000'000LL;
    k.depth = DepthImage(8, 6);
    for (auto& d : k.depth.depth_m) d = 2.0f;
    folder.keyframes.push_back(k);
  }
  WriteKeyframeFolder((dir_ / "kf").string(), folder);
  const Outcome o =
      Run(MAPDELTA_CLIENT_BIN, "upload " + (dir_ / "kf").string() +
                                   " --server http://127.0.0.1:9 --token t --give-up-after 1");
  EXPECT_EQ(o.exit_code, 1) << o.err;
  EXPECT_NE(o.err.find("mapdelta-client upload: error: gave up after"), std::string::npos) << o.err;
  EXPECT_NE(o.err.find("2 keyframes stay queued in"), std::string::npos) << o.err;
  EXPECT_NE(o.err.find("upload: 0/2 keyframes sent\n"), std::string::npos) << o.err;
  EXPECT_EQ(o.err.find('\r'), std::string::npos) << "stderr is a file: whole lines only";
  EXPECT_TRUE(std::filesystem::exists(dir_ / "kf.upload_queue"));
}

}  // namespace
}  // namespace mapdelta::testing
