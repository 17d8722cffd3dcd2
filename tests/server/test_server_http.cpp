// Integration test: the real HTTP server (in-process, loopback port) driven by a real HTTP
// client. A prior of ground + two boxes is imported; two vehicles upload sessions over a
// changed scene (box A removed, box C added; depth rendered analytically); the changes must
// lie on box A (removed) and box C (new); a refresh job must produce prior version 2 with
// box C and without box A, while version 1 stays readable. Every test runs on both storage
// backends (SQLite and a throw-away PostgreSQL).
#include <gtest/gtest.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <thread>

#include "auth.hpp"
#include "box_scene.hpp"
#include "changed_scene.hpp"
#include "http_test_server.hpp"
#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/server/http_server.hpp"
#include "mapdelta/server/map_service.hpp"

#include <httplib.h>  // last: its <resolv.h> defines macros that break Eigen

namespace mapdelta::server {
namespace {

using namespace mapdelta::testing;  // NOLINT: the shared test scene

class ServerHttpTest : public HttpServerTest, public ::testing::WithParamInterface<std::string> {
 protected:
  std::string Backend() const override { return GetParam(); }

  int64_t CreateSession(const std::string& vehicle) {
    const Json camera{{"width", 160}, {"height", 90}, {"fx", 80},
                      {"fy", 80},     {"cx", 80},     {"cy", 45}};
    auto [status, body] = Call(client_->Post(
        "/v1/sessions", H(vehicle_), Json{{"vehicle_id", vehicle}, {"camera", camera}}.dump(),
        "application/json"));
    EXPECT_EQ(status, 201);
    return body.value("session_id", int64_t{-1});
  }

  httplib::Result PutKeyframe(int64_t session, int64_t seq, const Json& meta,
                              const std::string& png, const std::string& auth = "") {
    httplib::MultipartFormDataItems items = {{"meta", meta.dump(), "", "application/json"},
                                             {"depth", png, "depth.png", "image/png"}};
    return client_->Put(
        "/v1/sessions/" + std::to_string(session) + "/keyframes/" + std::to_string(seq),
        H(auth.empty() ? vehicle_ : auth), items);
  }

  // Drives along x at y_cam, kCameraHeight high, looking at the boxes; uploads every keyframe.
  void UploadDrive(int64_t session, double y_cam) {
    const BoxScene scene = ChangedScene();
    int seq = 0;
    for (double x = -5; x <= 45; x += 2.5, ++seq) {
      const SE3 T = CameraLookingMinusY(x, y_cam, kCameraHeight, kPitch);
      const DepthImage depth = scene.Render(TestCamera(), T, kMaxDepth);
      auto [status, body] =
          Call(PutKeyframe(session, seq, MetaJson(1000000000LL * (seq + 1), T), PngString(depth)));
      ASSERT_EQ(status, 201) << body.dump();
    }
  }

