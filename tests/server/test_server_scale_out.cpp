// Several mapdelta-server processes on one PostgreSQL (a throw-away server of the test) give
// the one-process SQLite result:
//  - the tiny simulator data (tests/data/client_sim: 5 keyframes of S1_01 with ground-truth
//    depth and poses, the outdated prior around them) uploaded as three sessions through two
//    API processes, committed at once and run by two workers: the same changed tiles, counts,
//    points, confidences and observed octrees, byte for byte, as one SQLite process;
//  - a worker SIGKILLed during a commit: another worker takes the job over once its lease ran
//    out and ends with the uninterrupted result; keyframes of another session uploaded while
//    the process dies are all there if they were acknowledged.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <thread>

#include "changed_scene.hpp"
#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/euroc.hpp"
#include "server_backends.hpp"
#include "server_process.hpp"
#include "support/temp_dir.hpp"

#include <httplib.h>  // last: its <resolv.h> defines macros that break Eigen

namespace mapdelta::testing {
namespace {

using Json = nlohmann::json;
namespace fs = std::filesystem;

const std::string kSimDir = std::string(MAPDELTA_TEST_DATA_DIR) + "/client_sim/";

struct Upload {
  Json meta;
  std::string png;
};

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), {});
}

// The five simulated keyframes: ground-truth depth PNGs (16-bit mm) and T_map_cam.
std::vector<Upload> SimKeyframes(Json* camera) {
  const EurocSequence seq = ReadEurocSequence(kSimDir + "S1_01_5kf");
  const PinholeCamera& k = seq.cam0.intrinsics;
  *camera = Json{{"width", k.width}, {"height", k.height}, {"fx", k.fx},
                 {"fy", k.fy},       {"cx", k.cx},         {"cy", k.cy}};
  std::vector<Upload> out;
  for (const EurocImage& d : seq.depth0_images) {
    SE3 T_map_body;
    EXPECT_TRUE(InterpolateAt(seq.groundtruth, d.t_ns, &T_map_body));
    out.push_back({MetaJson(d.t_ns, T_map_body * seq.cam0.T_body_cam), ReadFile(d.path)});
  }
  return out;
}

// One database (backend + config file + tokens) and the processes serving it.
class Deployment {
 public:
  Deployment(const std::string& backend, const fs::path& dir) : dir_(dir) {
    fs::create_directories(dir_);
    server::ServerConfig db;
    UseFreshDatabase(backend, dir_, &db);
    config_ = (dir_ / "server.yaml").string();
    // lease_s 2: a killed worker's job is taken over within seconds.
    std::ofstream(config_) << "storage:\n  backend: " << db.storage.backend << "\n  database: \""
                           << db.storage.database << "\"\n  postgres_url: \""
                           << db.storage.postgres_url
                           << "\"\n  tile_size_m: 20\njobs:\n  lease_s: 2\n"
                           << "log:\n  level: info\n  format: json\n";
    log_ = (dir_ / "server.log").string();
    admin_ = Token("admin");
    vehicle_ = Token("vehicle");
    reader_ = Token("reader");
  }
  ~Deployment() {
    if (::testing::Test::HasFailure()) std::system(("tail -n 40 " + log_ + " >&2").c_str());
  }

  std::unique_ptr<ServerProcess> Start(const std::vector<std::string>& extra = {}) {
    return std::make_unique<ServerProcess>(config_, log_, extra);
  }

  httplib::Headers H(const std::string& token) const { return {{"Authorization", token}}; }
  const std::string& admin() const { return admin_; }
  const std::string& vehicle() const { return vehicle_; }
  const std::string& reader() const { return reader_; }

  void ImportPrior(httplib::Client& c, const std::string& pcd) {
    auto r =
        c.Post("/v1/admin/prior?format=pcd", H(admin_), ReadFile(pcd), "application/octet-stream");
    ASSERT_TRUE(r && r->status == 201) << (r ? r->body : "no response");
  }

  int64_t CreateSession(httplib::Client& c, const Json& camera) {
    auto r = c.Post("/v1/sessions", H(vehicle_),
                    Json{{"vehicle_id", "car"}, {"camera", camera}}.dump(), "application/json");
    EXPECT_TRUE(r && r->status == 201) << (r ? r->body : "no response");
    return r && r->status == 201 ? Json::parse(r->body)["session_id"].get<int64_t>() : -1;
  }

  // HTTP status of a keyframe upload (0 = no response).
  int Put(httplib::Client& c, int64_t session, int64_t seq, const Upload& u) {
    const httplib::MultipartFormDataItems items = {{"meta", u.meta.dump(), "", "application/json"},
                                                   {"depth", u.png, "d.png", "image/png"}};
    auto r = c.Put("/v1/sessions/" + std::to_string(session) + "/keyframes/" + std::to_string(seq),
                   H(vehicle_), items);
    return r ? r->status : 0;
  }

