// The HTTP layer around the routes, over a real loopback socket with raw requests: body-less
// POSTs as curl sends them, X-Request-Id on every response (httplib's own errors and static
// files included), Range ignored by the API (full body, own status), unknown query parameters
// refused.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>

#include "http_test_server.hpp"
#include "raw_http.hpp"

namespace mapdelta::server {
namespace {

// Longer than any answer takes, shorter than the server's read timeout (30 s): a request the
// server waits on (the body-less POST bug) shows up as no answer, not as a slow pass.
constexpr int kAnswerTimeoutS = 10;

class HttpProtocolTest : public HttpServerTest {
 protected:
  void BeforeRun(HttpServer& http) override {
    const auto web = dir_ / "web";
    std::filesystem::create_directories(web);
    std::ofstream(web / "index.html") << "<!doctype html><title>map</title>";
    ASSERT_TRUE(http.MountWebRoot(web.string()));
  }

  // A request as curl 7.88 writes it (no Content-Length without a body), plus extra headers.
  std::string CurlRequest(const std::string& method, const std::string& target,
                          const std::string& auth, const std::string& extra_headers = "") {
    return method + " " + target + " HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(port_) +
           "\r\nUser-Agent: curl/7.88.1\r\nAccept: */*\r\n" +
           (auth.empty() ? "" : "Authorization: " + auth + "\r\n") + extra_headers + "\r\n";
  }

