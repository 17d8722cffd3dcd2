// Several mapdelta-server processes on one PostgreSQL (a throw-away server of the test) give
// the one-process SQLite result:
//  - the tiny simulator data (tests/data/client_sim: 5 keyframes of S1_01 with ground-truth
//    depth and poses, the outdated prior around them) uploaded as three sessions through two
//    API processes, committed at once and run by two workers: the same changed tiles, counts,
//    points, confidences and observed octrees, byte for byte, as one SQLite process;
//  - per-tile claims within one commit: two workers classify tiles of the same commit (read
//    from the stored ownership of its tile work items), then the job's worker is SIGKILLed
//    holding a tile claim; the other worker takes the claim and the job over once their leases
//    ran out and ends with the uninterrupted result; keyframes of another session uploaded
//    while the process dies are all there if they were acknowledged;
//  - one process's cached observed octree is stale as soon as another process commits.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <stop_token>
#include <thread>

#include "changed_scene.hpp"
#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/euroc.hpp"
#include "mapdelta/server/storage.hpp"
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
  // extra_yaml: more top-level config sections (e.g. "pipeline:\n  threads: 1\n").
  Deployment(const std::string& backend, const fs::path& dir, const std::string& extra_yaml = "",
             double tile_size_m = 20)
      : dir_(dir) {
    fs::create_directories(dir_);
    server::ServerConfig& db = db_;
    UseFreshDatabase(backend, dir_, &db);
    config_ = (dir_ / "server.yaml").string();
    // lease_s 2: a killed worker's job is taken over within seconds.
    std::ofstream(config_) << "storage:\n  backend: " << db.storage.backend << "\n  database: \""
                           << db.storage.database << "\"\n  postgres_url: \""
                           << db.storage.postgres_url << "\"\n  tile_size_m: " << tile_size_m
                           << "\njobs:\n  lease_s: 2\n"
                           << "log:\n  level: info\n  format: json\n"
                           << extra_yaml;
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

  // The database as the servers see it (PostgreSQL deployments only).
  std::unique_ptr<server::Storage> OpenStorage() const {
    return server::OpenPostgresStorage(db_.storage.postgres_url, 2);
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
  server::ServerConfig db_;
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
    Deployment sqlite("sqlite", dir_ / "sqlite", "", 10);
    auto server = sqlite.Start();
    httplib::Client c("127.0.0.1", server->port());
    UploadAndCommitAll(sqlite, {&c});
    reference = sqlite.Snapshot(c);
    EXPECT_EQ(server->Kill(SIGTERM), 0);
  }
  ASSERT_GT(reference.size(), 3u) << "no changed tiles in the reference run";

  Deployment postgres("postgres", dir_ / "postgres", "", 10);
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

int64_t UploadBoxSession(Deployment& d, httplib::Client& c, double y_cam = 25.0) {
  const int64_t s = d.CreateSession(c, kBoxCamera);
  for (int seq = 0; seq < kBoxKeyframes; ++seq)
    EXPECT_EQ(d.Put(c, s, seq, BoxKeyframe(seq, y_cam)), 201);
  return s;
}

// The worker of a commit, stopped (SIGSTOP) at a moment it has classified a tile of the commit,
// holds the claim of another and leaves at least one unclaimed. Returns its worker id, or ""
// if the commit got past its tiles before such a moment was seen (the worker then runs on).
std::string StopWhileHoldingTileClaims(server::Storage& db, int64_t job, pid_t worker) {
  // Until the commit reaches its tiles (steps 1-4), it runs at full speed.
  for (int i = 0; i < 6000 && db.jobs().ListTileWork(job).empty(); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  for (int i = 0; i < 20000; ++i) {
    ::kill(worker, SIGSTOP);
    const auto record = db.jobs().Get(job);
    if (!record || record->state != server::JobState::kRunning) break;
    const std::string owner = record->lease_owner.value_or("");
    int done = 0, held = 0, unclaimed = 0;
    for (const server::TileWorkItem& w : db.jobs().ListTileWork(job)) {
      done += w.done_by == owner;
      held += !w.done_by && w.lease_owner == owner;
      unclaimed += !w.done_by && !w.lease_owner;
    }
    if (done > 0 && held > 0 && unclaimed > 0) return owner;
    ::kill(worker, SIGCONT);
    std::this_thread::sleep_for(std::chrono::microseconds(500));
  }
  ::kill(worker, SIGCONT);
  return "";
}

// Workers that completed tiles of the job, with how many each.
std::map<std::string, int> TilesDoneBy(server::Storage& db, int64_t job) {
  std::map<std::string, int> out;
  for (const server::TileWorkItem& w : db.jobs().ListTileWork(job)) {
    if (w.done_by) out[*w.done_by] += 1;
  }
  return out;
}

TEST_F(ScaleOutTest, TwoWorkersClassifyOneCommitsTilesAndAKilledWorkersClaimsAreTakenOver) {
  // 10 m tiles and one pipeline thread: many tiles per commit, one claim at a time.
  const std::string config = "pipeline:\n  threads: 1\n";
  std::map<std::string, std::string> reference;
  {
    Deployment sqlite("sqlite", dir_ / "sqlite", config, 10);
    auto server = sqlite.Start();
    httplib::Client c("127.0.0.1", server->port());
    ImportBoxPrior(sqlite, c, dir_);
    const int64_t job = sqlite.Commit(c, UploadBoxSession(sqlite, c));
    ASSERT_EQ(sqlite.WaitJob(c, job)["state"], "succeeded");
    reference = sqlite.Snapshot(c);
    EXPECT_EQ(server->Kill(SIGTERM), 0);
  }
  ASSERT_GT(reference.size(), 3u);

  Deployment d("postgres", dir_ / "postgres", config, 10);
  auto doomed = d.Start();  // API + the only worker at first: it takes the commit
  auto api = d.Start({"--api-only"});
  httplib::Client to_doomed("127.0.0.1", doomed->port()), to_api("127.0.0.1", api->port());
  ImportBoxPrior(d, to_api, dir_);
  const int64_t job = d.Commit(to_api, UploadBoxSession(d, to_api));
  for (int i = 0;
       i < 2000 && d.Get(to_api, "/v1/admin/jobs/" + std::to_string(job))["state"] == "queued";
       ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  const std::unique_ptr<server::Storage> db = d.OpenStorage();

  // A second vehicle uploads through both API processes while the worker process dies.
  const int64_t other = d.CreateSession(to_api, kBoxCamera);
  std::vector<int> acknowledged;
  // A jthread: a failed assertion below stops and joins it instead of std::terminate.
  std::jthread uploader([&](const std::stop_token& stop) {
    httplib::Client via_doomed("127.0.0.1", doomed->port()), via_api("127.0.0.1", api->port());
    for (int seq = 0; seq < kBoxKeyframes && !stop.stop_requested(); ++seq) {
      const Upload u = BoxKeyframe(seq, 20.0);
      int status = d.Put(seq % 2 ? via_doomed : via_api, other, seq, u);
      if (status == 0) status = d.Put(via_api, other, seq, u);  // its process died: retry
      if (status != 201 && status != 200) break;
      acknowledged.push_back(seq);
    }
  });

  // The doomed worker alone until it is caught holding claims with tiles left: with a second
  // worker already running, a loaded machine could finish every tile between two looks.
  const std::string doomed_id = StopWhileHoldingTileClaims(*db, job, doomed->pid());
  ASSERT_FALSE(doomed_id.empty()) << "the commit's tiles were never seen half classified";
  auto helper = d.Start({"--worker-only"});  // the job is taken: it helps with the tiles
  // While the job's worker is stopped, the helper classifies the unclaimed tiles.
  for (int i = 0; i < 600 && TilesDoneBy(*db, job).size() < 2; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  std::vector<std::string> held;  // tiles the doomed worker holds when it dies
  for (const server::TileWorkItem& w : db->jobs().ListTileWork(job)) {
    if (!w.done_by && w.lease_owner == doomed_id) held.push_back(w.tile.ToString());
  }
  EXPECT_FALSE(held.empty());
  doomed->Kill(SIGKILL);

  const Json done = d.WaitJob(to_api, job);  // the helper takes the job after its lease
  uploader.request_stop();
  uploader.join();
  ASSERT_EQ(done["state"], "succeeded") << done.dump();
  EXPECT_GE(done["attempts"].get<int>(), 2) << done.dump();
  EXPECT_EQ(d.Snapshot(to_api), reference);

  const std::map<std::string, int> by = TilesDoneBy(*db, job);
  ASSERT_EQ(by.size(), 2u) << "tiles of the one commit were not classified by both workers";
  EXPECT_GE(by.at(doomed_id), 1);
  for (const server::TileWorkItem& w : db->jobs().ListTileWork(job)) {
    EXPECT_TRUE(w.published) << w.tile.ToString();
    if (std::find(held.begin(), held.end(), w.tile.ToString()) != held.end()) {
      EXPECT_NE(w.done_by, doomed_id) << w.tile.ToString() << ": the dead worker's claim";
      EXPECT_GE(w.claims, 2) << w.tile.ToString();
    }
  }

  ASSERT_GE(acknowledged.size(), 2u);
  const Json s = d.Get(to_api, "/v1/sessions/" + std::to_string(other));
  EXPECT_GE(s["keyframe_count"].get<size_t>(), acknowledged.size());
  for (int seq : acknowledged)
    EXPECT_EQ(d.Put(to_api, other, seq, BoxKeyframe(seq, 20.0)), 200) << seq;
  for (auto* p : {api.get(), helper.get()}) EXPECT_EQ(p->Kill(SIGTERM), 0);
}

// The served observed octree is cached per process (http.observed_cache_bytes) and keyed on
// the stored tile state: a commit run by another process is seen by the very next request,
// and a reader holding the current ETag is answered 304.
TEST_F(ScaleOutTest, ACachedObservedOctreeIsStaleOnceAnotherProcessCommits) {
  Deployment d("postgres", dir_ / "postgres", "", 10);
  auto writer = d.Start();                // API + the worker that runs the commits
  auto reader = d.Start({"--api-only"});  // serves (and caches) the octrees
  httplib::Client w("127.0.0.1", writer->port()), r("127.0.0.1", reader->port());
  ImportBoxPrior(d, w, dir_);
  ASSERT_EQ(d.WaitJob(w, d.Commit(w, UploadBoxSession(d, w)))["state"], "succeeded");
  const Json listing = d.Get(r, "/v1/changes/tiles?bbox=-1000,-1000,1000,1000&page_size=1000");
  ASSERT_FALSE(listing["tiles"].empty());
  const std::string path =
      "/v1/observed/tiles/" + listing["tiles"][0]["tile"].get<std::string>() + ".bt";

  auto first = r.Get(path, d.H(d.reader()));
  ASSERT_TRUE(first && first->status == 200);
  const std::string etag = first->get_header_value("ETag");
  ASSERT_FALSE(etag.empty());
  auto again = r.Get(path, d.H(d.reader()));
  ASSERT_TRUE(again && again->status == 200);
  EXPECT_EQ(again->body, first->body);
  EXPECT_EQ(again->get_header_value("ETag"), etag);
  httplib::Headers conditional = d.H(d.reader());
  conditional.emplace("If-None-Match", etag);
  auto unchanged = r.Get(path, conditional);
  ASSERT_TRUE(unchanged && unchanged->status == 304);
  EXPECT_TRUE(unchanged->body.empty());

  // A second drive, committed by the other process.
  ASSERT_EQ(d.WaitJob(w, d.Commit(w, UploadBoxSession(d, w, 20.0)))["state"], "succeeded");
  auto after = r.Get(path, conditional);  // the old ETag: the tile changed, so 200
  ASSERT_TRUE(after && after->status == 200);
  EXPECT_NE(after->body, first->body);
  EXPECT_NE(after->get_header_value("ETag"), etag);
  auto from_writer = w.Get(path, d.H(d.reader()));
  ASSERT_TRUE(from_writer && from_writer->status == 200);
  EXPECT_EQ(after->body, from_writer->body);
  EXPECT_EQ(after->get_header_value("ETag"), from_writer->get_header_value("ETag"));

  auto metrics = r.Get("/metrics");
  ASSERT_TRUE(metrics && metrics->status == 200);
  EXPECT_NE(metrics->body.find("mapdelta_observed_cache_requests_total{result=\"hit\"} 1\n"),
            std::string::npos)
      << metrics->body;
  EXPECT_NE(metrics->body.find("mapdelta_observed_cache_requests_total{result=\"miss\"} 2\n"),
            std::string::npos);
  for (auto* p : {writer.get(), reader.get()}) EXPECT_EQ(p->Kill(SIGTERM), 0);
}

}  // namespace
}  // namespace mapdelta::testing