  int64_t Commit(httplib::Client& c, int64_t session) {
    auto r = c.Post("/v1/sessions/" + std::to_string(session) + "/commit", H(vehicle_));
    EXPECT_TRUE(r && r->status == 202) << (r ? r->body : "no response");
    return r && r->status == 202 ? Json::parse(r->body)["job_id"].get<int64_t>() : -1;
  }

  Json Get(httplib::Client& c, const std::string& path) {
    auto r = c.Get(path, H(admin_));
    EXPECT_TRUE(r && r->status == 200) << path << ": " << (r ? r->body : "no response");
    return r && r->status == 200 ? Json::parse(r->body) : Json();
  }

  Json WaitJob(httplib::Client& c, int64_t job) {
    for (int i = 0; i < 1200; ++i) {
      const Json j = Get(c, "/v1/admin/jobs/" + std::to_string(job));
      if (j.value("state", "") != "queued" && j.value("state", "") != "running") return j;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    ADD_FAILURE() << "job " << job << " did not finish";
    return Json();
  }

  // Everything a reader can see of the changes: the listing (counts, confidence), every
  // tile's change points (positions, confidence, evidence) and observed octree; without the
  // times of writing.
  std::map<std::string, std::string> Snapshot(httplib::Client& c) {
    std::map<std::string, std::string> out;
    Json listing = Get(c, "/v1/changes/tiles?bbox=-1000,-1000,1000,1000&page_size=1000");
    for (Json& t : listing["tiles"]) t.erase("updated_at");
    out["listing"] = listing.dump();
    for (const Json& t : listing["tiles"]) {
      const std::string tile = t["tile"];
      Json changes = Get(c, "/v1/changes/tiles/" + tile + "?format=json");
      changes.erase("updated_at");
      out["changes " + tile] = changes.dump();
      auto bt = c.Get("/v1/observed/tiles/" + tile + ".bt", H(reader_));
      EXPECT_TRUE(bt && bt->status == 200);
      out["observed " + tile] = bt ? bt->body : "";
    }
    return out;
  }

 private:
  std::string Token(const std::string& role) {
    int code = 0;
    const std::string out =
        RunCli("token create --config " + config_ + " --role " + role + " --name t-" + role, &code);
    EXPECT_EQ(code, 0) << out;
    const auto at = out.find("token: ");
    return at == std::string::npos ? ""
                                   : "Bearer " + out.substr(at + 7, out.find('\n', at) - at - 7);
  }

  fs::path dir_;
  std::string config_, log_, admin_, vehicle_, reader_;
};

// Keyframes of each session (indices into the five simulated frames): different sessions
// see different parts, so points differ in support and confidence.
const std::vector<std::vector<int>> kSessions = {{0, 1, 2, 3, 4}, {0, 2, 4}, {1, 3}};

// Uploads every session, alternating keyframes and commits over the clients, then commits
// them all at once (several workers run them side by side) and waits for the jobs.
void UploadAndCommitAll(Deployment& d, const std::vector<httplib::Client*>& api) {
  Json camera;
  const std::vector<Upload> frames = SimKeyframes(&camera);
  ASSERT_EQ(frames.size(), 5u);
  d.ImportPrior(*api[0], kSimDir + "prior_original_crop.pcd");
  std::vector<int64_t> sessions;
  size_t turn = 0;
  for (const auto& keyframes : kSessions) {
    const int64_t s = d.CreateSession(*api[0], camera);  // in order: the same ids everywhere
    for (size_t seq = 0; seq < keyframes.size(); ++seq) {
      ASSERT_EQ(
          d.Put(*api[turn++ % api.size()], s, static_cast<int64_t>(seq), frames[keyframes[seq]]),
          201);
    }
    sessions.push_back(s);
  }
  std::vector<int64_t> jobs;
  for (int64_t s : sessions) jobs.push_back(d.Commit(*api[turn++ % api.size()], s));
  for (int64_t job : jobs) ASSERT_EQ(d.WaitJob(*api[0], job)["state"], "succeeded");
}

class ScaleOutTest : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = FreshTempDir("mds_scale_out"); }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(ScaleOutTest, ThreeProcessesOnPostgresGiveTheOneProcessSqliteResult) {
  std::map<std::string, std::string> reference;
  {
    Deployment sqlite("sqlite", dir_ / "sqlite");
    auto server = sqlite.Start();
    httplib::Client c("127.0.0.1", server->port());
    UploadAndCommitAll(sqlite, {&c});
    reference = sqlite.Snapshot(c);
    EXPECT_EQ(server->Kill(SIGTERM), 0);
  }
  ASSERT_GT(reference.size(), 3u) << "no changed tiles in the reference run";

  Deployment postgres("postgres", dir_ / "postgres");
  auto both = postgres.Start();                     // API and worker
  auto api = postgres.Start({"--api-only"});        // API only
  auto worker = postgres.Start({"--worker-only"});  // worker only
  httplib::Client a("127.0.0.1", both->port()), b("127.0.0.1", api->port());
  UploadAndCommitAll(postgres, {&a, &b});
  EXPECT_EQ(postgres.Snapshot(b), reference);
  for (auto* p : {both.get(), api.get(), worker.get()}) EXPECT_EQ(p->Kill(SIGTERM), 0);
}

