// Process-level tests of the real mapdelta-server binary: the token CLI, SIGKILL during
// uploads (no acknowledged keyframe lost), SIGKILL during a commit (the job resumes and gives
// the same per-tile result as an uninterrupted run), SIGTERM (clean exit 0), one server per
// SQLite database and per port. Each on both storage backends (SQLite and a throw-away
// PostgreSQL).
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <thread>

#include "changed_scene.hpp"
#include "mapdelta/common/cloud_io.hpp"
#include "server_backends.hpp"
#include "server_process.hpp"

#include <httplib.h>  // last: its <resolv.h> defines macros that break Eigen

namespace mapdelta::testing {
namespace {

using Json = nlohmann::json;
namespace fs = std::filesystem;

class ServerProcessTest : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("mds_proc_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    config_ = (dir_ / "server.yaml").string();
    log_ = (dir_ / "server.log").string();
    NewDatabase();
  }
  // Writes the config with a new, empty database of this test's backend and makes tokens.
  void NewDatabase() {
    server::ServerConfig db;
    UseFreshDatabase(GetParam(), dir_, &db);
    std::ofstream(config_)
        << "storage:\n  backend: " << db.storage.backend << "\n  database: \""
        << db.storage.database << "\"\n  postgres_url: \"" << db.storage.postgres_url
        << "\"\n  tile_size_m: 20\njobs:\n  lease_s: 2\nlog:\n  level: info\n  format: json\n"
        << "pipeline:\n  max_depth_m: 50\n  free_space_depth_m: 20\n  pixel_stride: 1\n"
        << "classify:\n  th_ch_m: 2.4\n";
    admin_ = Token("admin");
    vehicle_ = Token("vehicle");
  }
  void TearDown() override {
    if (HasFailure()) std::system(("tail -n 30 " + log_ + " >&2").c_str());
    fs::remove_all(dir_);
  }

  std::string Token(const std::string& role) {
    int code = 0;
    const std::string out =
        RunCli("token create --config " + config_ + " --role " + role + " --name t-" + role, &code);
    EXPECT_EQ(code, 0) << out;
    const auto at = out.find("token: ");
    return at == std::string::npos ? ""
                                   : "Bearer " + out.substr(at + 7, out.find('\n', at) - at - 7);
  }

  httplib::Headers H(const std::string& t) { return {{"Authorization", t}}; }

  int64_t CreateSession(httplib::Client& c) {
    const Json camera{{"width", 160}, {"height", 90}, {"fx", 80},
                      {"fy", 80},     {"cx", 80},     {"cy", 45}};
    auto r = c.Post("/v1/sessions", H(vehicle_),
                    Json{{"vehicle_id", "car"}, {"camera", camera}}.dump(), "application/json");
    EXPECT_TRUE(r && r->status == 201);
    return r ? Json::parse(r->body)["session_id"].get<int64_t>() : -1;
  }

  // Keyframe seq of a drive along x (1 m steps), as multipart items.
  httplib::MultipartFormDataItems Keyframe(int seq, double y_cam) {
    const SE3 T = CameraLookingMinusY(-5 + seq * 1.0, y_cam, kCameraHeight, kPitch);
    const std::string png = PngString(ChangedScene().Render(TestCamera(), T, kMaxDepth));
    return {{"meta", MetaJson(1000000000LL * (seq + 1), T).dump(), "", "application/json"},
            {"depth", png, "d.png", "image/png"}};
  }

  int Put(httplib::Client& c, int64_t session, int seq, double y_cam) {
    auto r = c.Put("/v1/sessions/" + std::to_string(session) + "/keyframes/" + std::to_string(seq),
                   H(vehicle_), Keyframe(seq, y_cam));
    return r ? r->status : 0;
  }

  Json Get(httplib::Client& c, const std::string& path, const std::string& token) {
    auto r = c.Get(path, H(token));
    EXPECT_TRUE(r && r->status == 200) << path << ": " << (r ? r->body : "no response");
    return r ? Json::parse(r->body) : Json();
  }

  Json WaitJob(httplib::Client& c, int64_t job) {
    for (int i = 0; i < 1200; ++i) {
      const Json j = Get(c, "/v1/admin/jobs/" + std::to_string(job), admin_);
      if (j.value("state", "") != "queued" && j.value("state", "") != "running") return j;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return Json();
  }

  void ImportPrior(httplib::Client& c) {
    const std::string file = (dir_ / "prior.pcd").string();
    WriteCloud(file, PriorScene().Sample(0.4));
    std::ifstream in(file, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), {});
    auto r = c.Post("/v1/admin/prior?format=pcd", H(admin_), bytes, "application/octet-stream");
    ASSERT_TRUE(r && r->status == 201);
  }

