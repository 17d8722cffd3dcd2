// The uploader against the real mapdelta-server process (SQLite, HTTP): the server is killed
// and restarted mid-session (same database and port), the client is "killed" (uploader and
// queue destroyed) and restarted from its on-disk queue while the server is down. The oracle:
// the server's session ends with exactly n keyframes (it accepts seq only in order and
// answers identical retries with 200, so a lost or duplicated keyframe would show) and is
// committed once.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <atomic>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>
#include <thread>

#include <sys/wait.h>
#include <unistd.h>

#include "mapdelta/client/http_transport.hpp"
#include "mapdelta/client/uploader.hpp"
#include "support/temp_dir.hpp"

namespace mapdelta::client {
namespace {

namespace fs = std::filesystem;

std::string RunCapture(const std::string& command) {
  std::string out;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return out;
  char buffer[512];
  while (fgets(buffer, sizeof(buffer), pipe) != nullptr) out += buffer;
  pclose(pipe);
  return out;
}

// mapdelta-server serve as a child process; waits for "listening on HOST:PORT".
class ServerProcess {
 public:
  ServerProcess(const std::string& config, int port) {
    int fds[2];
    if (pipe(fds) != 0) return;
    pid_ = fork();
    if (pid_ == 0) {
      dup2(fds[1], STDOUT_FILENO);
      close(fds[0]);
      const std::string port_text = std::to_string(port);
      execl(MAPDELTA_SERVER_BIN, MAPDELTA_SERVER_BIN, "serve", "--config", config.c_str(), "--port",
            port_text.c_str(), static_cast<char*>(nullptr));
      _exit(127);
    }
    close(fds[1]);
    FILE* out = fdopen(fds[0], "r");
    char line[256];
    const std::regex listening(R"(listening on [^:]+:(\d+))");
    while (out != nullptr && fgets(line, sizeof(line), out) != nullptr) {
      std::cmatch m;
      if (std::regex_search(line, m, listening)) {
        port_ = std::stoi(m[1]);
        break;
      }
    }
    stdout_ = out;
  }
  ~ServerProcess() { Kill(); }
  void Kill() {
    if (pid_ > 0) {
      kill(pid_, SIGKILL);  // a crash, not a graceful stop
      waitpid(pid_, nullptr, 0);
      pid_ = -1;
    }
    if (stdout_ != nullptr) {
      fclose(stdout_);
      stdout_ = nullptr;
    }
  }
  int port() const { return port_; }

 private:
  pid_t pid_ = -1;
  int port_ = 0;
  FILE* stdout_ = nullptr;
};

Keyframe MakeKeyframe(int i) {
  Keyframe k;
  k.t_ns = 2'000'000'000LL + i * 100'000'000LL;
  k.T_map_cam.translation() = Eigen::Vector3d(i, 0.2 * i, 1.5);
  k.covariance = Eigen::Matrix<double, 6, 6>::Identity() * 0.01;
  k.depth = DepthImage(32, 24);
  for (size_t p = 0; p < k.depth.depth_m.size(); ++p)
    k.depth.depth_m[p] = 2.0f + 0.01f * ((p + i) % 100);
  return k;
}

TEST(UploaderRealServer, ServerCrashAndClientRestartLoseAndDuplicateNothing) {
  const fs::path dir = mapdelta::testing::FreshTempDir("mapdelta_client_real_server");
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string config = (dir / "server.yaml").string();
  std::ofstream(config) << "http:\n  port: 0\nstorage:\n  database: "
                        << (dir / "db.sqlite").string()
                        << "\nlog:\n  level: error\n  format: text\n";
  const std::string created =
      RunCapture(std::string(MAPDELTA_SERVER_BIN) + " token create --config " + config +
                 " --role vehicle --name client-test");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(created, m, std::regex(R"(token:\s*(\S+))"))) << created;
  const std::string token = m[1];

  auto server = std::make_unique<ServerProcess>(config, 0);
  const int port = server->port();
  ASSERT_GT(port, 0);
  const std::string url = "http://127.0.0.1:" + std::to_string(port);
  PinholeCamera camera;
  camera.width = 32;
  camera.height = 24;
  camera.fx = camera.fy = 20;
  camera.cx = 16;
  camera.cy = 12;
  UploadConfig upload;
  upload.retry_initial_s = 0.02;
  upload.retry_max_s = 0.2;
  upload.timeout_s = 2.0;
  const int n = 10;
  std::atomic<bool> stop{false};
  {
    UploadQueue queue((dir / "queue").string());
    auto transport = MakeHttpTransport(url, token, upload.timeout_s);
    Uploader uploader(upload, camera, &queue, transport.get());
    std::thread runner([&] { uploader.Run(stop); });
    for (int i = 0; i < 6; ++i) uploader.Enqueue(MakeKeyframe(i));
    while (queue.PendingCount() > 3) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    server->Kill();  // the server crashes mid-session ...
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    stop = true;  // ... and the client is killed while it retries
    runner.join();
  }
  stop = false;
  UploadQueue queue((dir / "queue").string());
  auto transport = MakeHttpTransport(url, token, upload.timeout_s);
  Uploader uploader(upload, camera, &queue, transport.get());
  UploadReport report;
  std::thread runner([&] { report = uploader.Run(stop); });
  for (int i = 6; i < n; ++i) uploader.Enqueue(MakeKeyframe(i));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // still down
  server = std::make_unique<ServerProcess>(config, port);       // back on the same port
  ASSERT_EQ(server->port(), port);
  queue.Seal();
  runner.join();
  EXPECT_TRUE(report.committed) << report.fatal;
  EXPECT_EQ(report.conflicts, 0u);
  EXPECT_GT(report.retries, 0u);

  const HttpResponse session = transport->Get("/v1/sessions/" + report.session_id);
  ASSERT_TRUE(session.Ok()) << session.status << " " << session.body;
  const auto j = nlohmann::json::parse(session.body);
  std::printf("server session after crash + client restart: %s\n", session.body.c_str());
  EXPECT_EQ(j.at("keyframe_count").get<int>(), n) << session.body;
  EXPECT_NE(j.at("state").get<std::string>(), "open") << session.body;
}

}  // namespace
}  // namespace mapdelta::client