// A drive of the box scene (tests/server/changed_scene.hpp): long enough a commit to be
// killed in the middle.
constexpr int kBoxKeyframes = 51;
Upload BoxKeyframe(int seq, double y_cam) {
  const SE3 T = CameraLookingMinusY(-5 + seq * 1.0, y_cam, kCameraHeight, kPitch);
  return {MetaJson(1000000000LL * (seq + 1), T),
          PngString(ChangedScene().Render(TestCamera(), T, kMaxDepth))};
}
const Json kBoxCamera{{"width", 160}, {"height", 90}, {"fx", 80},
                      {"fy", 80},     {"cx", 80},     {"cy", 45}};

void ImportBoxPrior(Deployment& d, httplib::Client& c, const fs::path& dir) {
  const std::string file = (dir / "prior.pcd").string();
  WriteCloud(file, PriorScene().Sample(0.4));
  d.ImportPrior(c, file);
}

int64_t UploadBoxSession(Deployment& d, httplib::Client& c) {
  const int64_t s = d.CreateSession(c, kBoxCamera);
  for (int seq = 0; seq < kBoxKeyframes; ++seq)
    EXPECT_EQ(d.Put(c, s, seq, BoxKeyframe(seq, 25.0)), 201);
  return s;
}

TEST_F(ScaleOutTest,
       AKilledWorkersCommitIsTakenOverWithTheSameResultAndNoAcknowledgedKeyframeLost) {
  std::map<std::string, std::string> reference;
  {
    Deployment sqlite("sqlite", dir_ / "sqlite");
    auto server = sqlite.Start();
    httplib::Client c("127.0.0.1", server->port());
    ImportBoxPrior(sqlite, c, dir_);
    const int64_t job = sqlite.Commit(c, UploadBoxSession(sqlite, c));
    ASSERT_EQ(sqlite.WaitJob(c, job)["state"], "succeeded");
    reference = sqlite.Snapshot(c);
    EXPECT_EQ(server->Kill(SIGTERM), 0);
  }
  ASSERT_GT(reference.size(), 3u);

  Deployment d("postgres", dir_ / "postgres");
  auto doomed = d.Start();  // API + the only worker at first
  auto api = d.Start({"--api-only"});
  httplib::Client to_doomed("127.0.0.1", doomed->port()), to_api("127.0.0.1", api->port());
  ImportBoxPrior(d, to_api, dir_);
  const int64_t job = d.Commit(to_api, UploadBoxSession(d, to_api));

  // A second vehicle uploads through both API processes while the worker process dies.
  const int64_t other = d.CreateSession(to_api, kBoxCamera);
  std::atomic<bool> stop{false};
  std::vector<int> acknowledged;
  std::thread uploader([&] {
    httplib::Client via_doomed("127.0.0.1", doomed->port()), via_api("127.0.0.1", api->port());
    for (int seq = 0; seq < kBoxKeyframes && !stop; ++seq) {
      const Upload u = BoxKeyframe(seq, 20.0);
      int status = d.Put(seq % 2 ? via_doomed : via_api, other, seq, u);
      if (status == 0) status = d.Put(via_api, other, seq, u);  // its process died: retry
      if (status != 201 && status != 200) break;
      acknowledged.push_back(seq);
    }
  });
  double progress_at_kill = -1;
  for (int i = 0; i < 4000 && progress_at_kill < 0; ++i) {
    const Json j = d.Get(to_api, "/v1/admin/jobs/" + std::to_string(job));
    if (j["state"] == "running" && j["progress"].get<double>() >= 0.3)
      progress_at_kill = j["progress"];
    if (j["state"] == "succeeded") break;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  doomed->Kill(SIGKILL);
  EXPECT_GE(progress_at_kill, 0.3) << "the commit finished before it could be killed";
  auto rescuer = d.Start({"--worker-only"});  // takes the job once the dead worker's lease ran out
  const Json done = d.WaitJob(to_api, job);
  stop = true;
  uploader.join();
  ASSERT_EQ(done["state"], "succeeded") << done.dump();
  EXPECT_GE(done["attempts"].get<int>(), 2) << done.dump();
  EXPECT_EQ(d.Snapshot(to_api), reference);

  ASSERT_GE(acknowledged.size(), 2u);
  const Json s = d.Get(to_api, "/v1/sessions/" + std::to_string(other));
  EXPECT_GE(s["keyframe_count"].get<size_t>(), acknowledged.size());
  for (int seq : acknowledged)
    EXPECT_EQ(d.Put(to_api, other, seq, BoxKeyframe(seq, 20.0)), 200) << seq;
  for (auto* p : {api.get(), rescuer.get()}) EXPECT_EQ(p->Kill(SIGTERM), 0);
}

}  // namespace
}  // namespace mapdelta::testing