  Json WaitJob(int64_t job) {
    for (int i = 0; i < 1200; ++i) {
      auto [status, body] = Call(client_->Get("/v1/admin/jobs/" + std::to_string(job), H(admin_)));
      EXPECT_EQ(status, 200);
      const std::string state = body.value("state", "");
      if (state != "queued" && state != "running") return body;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    ADD_FAILURE() << "job " << job << " did not finish";
    return Json();
  }

  PointCloud FetchCloud(const std::string& path) {
    auto r = client_->Get(path, H(reader_));
    EXPECT_TRUE(r && r->status == 200) << (r ? r->body : "no response");
    const std::string file = (dir_ / "fetched.pcd").string();
    std::ofstream(file, std::ios::binary) << r->body;
    return ReadCloud(file);
  }
};

TEST_P(ServerHttpTest, AuthRolesAnd401Vs403) {
  EXPECT_EQ(Call(client_->Get("/health")).first, 200);
  EXPECT_EQ(Call(client_->Get("/v1/changes/tiles?bbox=0,0,1,1")).first, 401);
  EXPECT_EQ(Call(client_->Get("/v1/changes/tiles?bbox=0,0,1,1", H("Bearer mdt_nope"))).first, 401);
  EXPECT_EQ(Call(client_->Get("/v1/changes/tiles?bbox=0,0,1,1", H("Basic abc"))).first, 401);
  EXPECT_EQ(Call(client_->Get("/v1/changes/tiles?bbox=0,0,1,1", H(vehicle_))).first, 403);
  EXPECT_EQ(Call(client_->Get("/v1/changes/tiles?bbox=0,0,1,1", H(reader_))).first, 200);
  EXPECT_EQ(Call(client_->Get("/v1/admin/jobs", H(reader_))).first, 403);
  EXPECT_EQ(Call(client_->Post("/v1/sessions", H(reader_), "{}", "application/json")).first, 403);
  // Revoked tokens are rejected from then on.
  const CreatedToken t = CreateToken(service_->storage(), "tmp", Role::kReader, NowMs());
  EXPECT_EQ(Call(client_->Get("/v1/changes/tiles?bbox=0,0,1,1", H("Bearer " + t.secret))).first,
            200);
  ASSERT_TRUE(service_->storage().tokens().Revoke(t.record.id, NowMs()));
  EXPECT_EQ(Call(client_->Get("/v1/changes/tiles?bbox=0,0,1,1", H("Bearer " + t.secret))).first,
            401);
  EXPECT_EQ(Call(client_->Get("/nope", H(admin_))).first, 404);
  // The OpenAPI document is served and names every route the server has.
  auto doc = client_->Get("/v1/openapi.yaml");
  ASSERT_TRUE(doc && doc->status == 200);
  for (const char* route : {"/v1/map:", "/v1/sessions/{session_id}/keyframes/{seq}:",
                            "/v1/changes/tiles/{tile}:", "/v1/admin/jobs/{job_id}/cancel:"}) {
    EXPECT_NE(doc->body.find(route), std::string::npos) << route;
  }
  // Request ids: a client's own id is echoed.
  auto echoed = client_->Get("/health", {{"X-Request-Id", "trace-42"}});
  ASSERT_TRUE(echoed);
  EXPECT_EQ(echoed->get_header_value("X-Request-Id"), "trace-42");
}

TEST_P(ServerHttpTest, UploadValidationStoresNothingHalfWay) {
  const int64_t s = CreateSession("car-1");
  const SE3 T = CameraLookingMinusY(0, 25, kCameraHeight, kPitch);
  const std::string png = PngString(ChangedScene().Render(TestCamera(), T, kMaxDepth));
  auto code = [&](const httplib::Result& r) {
    return Call(r).second["error"].value("code", std::string());
  };
  // Malformed JSON and bad fields in session creation.
  EXPECT_EQ(
      code(client_->Post("/v1/sessions", H(vehicle_), "{\"vehicle_id\":", "application/json")),
      "invalid_json");
  EXPECT_EQ(code(client_->Post("/v1/sessions", H(vehicle_),
                               R"({"vehicle_id":"x","camera":{"width":-1}})", "application/json")),
            "invalid_argument");
  EXPECT_EQ(
      code(client_->Post("/v1/sessions", H(vehicle_), std::string(70000, ' '), "application/json")),
      "payload_too_large");
  // A keyframe-sized body is fine for PUT but too large for a JSON route.
  EXPECT_EQ(code(client_->Post("/v1/admin/jobs", H(admin_), std::string(200000, ' '),
                               "application/json")),
            "payload_too_large");
  EXPECT_EQ(code(client_->Post("/v1/sessions", H(vehicle_), "{}", "text/plain")),
            "unsupported_media_type");
  // Keyframes: bad PNG, wrong size, NaN-ish pose, non-unit quaternion, unknown session.
  EXPECT_EQ(code(PutKeyframe(s, 0, MetaJson(1, T), "not a png")), "invalid_image");
  DepthImage small(80, 45);
  EXPECT_EQ(code(PutKeyframe(s, 0, MetaJson(1, T), PngString(small))), "image_size_mismatch");
  Json nan_pose = MetaJson(1, T);
  nan_pose["T_map_cam"]["t"][0] = nullptr;  // what JSON encoders emit for NaN
  EXPECT_EQ(code(PutKeyframe(s, 0, nan_pose, png)), "invalid_pose");
  Json bad_q = MetaJson(1, T);
  bad_q["T_map_cam"]["q"] = {1.0, 1.0, 0.0, 0.0};
  EXPECT_EQ(code(PutKeyframe(s, 0, bad_q, png)), "invalid_pose");
  Json bad_cov = MetaJson(1, T);
  bad_cov["covariance"] = Json::array({1, 2, 3});
  EXPECT_EQ(code(PutKeyframe(s, 0, bad_cov, png)), "invalid_pose");
  EXPECT_EQ(code(PutKeyframe(9999, 0, MetaJson(1, T), png)), "not_found");
  EXPECT_EQ(code(PutKeyframe(s, 0, MetaJson(1, T), png, reader_)), "forbidden");
  {
    auto r = client_->Put("/v1/sessions/" + std::to_string(s) + "/keyframes/0", H(vehicle_), "{}",
                          "application/json");
    EXPECT_EQ(code(r), "unsupported_media_type");
  }
  // Nothing stored so far.
  EXPECT_EQ(
      Call(client_->Get("/v1/sessions/" + std::to_string(s), H(vehicle_))).second["keyframe_count"],
      0);
  // Out of order, then the right one, an identical retry (200), a conflicting one (409).
  EXPECT_EQ(code(PutKeyframe(s, 1, MetaJson(1, T), png)), "seq_out_of_order");
  EXPECT_EQ(Call(PutKeyframe(s, 0, MetaJson(1, T), png)).first, 201);
  EXPECT_EQ(Call(PutKeyframe(s, 0, MetaJson(1, T), png)).first, 200);
  EXPECT_EQ(code(PutKeyframe(s, 0, MetaJson(2, T), png)), "keyframe_conflict");
  EXPECT_EQ(code(PutKeyframe(s, 1, MetaJson(1, T), png)), "time_not_increasing");
  EXPECT_EQ(Call(PutKeyframe(s, 1, MetaJson(2, T), png)).first, 201);
  const Json session = Call(client_->Get("/v1/sessions/" + std::to_string(s), H(vehicle_))).second;
  EXPECT_EQ(session["keyframe_count"], 2);
  EXPECT_EQ(session["state"], "open");
  // Commit twice: the second is a conflict. Unknown session: 404.
  EXPECT_EQ(Call(client_->Post("/v1/sessions/" + std::to_string(s) + "/commit", H(vehicle_))).first,
            202);
  EXPECT_EQ(code(client_->Post("/v1/sessions/" + std::to_string(s) + "/commit", H(vehicle_))),
            "session_not_open");
  EXPECT_EQ(code(PutKeyframe(s, 2, MetaJson(3, T), png)), "session_not_open");
  EXPECT_EQ(code(client_->Post("/v1/sessions/424242/commit", H(vehicle_))), "not_found");
  // Bad queries.
  EXPECT_EQ(code(client_->Get("/v1/changes/tiles?bbox=1,2,3", H(reader_))), "invalid_argument");
  EXPECT_EQ(code(client_->Get("/v1/changes/tiles/abc", H(reader_))), "not_found");
  EXPECT_EQ(code(client_->Get("/v1/changes/tiles/1_x2", H(reader_))), "not_found");
  EXPECT_EQ(code(client_->Get("/v1/changes/tiles/1_2?format=pcd", H(reader_))), "invalid_argument");
  EXPECT_EQ(
      code(client_->Post("/v1/admin/jobs", H(admin_), R"({"type":"explode"})", "application/json")),
      "invalid_argument");
  EXPECT_EQ(
      code(client_->Post("/v1/admin/jobs", H(admin_),
                         R"({"type":"reclassify","params":{"th_ch_m":-1}})", "application/json")),
      "invalid_argument");
  // The server still serves.
  EXPECT_EQ(Call(client_->Get("/health")).first, 200);
}

TEST_P(ServerHttpTest, TwoSessionsChangesAndRefresh) {
  // 1. Import the prior (admin endpoint, PCD bytes).
  const PointCloud prior = PriorScene().Sample(0.4);
  const std::string prior_file = (dir_ / "prior.pcd").string();
  WriteCloud(prior_file, prior);
  std::ifstream in(prior_file, std::ios::binary);
  const std::string prior_bytes((std::istreambuf_iterator<char>(in)), {});
  auto [st, imported] = Call(client_->Post("/v1/admin/prior?format=pcd", H(admin_), prior_bytes,
                                           "application/octet-stream"));
  ASSERT_EQ(st, 201) << imported.dump();
  EXPECT_EQ(imported["prior_version"], 1);
  EXPECT_EQ(imported["points"], prior.size());
  EXPECT_EQ(Call(client_->Post("/v1/admin/prior?format=pcd", H(admin_), "garbage",
                               "application/octet-stream"))
                .first,
            400);

  // Prior tiles around a position.
  auto [st2, near] = Call(client_->Get("/v1/prior/tiles?x=17&y=12&radius=2", H(vehicle_)));
  ASSERT_EQ(st2, 200);
  ASSERT_EQ(near["tiles"].size(), 1u);
  EXPECT_EQ(near["tiles"][0]["tile"], "0_0");

  // 2. Two vehicles, slightly different paths, over the changed scene.
  const int64_t s1 = CreateSession("car-1");
  const int64_t s2 = CreateSession("car-2");
  UploadDrive(s1, 25.0);
  UploadDrive(s2, 24.0);
  for (int64_t s : {s1, s2}) {
    auto [status, body] =
        Call(client_->Post("/v1/sessions/" + std::to_string(s) + "/commit", H(vehicle_)));
    ASSERT_EQ(status, 202);
    const Json job = WaitJob(body["job_id"]);
    ASSERT_EQ(job["state"], "succeeded") << job.dump(2);
    // Exact poses: GICP may accept (a tiny correction) or reject (planar scene, slow
    // convergence); either way the poses must stay put.
    const Json& reg = job["result"]["registration"];
    if (reg["status"] == "accepted") {
      EXPECT_LT(reg["correction_m"].get<double>(), 0.2) << reg.dump();
    }
    EXPECT_NE(reg["status"], "skipped") << reg.dump();
  }
  EXPECT_EQ(Call(client_->Get("/v1/sessions/" + std::to_string(s1), H(reader_))).second["state"],
            "committed");

  // 3. Changed tiles, then every change point of every tile against the analytic truth.
  auto [st3, listing] =
      Call(client_->Get("/v1/changes/tiles?bbox=-30,-10,70,40&page_size=2", H(reader_)));
  ASSERT_EQ(st3, 200);
  EXPECT_EQ(listing["prior_version"], 1);
  ASSERT_GE(listing["total"].get<int>(), 2);
  EXPECT_LE(listing["tiles"].size(), 2u);
  const Json all =
      Call(client_->Get("/v1/changes/tiles?bbox=-30,-10,70,40&page_size=100", H(reader_))).second;
  size_t n_new = 0, n_removed = 0, n_new_both = 0;
  std::vector<std::string> tiles;
  for (const Json& t : all["tiles"]) {
    tiles.push_back(t["tile"]);
    const Json c =
        Call(client_->Get("/v1/changes/tiles/" + t["tile"].get<std::string>(), H(reader_))).second;
    for (const Json& p : c["new"]) {
      const Eigen::Vector3d x(p["p"][0], p["p"][1], p["p"][2]);
      // New: box C, or the ground that box A covered (not in the prior, seen now).
      const bool on_c = kBoxC.Distance(x) < 1.0;
      const bool under_a = kBoxA.Distance(x) < 1.0 && x.z() < kGroundZ + 0.5;
      EXPECT_TRUE(on_c || under_a) << "new point off box C and box A's footprint: " << p.dump();
      ++n_new;
      if (p["supported_by"].size() == 2) {
        ++n_new_both;
        EXPECT_NEAR(p["confidence"].get<double>(), 0.75, 1e-6);  // (2+1)/(2+2)
      }
    }
    for (const Json& p : c["removed"]) {
      const Eigen::Vector3d x(p["p"][0], p["p"][1], p["p"][2]);
      EXPECT_LT(kBoxA.Distance(x), 0.01) << "removed point off box A: " << p.dump();
      EXPECT_FALSE(p["observed_by"].empty());
      ++n_removed;
    }
  }
  EXPECT_GT(n_new, 30u);
  EXPECT_GT(n_removed, 30u);
  EXPECT_GT(n_new_both, 10u);
  // Filters: min_support=2 keeps only points both vehicles support; PCD of one kind.
  const Json strict = Call(client_->Get("/v1/changes/tiles/1_0?min_support=2", H(reader_))).second;
  for (const Json& p : strict["new"]) EXPECT_EQ(p["supported_by"].size(), 2u);
  // The listing with min_support counts exactly the points the per-tile query returns.
  const Json strict_list =
      Call(client_->Get("/v1/changes/tiles?bbox=-30,-10,70,40&min_support=2&min_confidence=0.7",
                        H(reader_)))
          .second;
  ASSERT_GE(strict_list["tiles"].size(), 1u);
  EXPECT_EQ(strict_list["total"], strict_list["tiles"].size());
  for (const Json& t : strict_list["tiles"]) {
    const Json c = Call(client_->Get("/v1/changes/tiles/" + t["tile"].get<std::string>() +
                                         "?min_support=2&min_confidence=0.7",
                                     H(reader_)))
                       .second;
    EXPECT_EQ(t["new_count"], c["new"].size());
    EXPECT_EQ(t["removed_count"], c["removed"].size());
    EXPECT_GT(c["new"].size() + c["removed"].size(), 0u);
  }
  const PointCloud removed_pcd = FetchCloud("/v1/changes/tiles/0_0?format=pcd&kind=removed");
  for (const Point& p : removed_pcd) EXPECT_LT(kBoxA.Distance(p.cast<double>()), 0.01);
  // Change clouds carry each point's evidence as fields (binary: 3 + 1 float32, 2 uint32),
  // in the order of the JSON listing.
  auto pcd = client_->Get("/v1/changes/tiles/1_0?format=pcd&kind=new", H(reader_));
  ASSERT_TRUE(pcd && pcd->status == 200);
  EXPECT_NE(pcd->body.find("\nFIELDS x y z confidence observed_by supported_by\n"),
            std::string::npos);
  const Json listed_new = Call(client_->Get("/v1/changes/tiles/1_0", H(reader_))).second["new"];
  const size_t data = pcd->body.find("DATA binary\n") + 12;
  ASSERT_EQ(pcd->body.size() - data, listed_new.size() * 24);
  for (size_t i = 0; i < listed_new.size(); ++i) {
    float confidence = 0;
    uint32_t observed = 0, supported = 0;
    std::memcpy(&confidence, pcd->body.data() + data + 24 * i + 12, 4);
    std::memcpy(&observed, pcd->body.data() + data + 24 * i + 16, 4);
    std::memcpy(&supported, pcd->body.data() + data + 24 * i + 20, 4);
    EXPECT_FLOAT_EQ(confidence, listed_new[i]["confidence"].get<float>());
    EXPECT_EQ(observed, listed_new[i]["observed_by"].size());
    EXPECT_EQ(supported, listed_new[i]["supported_by"].size());
  }
  // The observed octree of a tile is a valid .bt download.
  auto bt = client_->Get("/v1/observed/tiles/0_0.bt", H(reader_));
  ASSERT_TRUE(bt && bt->status == 200);
  EXPECT_EQ(bt->body.rfind("# Octomap OcTree binary file", 0), 0u);
  // Its ETag names the tile's state: asked again with it, the answer is 304 without a body;
  // with another ETag, the same bytes (from the cache).
  const std::string bt_etag = bt->get_header_value("ETag");
  ASSERT_FALSE(bt_etag.empty());
  EXPECT_EQ(bt->get_header_value("Cache-Control"), "no-cache");
  httplib::Headers conditional = H(reader_);
  conditional.emplace("If-None-Match", "\"other\", " + bt_etag);
  auto bt_304 = client_->Get("/v1/observed/tiles/0_0.bt", conditional);
  ASSERT_TRUE(bt_304);
  EXPECT_EQ(bt_304->status, 304);
  EXPECT_TRUE(bt_304->body.empty());
  conditional = H(reader_);
  conditional.emplace("If-None-Match", "\"other\"");
  auto bt_again = client_->Get("/v1/observed/tiles/0_0.bt", conditional);
  ASSERT_TRUE(bt_again && bt_again->status == 200);
  EXPECT_EQ(bt_again->body, bt->body);

  // 4. Refresh everything changed with confidence >= 0.7 into version 2.
  auto [st4, job] = Call(client_->Post(
      "/v1/admin/jobs", H(admin_),
      Json{{"type", "refresh"}, {"bbox", {-30, -10, 70, 40}}, {"min_confidence", 0.7}}.dump(),
      "application/json"));
  ASSERT_EQ(st4, 202) << job.dump();
  const Json done = WaitJob(job["job_id"]);
  ASSERT_EQ(done["state"], "succeeded") << done.dump(2);
  EXPECT_EQ(done["result"]["prior_version"], 2);
  const Json versions = Call(client_->Get("/v1/prior/versions", H(reader_))).second;
  ASSERT_EQ(versions["versions"].size(), 2u);
  EXPECT_EQ(versions["versions"][1]["source"], "refresh");

  // 5. Version 2 has box C's front and lost box A's observed points; version 1 is unchanged.
  // Box points only (above the ground), near the box.
  auto count_near = [](const PointCloud& c, const Box& b, double d) {
    return std::count_if(c.begin(), c.end(), [&](const Point& p) {
      return p.z() > kGroundZ + 0.5 && b.Distance(p.cast<double>()) < d;
    });
  };
  PointCloud v1, v2;
  for (const char* tile : {"0_0", "1_0"}) {
    const PointCloud a =
        FetchCloud(std::string("/v1/prior/tiles/") + tile + "?version=1&format=pcd");
    const PointCloud b =
        FetchCloud(std::string("/v1/prior/tiles/") + tile + "?version=2&format=pcd");
    v1.insert(v1.end(), a.begin(), a.end());
    v2.insert(v2.end(), b.begin(), b.end());
  }
  EXPECT_EQ(count_near(v1, kBoxC, 0.5), 0);
  EXPECT_GT(count_near(v2, kBoxC, 1.0), 10);
  // Box A's faces towards the cameras (front y = 15 and top) were in plain view: the free
  // space seen through them removes them, except within th_ch of the ground (Alg. 2 keeps a
  // prior point that has any current point within th_ch). Far faces may stay.
  auto count_visible_faces = [](const PointCloud& c, const Box& b) {
    return std::count_if(c.begin(), c.end(), [&](const Point& p) {
      const bool front = std::abs(p.y() - b.max.y()) < 0.01,
                 top = std::abs(p.z() - b.max.z()) < 0.01;
      return p.z() > kGroundZ + 2.4 + 0.1 && b.Distance(p.cast<double>()) < 0.01 && (front || top);
    });
  };
  EXPECT_GT(count_visible_faces(v1, kBoxA), 200);
  EXPECT_LT(count_visible_faces(v2, kBoxA), count_visible_faces(v1, kBoxA) / 10);
  EXPECT_LT(count_near(v2, kBoxA, 0.01), count_near(v1, kBoxA, 0.01));
  EXPECT_EQ(count_near(v2, kBoxB, 0.01), count_near(v1, kBoxB, 0.01));  // untouched box stays
  // Refreshed tiles start aggregating afresh: no changes listed for them any more.
  const Json after =
      Call(client_->Get("/v1/changes/tiles?bbox=-30,-10,70,40&min_confidence=0.7", H(reader_)))
          .second;
  for (const Json& t : after["tiles"]) {
    EXPECT_EQ(std::find(tiles.begin(), tiles.end(), t["tile"].get<std::string>()), tiles.end())
        << t["tile"] << " still lists changes after refresh";
  }

  // 6. Reclassify with a new threshold is accepted and runs; metrics saw the ingest.
  auto [st5, rjob] =
      Call(client_->Post("/v1/admin/jobs", H(admin_),
                         R"({"type":"reclassify","params":{"th_ch_m":2.4}})", "application/json"));
  ASSERT_EQ(st5, 202);
  EXPECT_EQ(WaitJob(rjob["job_id"])["state"], "succeeded");
  const auto metrics = client_->Get("/metrics");
  ASSERT_TRUE(metrics);
  EXPECT_NE(metrics->body.find("mapdelta_keyframes_ingested_total 42"), std::string::npos)
      << metrics->body;
}

// Malformed input on every body and parameter: each gets a 4xx JSON error, nothing is stored,
// and the server keeps serving.
TEST_P(ServerHttpTest, MalformedInputGets4xxAndTheServerKeepsServing) {
  const int64_t s = CreateSession("car-1");
  const SE3 T = CameraLookingMinusY(0, 25, kCameraHeight, kPitch);
  const std::string png = PngString(ChangedScene().Render(TestCamera(), T, kMaxDepth));
  std::vector<std::pair<std::string, httplib::Result>> cases;
  auto add = [&](const std::string& name, httplib::Result r) {
    cases.emplace_back(name, std::move(r));
  };
  // Depth PNGs: truncated (header intact, data cut; and cut inside the header), a header
  // claiming 60000x60000 (a decompression bomb if decoded), 8-bit instead of 16-bit.
  add("png truncated", PutKeyframe(s, 0, MetaJson(1, T), png.substr(0, png.size() / 2)));
  add("png cut in header", PutKeyframe(s, 0, MetaJson(1, T), png.substr(0, 20)));
  std::string huge = png;
  for (int i : {16, 20}) huge.replace(i, 4, std::string("\x00\x00\xea\x60", 4));
  add("png huge", PutKeyframe(s, 0, MetaJson(1, T), huge));
  std::string eight = png;
  eight[24] = 8;
  add("png 8-bit", PutKeyframe(s, 0, MetaJson(1, T), eight));
  add("png empty", PutKeyframe(s, 0, MetaJson(1, T), ""));
  // Meta JSON with wrong types, out-of-range numbers, inf (1e400 parses to inf) and NaN.
  Json m = MetaJson(1, T);
  for (const auto& [name, patch] : std::vector<std::pair<std::string, Json>>{
           {"t_ns string", {{"t_ns", "1"}}},
           {"t_ns float", {{"t_ns", 1.5}}},
           {"t_ns beyond int64", {{"t_ns", 18446744073709551615ull}}},
           {"pose array", {{"T_map_cam", Json::array()}}},
           {"pose t strings", {{"T_map_cam", {{"t", {"a", "b", "c"}}, {"q", {1, 0, 0, 0}}}}}},
           {"covariance object", {{"covariance", {{"a", 1}}}}},
           {"covariance 35", {{"covariance", std::vector<double>(35, 1.0)}}},
           {"covariance negative", {{"covariance", [] { std::vector<double> v(36, 0.0); v[0] = -1; return v; }()}}},
           {"extra field", {{"speed", 3}}}}) {
    Json bad = m;
    bad.update(patch);
    add("meta " + name, PutKeyframe(s, 0, bad, png));
  }
  const std::string meta_text = MetaJson(1, T).dump();
  for (const std::string& text :
       {std::string("[1,2]"), std::string("null"), std::string("{\"t_ns\": NaN}"),
        meta_text.substr(0, meta_text.size() - 3)}) {
    httplib::MultipartFormDataItems items = {{"meta", text, "", "application/json"},
                                             {"depth", png, "d.png", "image/png"}};
    add("meta text " + text,
        client_->Put("/v1/sessions/" + std::to_string(s) + "/keyframes/0", H(vehicle_), items));
  }
  std::string inf_cov = MetaJson(1, T).dump();
  inf_cov.insert(inf_cov.size() - 1, ",\"covariance\":[1e400" + std::string(35 * 2, ' ') + "]");
  for (int i = 0; i < 35; ++i) inf_cov.replace(inf_cov.find(' '), 2, ",0");
  {
    httplib::MultipartFormDataItems items = {{"meta", inf_cov, "", "application/json"},
                                             {"depth", png, "d.png", "image/png"}};
    add("covariance inf",
        client_->Put("/v1/sessions/" + std::to_string(s) + "/keyframes/0", H(vehicle_), items));
  }
  // Sequence numbers: beyond max_keyframes_per_session, beyond int64 (no route), negative.
  add("seq huge", PutKeyframe(s, 999999999999999999LL, MetaJson(1, T), png));
  {
    httplib::MultipartFormDataItems items = {
        {"meta", MetaJson(1, T).dump(), "", "application/json"},
        {"depth", png, "d.png", "image/png"}};
    add("seq 2^64",
        client_->Put("/v1/sessions/" + std::to_string(s) + "/keyframes/18446744073709551616",
                     H(vehicle_), items));
    add("seq -1",
        client_->Put("/v1/sessions/" + std::to_string(s) + "/keyframes/-1", H(vehicle_), items));
    add("session 2^64",
        client_->Put("/v1/sessions/99999999999999999999/keyframes/0", H(vehicle_), items));
  }
  // Session creation with wrong types and a width that would wrap when narrowed to int.
  for (
      const std::string& body :
      {std::string(R"({"vehicle_id":5,"camera":{}})"),
       std::string(R"({"vehicle_id":"v","camera":"x"})"),
       std::string(
           R"({"vehicle_id":"v","camera":{"width":4294967456,"height":90,"fx":80,"fy":80,"cx":80,"cy":45}})"),
       std::string(
           R"({"vehicle_id":"v","camera":{"width":160,"height":90,"fx":1e400,"fy":80,"cx":80,"cy":45}})"),
       std::string(
           R"({"vehicle_id":"v","depth_scale":"big","camera":{"width":160,"height":90,"fx":80,"fy":80,"cx":80,"cy":45}})"),
       std::string("[]"), std::string("\"text\""), std::string("{\"vehicle_id\":\"v\",")}) {
    add("session " + body, client_->Post("/v1/sessions", H(vehicle_), body, "application/json"));
  }
  // Admin jobs with wrong types and overflowing values.
  for (const std::string& body :
       {std::string(R"({"type":"refresh","bbox":["a",0,1,1]})"),
        std::string(R"({"type":"refresh","tiles":[1,2]})"),
        std::string(R"({"type":"refresh","tiles":["99999999999_0"]})"),
        std::string(R"({"type":"refresh","bbox":[0,0,1,1],"min_confidence":"high"})"),
        std::string(R"({"type":"refresh","bbox":[1e300,1e300,1e300,1e300]})"),
        std::string(R"({"type":"reclassify","params":{"min_voxel_support":4294967297}})"),
        std::string(R"({"type":7})"), std::string("[]")}) {
    add("job " + body, client_->Post("/v1/admin/jobs", H(admin_), body, "application/json"));
  }
  // Query parameters.
  for (const std::string& path :
       {std::string("/v1/changes/tiles?bbox=nan,0,1,1"),
        std::string("/v1/changes/tiles?bbox=1e300,1e300,1e300,1e300"),
        std::string("/v1/changes/tiles?bbox=0,0,1,1&page=abc"),
        std::string("/v1/changes/tiles?bbox=0,0,1,1&page=99999999999999999999"),
        std::string("/v1/changes/tiles?bbox=0,0,1,1&page_size=0"),
        std::string("/v1/changes/tiles?bbox=0,0,1,1&min_confidence=inf"),
        std::string("/v1/changes/tiles?bbox=0,0,1,1&min_support=-1"),
        std::string("/v1/changes/tiles/99999999999_1"),
        std::string("/v1/changes/tiles/0_0?min_support=x"),
        std::string("/v1/observed/tiles/99999999999_1.bt"),
        std::string("/v1/observed/tiles/2147483647_2147483647.bt")}) {
    add("GET " + path, client_->Get(path, H(reader_)));
  }
  add("prior near inf", client_->Get("/v1/prior/tiles?x=1e300&y=0", H(vehicle_)));
  add("prior truncated",
      client_->Post("/v1/admin/prior?format=pcd", H(admin_),
                    "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
                    "WIDTH 1000\nHEIGHT 1\nPOINTS 1000\nDATA binary\n\x01\x02",
                    "application/octet-stream"));
  add("prior ply garbage", client_->Post("/v1/admin/prior?format=ply", H(admin_),
                                         std::string(1000, '\xff'), "application/octet-stream"));
  for (auto& [name, r] : cases) {
    SCOPED_TRACE(name);
    ASSERT_TRUE(r) << "no response";
    EXPECT_GE(r->status, 400) << r->body;
    EXPECT_LT(r->status, 500) << r->body;
    EXPECT_EQ(r->get_header_value("Content-Type"), "application/json");
  }
  // Nothing was stored, and the server still takes a good keyframe.
  EXPECT_EQ(
      Call(client_->Get("/v1/sessions/" + std::to_string(s), H(vehicle_))).second["keyframe_count"],
      0);
  EXPECT_EQ(Call(PutKeyframe(s, 0, MetaJson(1, T), png)).first, 201);
  EXPECT_EQ(Call(client_->Get("/health")).first, 200);
  EXPECT_EQ(service_->storage().priors().ListVersions().size(), 0u);
}

INSTANTIATE_TEST_SUITE_P(Backends, ServerHttpTest, ::testing::ValuesIn(kServerBackends),
                         BackendName());

}  // namespace
}  // namespace mapdelta::server