  fs::path dir_;
  std::string config_, log_, admin_, vehicle_;
};

TEST_P(ServerProcessTest, TokenCliAndSigterm) {
  int code = 0;
  EXPECT_NE(RunCli("--help", &code).find("token create"), std::string::npos);
  EXPECT_EQ(code, 0);
  RunCli("token create --config " + config_ + " --role pilot --name x", &code);
  EXPECT_EQ(code, 2);
  ServerProcess server(config_, log_);
  httplib::Client c("127.0.0.1", server.port());
  EXPECT_EQ(c.Get("/v1/admin/jobs", H(admin_))->status, 200);
  // Revoke through the CLI: the running server rejects the token at once.
  const std::string id = admin_.substr(std::string("Bearer mdt_").size(), 12);
  RunCli("token revoke --config " + config_ + " --id " + id, &code);
  EXPECT_EQ(code, 0);
  EXPECT_EQ(c.Get("/v1/admin/jobs", H(admin_))->status, 401);
  EXPECT_EQ(server.Kill(SIGTERM), 0);
}

// A second server on the same database is refused (it would run a second job worker on the
// same jobs) with an error naming the first one; the kernel drops the first one's lock when it
// is SIGKILLed, so a restart after a crash is not blocked.
TEST_P(ServerProcessTest, SecondServerOnTheSameDatabaseIsRefused) {
  if (GetParam() != "sqlite") GTEST_SKIP() << "PostgreSQL is shared by several servers by design";
  auto first = std::make_unique<ServerProcess>(config_, log_);
  ASSERT_GT(first->port(), 0);
  int code = 0;
  const std::string out = RunCli("serve --config " + config_ + " --port 0", &code, true);
  EXPECT_EQ(code, 1) << out;
  EXPECT_NE(out.find("is already served by another mapdelta-server (pid " +
                     std::to_string(first->pid()) + ","),
            std::string::npos)
      << out;
  EXPECT_EQ(out.find("listening on"), std::string::npos) << out;
  httplib::Client c("127.0.0.1", first->port());
  auto health = c.Get("/health");
  EXPECT_TRUE(health && health->status == 200);
  first->Kill(SIGKILL);
  ServerProcess restarted(config_, log_);
  EXPECT_GT(restarted.port(), 0);
  EXPECT_EQ(restarted.Kill(SIGTERM), 0);
}

// A port another server listens on is an error at start (httplib's default SO_REUSEPORT let
// both bind and split the connections), even for a server of another database.
TEST_P(ServerProcessTest, PortInUseFailsWithAClearError) {
  ServerProcess first(config_, log_);
  ASSERT_GT(first.port(), 0);
  const std::string other = (dir_ / "other.yaml").string();
  std::ofstream(other) << "storage:\n  database: " << (dir_ / "other.sqlite").string() << "\n";
  int code = 0;
  const std::string port = std::to_string(first.port());
  const std::string out = RunCli("serve --config " + other + " --port " + port, &code, true);
  EXPECT_EQ(code, 1) << out;
  EXPECT_NE(out.find("cannot listen on 127.0.0.1:" + port + ": Address already in use"),
            std::string::npos)
      << out;
  EXPECT_EQ(out.find("listening on"), std::string::npos) << out;
  EXPECT_EQ(first.Kill(SIGTERM), 0);
}

TEST_P(ServerProcessTest, SigkillDuringUploadsLosesNoAcknowledgedKeyframe) {
  constexpr int kMaxUploads = 100000;
  auto server = std::make_unique<ServerProcess>(config_, log_);
  int64_t session = 0;
  std::vector<int> acknowledged;
  {
    httplib::Client c("127.0.0.1", server->port());
    session = CreateSession(c);
    // The kill comes once 20 uploads are acknowledged, while the loop keeps uploading (a fixed
    // delay raced the uploads: on an idle machine all of them finished before it).
    std::atomic<int> acknowledged_count{0};
    std::thread killer([&] {
      while (acknowledged_count.load() < 20)
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
      server->Kill(SIGKILL);
    });
    for (int seq = 0; seq < kMaxUploads; ++seq) {
      const int status = Put(c, session, seq, 25.0);
      if (status != 201) break;  // connection refused after the kill
      acknowledged.push_back(seq);
      acknowledged_count.store(static_cast<int>(acknowledged.size()));
    }
    acknowledged_count.store(
        kMaxUploads);  // the killer must not wait for ever if uploads failed early
    killer.join();
  }
  ASSERT_GE(acknowledged.size(), 20u) << "uploads failed before the kill";
  ASSERT_LT(acknowledged.size(), static_cast<size_t>(kMaxUploads))
      << "the kill came after all uploads";
  ServerProcess restarted(config_, log_);
  httplib::Client c("127.0.0.1", restarted.port());
  const Json s = Get(c, "/v1/sessions/" + std::to_string(session), vehicle_);
  // Every acknowledged keyframe is there; at most the one in flight was stored unacknowledged.
  EXPECT_GE(s["keyframe_count"].get<size_t>(), acknowledged.size());
  EXPECT_LE(s["keyframe_count"].get<size_t>(), acknowledged.size() + 1);
  // Retrying acknowledged keyframes is an identical repeat (200), the next is new (201).
  EXPECT_EQ(Put(c, session, acknowledged.back(), 25.0), 200);
  const int next = s["next_seq"].get<int>();
  EXPECT_EQ(Put(c, session, next, 25.0), 201);
  EXPECT_EQ(restarted.Kill(SIGTERM), 0);
}

TEST_P(ServerProcessTest, SigkillDuringCommitResumesToTheSameResult) {
  constexpr int kKeyframes = 51;
  // Reference: an uninterrupted commit of the same session in a first database.
  auto tiles_of = [&](httplib::Client& c) {
    std::map<std::string, std::pair<int, int>> out;
    const Json listing =
        Get(c, "/v1/changes/tiles?bbox=-30,-10,70,40&page_size=100", Token("reader"));
    for (const Json& t : listing["tiles"]) {
      out[t["tile"]] = {t["new_count"].get<int>(), t["removed_count"].get<int>()};
    }
    return out;
  };
  auto upload_and_commit = [&](httplib::Client& c) {
    ImportPrior(c);
    const int64_t session = CreateSession(c);
    for (int seq = 0; seq < kKeyframes; ++seq) EXPECT_EQ(Put(c, session, seq, 25.0), 201);
    auto r = c.Post("/v1/sessions/" + std::to_string(session) + "/commit", H(vehicle_));
    EXPECT_TRUE(r && r->status == 202);
    return Json::parse(r->body)["job_id"].get<int64_t>();
  };
  std::map<std::string, std::pair<int, int>> reference;
  {
    ServerProcess server(config_, log_);
    httplib::Client c("127.0.0.1", server.port());
    const int64_t job = upload_and_commit(c);
    ASSERT_EQ(WaitJob(c, job)["state"], "succeeded");
    reference = tiles_of(c);
    server.Kill(SIGTERM);
  }
  ASSERT_FALSE(reference.empty()) << "no changed tiles in the reference run";
  NewDatabase();

  // Same again, killed while the commit job runs.
  double progress_at_kill = -1;
  int64_t job = 0;
  {
    ServerProcess server(config_, log_);
    httplib::Client c("127.0.0.1", server.port());
    job = upload_and_commit(c);
    for (int i = 0; i < 2000; ++i) {
      const Json j = Get(c, "/v1/admin/jobs/" + std::to_string(job), admin_);
      if (j["state"] == "running" && j["progress"].get<double>() >= 0.3) {
        progress_at_kill = j["progress"];
        break;
      }
      if (j["state"] == "succeeded") break;
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    server.Kill(SIGKILL);
  }
  EXPECT_GE(progress_at_kill, 0.3) << "the commit finished before it could be killed";
  ServerProcess restarted(config_, log_);
  httplib::Client c("127.0.0.1", restarted.port());
  const Json done = WaitJob(c, job);
  ASSERT_EQ(done["state"], "succeeded") << done.dump();
  EXPECT_EQ(tiles_of(c), reference);
  EXPECT_EQ(restarted.Kill(SIGTERM), 0);
}

INSTANTIATE_TEST_SUITE_P(Backends, ServerProcessTest, ::testing::ValuesIn(kServerBackends),
                         BackendName());

}  // namespace
}  // namespace mapdelta::testing
