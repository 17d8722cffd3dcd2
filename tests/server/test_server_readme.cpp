// server/README.md "Run it for real", run as written: the commands are read from the README
// (so this test breaks when the README drifts from the server) and run by bash in a fresh
// folder laid out as the README expects (build/server/mapdelta-server, config/, prior.pcd,
// depth/1000.png: a tiny generated prior and one depth PNG), against the real binary.
// What the test does that a reader would do by hand, and nothing else:
//  - skips the set-up lines (deploy/install-deps.sh, the cmake build): the build made the binary;
//  - edits server.yaml as the README's comment says (storage.database, http.port: 0 = free port);
//  - takes $V, $R, $A from the "token:" lines that `token create` prints;
//  - runs `serve` in the background and sends the curl lines to the port it printed.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>

#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/depth_image.hpp"
#include "support/temp_dir.hpp"

namespace mapdelta::testing {
namespace {

using Json = nlohmann::json;
namespace fs = std::filesystem;

// The shell commands of a README section: its ```sh blocks, backslash continuations joined.
std::vector<std::string> SectionCommands(const std::string& readme_path,
                                         const std::string& heading) {
  std::ifstream in(readme_path);
  std::vector<std::string> commands;
  bool in_section = false, in_block = false;
  std::string pending;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("## ", 0) == 0) in_section = line == heading;
    if (!in_section) continue;
    if (line.rfind("```", 0) == 0) {
      in_block = !in_block && line == "```sh";
      continue;
    }
    if (!in_block) continue;
    if (!line.empty() && line.back() == '\\') {
      pending += line.substr(0, line.size() - 1);
      continue;
    }
    pending += line;
    if (pending.find_first_not_of(' ') != std::string::npos) commands.push_back(pending);
    pending.clear();
  }
  return commands;
}

struct CommandRun {
  int exit_code = -1;
  std::string out;
};

// Runs one command with bash in `dir` (stdout captured, stderr to the log), bounded in time.
CommandRun Bash(const fs::path& dir, const std::string& command, const fs::path& log) {
  std::ofstream(dir / "command.sh") << command << "\n";
  const std::string cmd =
      "cd '" + dir.string() + "' && timeout 120 bash command.sh 2>>'" + log.string() + "'";
  CommandRun r;
  FILE* pipe = popen(cmd.c_str(), "r");
  char buf[4096];
  size_t n;
  while (pipe && (n = fread(buf, 1, sizeof(buf), pipe)) > 0) r.out.append(buf, n);
  const int status = pipe ? pclose(pipe) : -1;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

// `serve` in the background; returns its pid and the port from "listening on HOST:PORT".
pid_t StartServe(const fs::path& dir, const std::string& command, const fs::path& log, int* port) {
  int fds[2];
  if (pipe(fds) != 0) return -1;
  const pid_t pid = fork();
  if (pid == 0) {
    dup2(fds[1], 1);
    FILE* err = std::fopen(log.c_str(), "a");
    if (err) dup2(fileno(err), 2);
    close(fds[0]);
    if (chdir(dir.c_str()) != 0) _exit(126);
    execl("/bin/bash", "bash", "-c", ("exec " + command).c_str(), nullptr);
    _exit(127);
  }
  close(fds[1]);
  FILE* out = fdopen(fds[0], "r");
  char line[256] = {0};
  *port = 0;
  if (out && fgets(line, sizeof(line), out)) {
    std::smatch m;
    const std::string s(line);
    if (std::regex_search(s, m, std::regex("listening on [0-9.]+:([0-9]+)")))
      *port = std::stoi(m[1]);
  }
  if (out) fclose(out);
  return pid;
}

// What the README's reader brings: a prior (a 0.2 m grid plane at z = 6.5 over x in [-10, -2],
// above mapped ground at z = 0 over x, y in [-10, 10]) and one 800x450 depth PNG, 5 m
// everywhere. The README's keyframe camera sits at z = 1.5 looking up (identity rotation:
// camera z = map z), so it sees a 10 x 5.6 m patch of the upper plane: the part at
// x > -2 + th_ch (3.2 m) is new (within the prior's footprint, over the mapped ground), and
// lies in tiles 0_0 and 0_-1.
void WriteInputs(const fs::path& dir) {
  PointCloud prior;
  for (float x = -10; x <= 10; x += 0.2f) {
    for (float y = -10; y <= 10; y += 0.2f) {
      prior.emplace_back(x, y, 0.f);
      if (x <= -2) prior.emplace_back(x, y, 6.5f);
    }
  }
  WriteCloud((dir / "prior.pcd").string(), prior);
  fs::create_directories(dir / "depth");
  DepthImage depth(800, 450);
  std::fill(depth.depth_m.begin(), depth.depth_m.end(), 5.0f);
  WriteDepthPng((dir / "depth/1000.png").string(), depth);
}

// The README says: "edit storage.database, http.port".
void EditServerYaml(const fs::path& dir) {
  std::ifstream in(dir / "server.yaml");
  std::stringstream edited;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("  database:", 0) == 0) line = "  database: " + (dir / "mapdelta.db").string();
    if (line.rfind("  port:", 0) == 0) line = "  port: 0";
    edited << line << "\n";
  }
  in.close();
  std::ofstream(dir / "server.yaml") << edited.str();
}

// Stops the background server however the test ends (SIGKILL unless Stop() came first).
struct ServeProcess {
  pid_t pid = -1;
  int Stop(int sig) {
    if (pid <= 0) return -1;
    ::kill(pid, sig);
    int status = 0;
    waitpid(pid, &status, 0);
    pid = -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
  }
  ~ServeProcess() { Stop(SIGKILL); }
};

