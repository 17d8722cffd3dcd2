// The change feed and cluster routes over real HTTP (issue #20 item 3): ETag / If-None-Match ->
// 304 and Cache-Control (immutable for a prior tile at a version), gzip when the client accepts
// it, roles, the admin's confirm / reject, and every bad parameter refused with a 400 naming it.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "http_test_server.hpp"
#include "mapdelta/common/cloud_io.hpp"

#include <httplib.h>  // last: its <resolv.h> defines macros that break Eigen

namespace mapdelta::server {
namespace {

class ChangeFeedHttp : public HttpServerTest {
 protected:
  void SetUp() override {
    HttpServerTest::SetUp();
    const std::string prior = (dir_ / "prior.pcd").string();
    WriteCloud(prior, PriorScene().Sample(0.5));
    service_->ImportPriorFile(prior, "prior");
  }
  // One drive over the changed scene through the facade, committed by the running worker.
  void Drive(const std::string& vehicle, double y_cam) {
    const Json camera{{"width", 160}, {"height", 90}, {"fx", 80},
                      {"fy", 80},     {"cx", 80},     {"cy", 45}};
    const int64_t s =
        service_->CreateSession({{"vehicle_id", vehicle}, {"camera", camera}})["session_id"];
    int64_t seq = 0;
    for (double x = -5; x <= 45; x += 2.5, ++seq) {
      const SE3 T = CameraLookingMinusY(x, y_cam, kCameraHeight, kPitch);
      const auto png = EncodeDepthPng(ChangedScene().Render(TestCamera(), T, kMaxDepth));
      bool created = false;
      service_->PutKeyframe(s, seq, MetaJson(1000000000LL * (seq + 1), T),
                            Bytes(png.begin(), png.end()), &created);
    }
    const int64_t job = service_->CommitSession(s)["job_id"];
    for (int i = 0; i < 1200 && service_->GetJob(job)["state"] != "succeeded"; ++i) {
      ASSERT_NE(service_->GetJob(job)["state"], "failed");
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    ASSERT_EQ(service_->GetJob(job)["state"], "succeeded");
  }
  httplib::Headers With(const std::string& auth, const std::string& name,
                        const std::string& value) {
    return {{"Authorization", auth}, {name, value}};
  }
  // The status and error message of a GET that must fail.
  std::pair<int, std::string> Refused(const std::string& path) {
    auto [status, body] = Call(client_->Get(path, H(reader_)));
    return {status, body["error"].value("message", "")};
  }
};

TEST_F(ChangeFeedHttp, PriorTilesCarryAnETagAndAreImmutableAtAVersion) {
  auto first = client_->Get("/v1/prior/tiles/0_0?version=1", H(reader_));
  ASSERT_TRUE(first && first->status == 200);
  const std::string etag = first->get_header_value("ETag");
  ASSERT_FALSE(etag.empty());
  EXPECT_EQ(etag.front(), '"');
  EXPECT_NE(first->get_header_value("Cache-Control").find("immutable"), std::string::npos);
  auto again = client_->Get("/v1/prior/tiles/0_0?version=1", With(reader_, "If-None-Match", etag));
  ASSERT_TRUE(again);
  EXPECT_EQ(again->status, 304);
  EXPECT_TRUE(again->body.empty());
  EXPECT_EQ(again->get_header_value("ETag"), etag);
  auto weak = client_->Get("/v1/prior/tiles/0_0?version=1",
                           With(reader_, "If-None-Match", "\"x\", W/" + etag));
  ASSERT_TRUE(weak);
  EXPECT_EQ(weak->status, 304);
  auto other =
      client_->Get("/v1/prior/tiles/0_0?version=1", With(reader_, "If-None-Match", "\"x\""));
  ASSERT_TRUE(other);
  EXPECT_EQ(other->status, 200);
  EXPECT_EQ(other->body, first->body);
  // The latest version: the same bytes and ETag, but revalidated on every use.
  auto latest = client_->Get("/v1/prior/tiles/0_0", H(reader_));
  ASSERT_TRUE(latest && latest->status == 200);
  EXPECT_EQ(latest->get_header_value("ETag"), etag);
  EXPECT_EQ(latest->get_header_value("Cache-Control"), "no-cache");
  // Another format is other bytes: another ETag.
  auto ply = client_->Get("/v1/prior/tiles/0_0?version=1&format=ply", H(reader_));
  ASSERT_TRUE(ply && ply->status == 200);
  EXPECT_NE(ply->get_header_value("ETag"), etag);
  // A failed request has none.
  auto missing = client_->Get("/v1/prior/tiles/0_0?version=7", H(reader_));
  ASSERT_TRUE(missing);
  EXPECT_EQ(missing->status, 404);
  EXPECT_TRUE(missing->get_header_value("ETag").empty());
}

TEST_F(ChangeFeedHttp, FeedClustersAndAdminDecisions) {
  Drive("car-1", 25.0);
  auto [status, feed] = Call(client_->Get("/v1/changes/feed", H(reader_)));
  ASSERT_EQ(status, 200);
  ASSERT_FALSE(feed["clusters"].empty());
  EXPECT_EQ(feed["since"], 0);
  EXPECT_EQ(feed["next"], feed["clusters"].back()["seq"]);
  const int64_t id = feed["clusters"][0]["cluster_id"];
  EXPECT_EQ(feed["clusters"][0]["state"], "candidate");

  // Revalidation: the same answer is a 304 until something changes.
  auto r = client_->Get("/v1/changes/feed", H(reader_));
  ASSERT_TRUE(r);
  const std::string etag = r->get_header_value("ETag");
  EXPECT_EQ(r->get_header_value("Cache-Control"), "no-cache");
  auto same = client_->Get("/v1/changes/feed", With(reader_, "If-None-Match", etag));
  ASSERT_TRUE(same);
  EXPECT_EQ(same->status, 304);
  // gzip for a client that accepts it (cpp-httplib's own compression).
  httplib::Headers gz = With(reader_, "Accept-Encoding", "gzip");
  auto zipped = client_->Get("/v1/changes/feed", gz);
  ASSERT_TRUE(zipped && zipped->status == 200);
  EXPECT_EQ(zipped->get_header_value("Content-Encoding"), "gzip");
  EXPECT_EQ(Json::parse(zipped->body), feed) << "the client decompresses it";

  // One cluster with its history; the listing by bbox and state.
  auto [one_status, one] =
      Call(client_->Get("/v1/changes/clusters/" + std::to_string(id), H(reader_)));
  ASSERT_EQ(one_status, 200);
  EXPECT_EQ(one["transitions"].size(), 1u);
  auto [list_status, list] =
      Call(client_->Get("/v1/changes/clusters?bbox=-30,-10,70,40&state=candidate", H(reader_)));
  ASSERT_EQ(list_status, 200);
  EXPECT_EQ(list["total"], feed["clusters"].size());
  auto [none_status, none] =
      Call(client_->Get("/v1/changes/clusters?bbox=500,500,600,600", H(reader_)));
  ASSERT_EQ(none_status, 200);
  EXPECT_EQ(none["total"], 0);

  // Admin decisions: roles, body, state.
  const std::string confirm = "/v1/admin/changes/" + std::to_string(id) + "/confirm";
  const std::string cause = R"({"cause":"surveyed"})";
  EXPECT_EQ(Call(client_->Post(confirm, H(reader_), cause, "application/json")).first, 403);
  EXPECT_EQ(Call(client_->Post(confirm, cause, "application/json")).first, 401);
  EXPECT_EQ(Call(client_->Post(confirm, H(admin_), cause, "text/plain")).first, 415);
  auto [no_cause, no_cause_body] =
      Call(client_->Post(confirm, H(admin_), "{}", "application/json"));
  EXPECT_EQ(no_cause, 400);
  EXPECT_NE(no_cause_body["error"]["message"].get<std::string>().find("cause"), std::string::npos);
  auto [ok, decided] = Call(client_->Post(confirm, H(admin_), cause, "application/json"));
  ASSERT_EQ(ok, 200);
  EXPECT_EQ(decided["state"], "confirmed");
  EXPECT_EQ(decided["transitions"].back()["actor"], "admin:admin");
  auto [again, again_body] = Call(client_->Post(confirm, H(admin_), cause, "application/json"));
  EXPECT_EQ(again, 409);
  EXPECT_EQ(again_body["error"]["code"], "cluster_state_conflict");
  EXPECT_EQ(
      Call(client_->Post("/v1/admin/changes/999999/reject", H(admin_), cause, "application/json"))
          .first,
      404);
  // The feed moved on: the old ETag no longer matches, and the cursor shows just the decision.
  auto changed = client_->Get("/v1/changes/feed", With(reader_, "If-None-Match", etag));
  ASSERT_TRUE(changed);
  EXPECT_EQ(changed->status, 200);
  auto [after_status, after] = Call(client_->Get(
      "/v1/changes/feed?since=" + std::to_string(feed["next"].get<int64_t>()), H(reader_)));
  ASSERT_EQ(after_status, 200);
  ASSERT_EQ(after["clusters"].size(), 1u);
  EXPECT_EQ(after["clusters"][0]["cluster_id"], id);
  EXPECT_EQ(after["next"], feed["next"].get<int64_t>() + 1);
}

TEST_F(ChangeFeedHttp, BadParametersAreRefusedNamingThem) {
  EXPECT_EQ(Call(client_->Get("/v1/changes/feed")).first, 401);
  EXPECT_EQ(Call(client_->Get("/v1/changes/feed", H(vehicle_))).first, 403);
  for (const auto& [path, named] : std::vector<std::pair<std::string, std::string>>{
           {"/v1/changes/feed?since=abc", "'since'"},
           {"/v1/changes/feed?since=-1", "'since'"},
           {"/v1/changes/feed?since=1e3", "'since'"},
           {"/v1/changes/feed?since=99999999999999999999", "'since'"},
           {"/v1/changes/feed?since=5", "beyond the feed's last position 0"},
           {"/v1/changes/feed?limit=0", "'limit'"},
           {"/v1/changes/feed?limit=1001", "'limit'"},
           {"/v1/changes/feed?limit=ten", "'limit'"},
           {"/v1/changes/feed?cursor=1", "unknown query parameter 'cursor'"},
           {"/v1/changes/clusters?bbox=1,2,3", "bbox"},
           {"/v1/changes/clusters?bbox=0,0,1,x", "bbox"},
           {"/v1/changes/clusters?bbox=5,0,1,1", "bbox"},
           {"/v1/changes/clusters?state=maybe", "'state'"},
           {"/v1/changes/clusters?page_size=5000", "page_size"},
           {"/v1/changes/clusters?page=0", "page"},
       }) {
    auto [status, message] = Refused(path);
    EXPECT_EQ(status, 400) << path;
    EXPECT_NE(message.find(named), std::string::npos) << path << ": " << message;
  }
  EXPECT_EQ(Refused("/v1/changes/clusters/123").first, 404);
  EXPECT_EQ(Refused("/v1/changes/clusters/abc").first, 404) << "not a route";
  auto [status, feed] = Call(client_->Get("/v1/changes/feed?since=0&limit=1000", H(reader_)));
  EXPECT_EQ(status, 200);
  EXPECT_TRUE(feed["clusters"].empty());
  EXPECT_EQ(feed["next"], 0);
  // The OpenAPI document names the new routes.
  auto doc = client_->Get("/v1/openapi.yaml");
  ASSERT_TRUE(doc && doc->status == 200);
  for (const char* route :
       {"/v1/changes/feed:", "/v1/changes/clusters:", "/v1/changes/clusters/{cluster_id}:",
        "/v1/admin/changes/{cluster_id}/confirm:", "/v1/admin/changes/{cluster_id}/reject:"}) {
    EXPECT_NE(doc->body.find(route), std::string::npos) << route;
  }
}

}  // namespace
}  // namespace mapdelta::server