  int64_t SessionWithOneKeyframe() {
    const Json camera{{"width", 160}, {"height", 90}, {"fx", 80},
                      {"fy", 80},     {"cx", 80},     {"cy", 45}};
    auto [status, session] = Call(
        client_->Post("/v1/sessions", H(vehicle_),
                      Json{{"vehicle_id", "car"}, {"camera", camera}}.dump(), "application/json"));
    EXPECT_EQ(status, 201);
    const int64_t id = session.value("session_id", int64_t{-1});
    const SE3 T = CameraLookingMinusY(0, 25, kCameraHeight, kPitch);
    httplib::MultipartFormDataItems items = {
        {"meta", MetaJson(1, T).dump(), "", "application/json"},
        {"depth", PngString(ChangedScene().Render(TestCamera(), T, kMaxDepth)), "d.png",
         "image/png"}};
    EXPECT_EQ(Call(client_->Put("/v1/sessions/" + std::to_string(id) + "/keyframes/0", H(vehicle_),
                                items))
                  .first,
              201);
    return id;
  }
};

Json BodyOf(const RawResponse& r) {
  EXPECT_EQ(r.Header("content-type"), "application/json") << r.body;
  return Json::parse(r.body, nullptr, false);
}

TEST_F(HttpProtocolTest, BodylessPostsAreAnsweredAtOnceOnAKeptConnection) {
  const int64_t session = SessionWithOneKeyframe();
  RawConnection c(port_, kAnswerTimeoutS);
  const auto t0 = std::chrono::steady_clock::now();
  // Commit without a body (curl -X POST .../commit): 202 with the job.
  auto commit = c.Exchange(
      CurlRequest("POST", "/v1/sessions/" + std::to_string(session) + "/commit", vehicle_));
  ASSERT_TRUE(commit) << "no answer to a body-less POST within " << kAnswerTimeoutS << " s";
  ASSERT_EQ(commit->status, 202) << commit->body;
  const Json job = BodyOf(*commit);
  ASSERT_TRUE(job.contains("job_id")) << commit->body;
  // Cancel, also body-less, on the same connection: cancelled (200), or 409 if the commit
  // already finished; either way the route answered, not the HTTP layer.
  auto cancel = c.Exchange(CurlRequest(
      "POST", "/v1/admin/jobs/" + std::to_string(job["job_id"].get<int64_t>()) + "/cancel",
      admin_));
  ASSERT_TRUE(cancel) << "no answer to the body-less cancel";
  EXPECT_TRUE(cancel->status == 200 || cancel->status == 409)
      << cancel->status << " " << cancel->body;
  if (cancel->status == 409) {
    EXPECT_EQ(BodyOf(*cancel)["error"]["code"], "job_not_cancellable");
  }
  // Routes that need a body say so instead of "malformed HTTP request".
  auto create = c.Exchange(CurlRequest("POST", "/v1/sessions", vehicle_));
  ASSERT_TRUE(create);
  EXPECT_EQ(create->status, 415);
  EXPECT_EQ(BodyOf(*create)["error"]["code"], "unsupported_media_type");
  auto put = c.Exchange(
      CurlRequest("PUT", "/v1/sessions/" + std::to_string(session) + "/keyframes/1", vehicle_));
  ASSERT_TRUE(put);
  EXPECT_EQ(put->status, 415);
  EXPECT_EQ(BodyOf(*put)["error"]["code"], "unsupported_media_type") << put->body;
  // The connection is still in sync: the next request gets its own answer.
  auto health = c.Exchange(CurlRequest("GET", "/health", ""));
  ASSERT_TRUE(health);
  EXPECT_EQ(health->status, 200);
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(kAnswerTimeoutS));
}

TEST_F(HttpProtocolTest, EveryResponseCarriesARequestId) {
  struct Case {
    std::string name, request;
    int status;
  };
  const std::vector<Case> cases = {
      {"unknown route", CurlRequest("GET", "/nope", admin_), 404},
      {"malformed request line", "GARBAGE\r\n\r\n", 400},
      {"request URI too long", CurlRequest("GET", "/" + std::string(9000, 'a'), ""), 414},
      {"unparsable Range", CurlRequest("GET", "/health", "", "Range: bytes=abc\r\n"), 416},
      {"declared body too large",
       CurlRequest("POST", "/v1/sessions", vehicle_, "Content-Length: 999999999\r\n"), 413},
      {"no token", CurlRequest("GET", "/v1/admin/jobs", ""), 401},
      {"handler answer", CurlRequest("GET", "/health", ""), 200},
      {"static file", CurlRequest("GET", "/index.html", ""), 200},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    RawConnection conn(port_, kAnswerTimeoutS);
    auto r = conn.Exchange(c.request);
    ASSERT_TRUE(r) << "no answer";
    EXPECT_EQ(r->status, c.status) << r->body;
    const std::string id = r->Header("x-request-id");
    EXPECT_FALSE(id.empty());
    if (r->status >= 400) {
      EXPECT_EQ(BodyOf(*r)["error"]["request_id"], id) << r->body;
    }
  }
  // A client's own id comes back, also on an error httplib answers by itself.
  RawConnection conn(port_, kAnswerTimeoutS);
  auto r = conn.Exchange(CurlRequest("GET", "/nope", "", "X-Request-Id: trace-7\r\n"));
  ASSERT_TRUE(r);
  EXPECT_EQ(r->Header("x-request-id"), "trace-7");
  EXPECT_EQ(BodyOf(*r)["error"]["request_id"], "trace-7");
}

TEST_F(HttpProtocolTest, RangeIsIgnoredWholeBodyWithItsOwnStatus) {
  RawConnection c(port_, kAnswerTimeoutS);
  auto whole = c.Exchange(CurlRequest("GET", "/v1/openapi.yaml", ""));
  ASSERT_TRUE(whole);
  ASSERT_EQ(whole->status, 200);
  for (const std::string range : {"bytes=0-9", "bytes=-5", "bytes=0-1,4-6", "bytes=999999-"}) {
    SCOPED_TRACE(range);
    auto r = c.Exchange(CurlRequest("GET", "/v1/openapi.yaml", "", "Range: " + range + "\r\n"));
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 200);
    EXPECT_EQ(r->body, whole->body);
    EXPECT_EQ(r->Header("content-range"), "");
    EXPECT_EQ(r->Header("accept-ranges"), "none");
    // Errors too stay whole JSON (httplib used to cut them to the range).
    auto error = c.Exchange(
        CurlRequest("GET", "/v1/changes/tiles?bbox=0,0,1,1", "", "Range: " + range + "\r\n"));
    ASSERT_TRUE(error);
    EXPECT_EQ(error->status, 401);
    EXPECT_EQ(BodyOf(*error)["error"]["code"], "unauthenticated") << error->body;
  }
  // The web map's static files (httplib's file handler) too.
  auto file = c.Exchange(CurlRequest("GET", "/index.html", "", "Range: bytes=0-4\r\n"));
  ASSERT_TRUE(file);
  EXPECT_EQ(file->status, 200);
  EXPECT_EQ(file->body, "<!doctype html><title>map</title>");
  EXPECT_EQ(file->Header("content-range"), "");
  EXPECT_EQ(file->Header("accept-ranges"), "none");
}