std::string Replace(std::string s, const std::string& from, const std::string& to) {
  for (size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size()))
    s.replace(at, from.size(), to);
  return s;
}

class ServerReadme : public ::testing::Test {
 protected:
  void TearDown() override {
    if (log_.empty()) return;
    if (HasFailure()) std::system(("tail -n 20 '" + log_.string() + "' >&2").c_str());
    if (!HasFailure()) fs::remove_all(log_.parent_path());
  }
  fs::path log_;
};

TEST_F(ServerReadme, RunItForRealWalkThroughWorksAsWritten) {
  const auto commands =
      SectionCommands(std::string(MAPDELTA_SOURCE_DIR) + "/server/README.md", "## Run it for real");
  ASSERT_GE(commands.size(), 14u) << "the README's walk-through was not found";
  const fs::path dir = FreshTempDir("mapdelta_readme");
  const fs::path log = log_ = dir / "stderr.log";
  fs::create_directories(dir / "build/server");
  fs::create_symlink(MAPDELTA_SERVER_BIN, dir / "build/server/mapdelta-server");
  fs::create_directories(dir / "config");
  fs::copy_file(std::string(MAPDELTA_SOURCE_DIR) + "/config/server.example.yaml",
                dir / "config/server.example.yaml");
  WriteInputs(dir);

  std::map<std::string, std::string> tokens;  // V, R, A
  ServeProcess server;
  int port = 0;
  size_t curl_lines = 0;
  for (const std::string& readme_command : commands) {
    SCOPED_TRACE(readme_command);
    if (readme_command.rfind("deploy/install-deps.sh", 0) == 0 ||
        readme_command.rfind("cmake ", 0) == 0)
      continue;
    if (readme_command.find(" serve ") != std::string::npos) {
      server.pid = StartServe(dir, readme_command, log, &port);
      ASSERT_GT(port, 0) << "serve did not print 'listening on HOST:PORT'";
      continue;
    }
    std::string command =
        Replace(readme_command, "localhost:8080", "localhost:" + std::to_string(port));
    std::string exports;
    for (const auto& [name, value] : tokens) exports += name + "='" + value + "' ";
    const CommandRun r =
        Bash(dir, (exports.empty() ? "" : "export " + exports + "; ") + command, log);
    ASSERT_EQ(r.exit_code, 0) << r.out;
    if (readme_command.rfind("cp config/server.example.yaml server.yaml", 0) == 0)
      EditServerYaml(dir);
    if (readme_command.find("token create") != std::string::npos) {
      std::smatch m;
      ASSERT_TRUE(std::regex_search(r.out, m, std::regex("token: (\\S+)"))) << r.out;
      const std::string role = std::regex_search(readme_command, std::regex("--role admin")) ? "A"
                               : std::regex_search(readme_command, std::regex("--role vehicle"))
                                   ? "V"
                                   : "R";
      tokens[role] = m[1];
    }
    if (readme_command.find("import-prior") != std::string::npos) {
      EXPECT_EQ(Json::parse(r.out)["prior_version"], 1) << r.out;
    }
    if (readme_command.find("export-autoware") != std::string::npos) {
      // The Autoware folder: tile PCDs and their metadata (round trip: test_server_autoware).
      EXPECT_NE(r.out.find("prior_version: 1\n"), std::string::npos) << r.out;
      EXPECT_TRUE(fs::exists(dir / "autoware-map/pointcloud_map_metadata.yaml")) << r.out;
    }
    if (readme_command.rfind("curl", 0) != 0) continue;
    ++curl_lines;
    if (readme_command.find("> new.ply") != std::string::npos) {
      // Tile 0_0's new points as PLY, with their evidence as properties.
      const PointCloud fresh = ReadCloud((dir / "new.ply").string());
      EXPECT_GT(fresh.size(), 5u);
      for (const Point& p : fresh) {
        EXPECT_GT(p.x(), 1.2f);
        EXPECT_GE(p.y(), 0.f);
        EXPECT_NEAR(p.z(), 6.5f, 0.5f);
      }
      std::ifstream ply(dir / "new.ply", std::ios::binary);
      const std::string bytes((std::istreambuf_iterator<char>(ply)), {});
      EXPECT_NE(bytes.find("property float confidence"), std::string::npos);
      continue;
    }
    if (r.out.empty()) continue;  // the wait loop prints nothing
    const Json answer = Json::parse(r.out, nullptr, false);
    ASSERT_FALSE(answer.is_discarded()) << r.out;
    EXPECT_FALSE(answer.contains("error")) << r.out;
    const auto is = [&](const char* part) {
      return readme_command.find(part) != std::string::npos;
    };
    if (is("/v1/sessions ")) {
      EXPECT_EQ(answer["session_id"], 1);
    } else if (is("/keyframes/0")) {
      EXPECT_EQ(answer["stored"], true);
    } else if (is("/commit") || is("/v1/admin/jobs")) {
      EXPECT_TRUE(answer.contains("job_id")) << r.out;
    } else if (is("/v1/changes/tiles?bbox")) {
      std::map<std::string, int> new_counts;
      for (const Json& t : answer["tiles"]) new_counts[t["tile"]] = t["new_count"];
      EXPECT_GT(new_counts["0_0"], 5) << r.out;
      EXPECT_GT(new_counts["0_-1"], 5) << r.out;
    } else {
      ADD_FAILURE() << "a curl line this test does not know: say what it should answer";
    }
  }
  EXPECT_GE(curl_lines, 6u);
  EXPECT_EQ(server.Stop(SIGTERM), 0) << "serve did not stop cleanly on SIGTERM";
}

}  // namespace
}  // namespace mapdelta::testing