TEST_F(HttpProtocolTest, UnknownQueryParametersAreRefusedOnEveryRoute) {
  const std::string json = "application/json";
  struct Route {
    std::string method, path, token;
  };
  // Every route of the API (docs/api.md), each with a parameter it does not take.
  const std::vector<Route> routes = {
      {"GET", "/health", ""},
      {"GET", "/metrics", ""},
      {"GET", "/v1/openapi.yaml", ""},
      {"POST", "/v1/sessions", vehicle_},
      {"PUT", "/v1/sessions/1/keyframes/0", vehicle_},
      {"POST", "/v1/sessions/1/commit", vehicle_},
      {"GET", "/v1/sessions/1", vehicle_},
      {"GET", "/v1/prior/tiles?x=0&y=0", vehicle_},
      {"GET", "/v1/prior/tiles/0_0", vehicle_},
      {"GET", "/v1/map", reader_},
      {"GET", "/v1/prior/versions", vehicle_},
      {"GET", "/v1/changes/tiles?bbox=0,0,1,1", reader_},
      {"GET", "/v1/changes/tiles/0_0", reader_},
      {"GET", "/v1/observed/tiles/0_0.bt", reader_},
      {"POST", "/v1/admin/prior?format=pcd", admin_},
      {"POST", "/v1/admin/jobs", admin_},
      {"GET", "/v1/admin/jobs", admin_},
      {"GET", "/v1/admin/jobs/1", admin_},
      {"POST", "/v1/admin/jobs/1/cancel", admin_},
  };
  for (const Route& route : routes) {
    SCOPED_TRACE(route.method + " " + route.path);
    const std::string target =
        route.path + (route.path.find('?') == std::string::npos ? "?" : "&") + "since=5";
    httplib::Result r = route.method == "GET"    ? client_->Get(target, H(route.token))
                        : route.method == "POST" ? client_->Post(target, H(route.token), "{}", json)
                                                 : client_->Put(target, H(route.token), "{}", json);
    auto [status, body] = Call(r);
    EXPECT_EQ(status, 400);
    EXPECT_EQ(body["error"]["code"], "invalid_argument");
    EXPECT_NE(body["error"].value("message", "").find("unknown query parameter 'since'"),
              std::string::npos)
        << body.dump();
  }
  // A parameter given twice is refused; the documented ones still work.
  auto [twice, twice_body] =
      Call(client_->Get("/v1/changes/tiles?bbox=0,0,1,1&bbox=2,2,3,3", H(reader_)));
  EXPECT_EQ(twice, 400);
  EXPECT_NE(twice_body["error"].value("message", "").find("'bbox' is given more than once"),
            std::string::npos);
  EXPECT_EQ(
      Call(
          client_->Get(
              "/v1/changes/tiles?bbox=0,0,1,1&min_confidence=0.5&min_support=1&page=1&page_size=10",
              H(reader_)))
          .first,
      200);
  EXPECT_EQ(Call(client_->Get("/v1/admin/jobs?page=1&page_size=5", H(admin_))).first, 200);
  // A form-encoded body is not taken for query parameters: it is the wrong media type.
  EXPECT_EQ(Call(client_->Post("/v1/sessions", H(vehicle_), "vehicle_id=car",
                               "application/x-www-form-urlencoded"))
                .first,
            415);
}

}  // namespace
}  // namespace mapdelta::server
