// Found by bench/load.sh (16 uploaders + 2 readers, 8 HTTP threads): httplib serves a
// keep-alive connection on one worker until it has made keep_alive_max_count requests, so with
// more busy vehicles than workers the rest were not served at all (4 of 16 uploaders got no
// answer to their first request after 52 s). This test keeps both workers of a 2-thread server
// busy with two uploading vehicles and checks that a third client is answered meanwhile. The
// 3 s bound is a liveness check with a wide margin (answered within ~10 uploads now; the old
// limit of 1000 requests per connection took ~10 s here), not a speed target.
#include <gtest/gtest.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "auth.hpp"
#include "mapdelta/common/depth_image.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/server/http_server.hpp"
#include "mapdelta/server/map_service.hpp"

#include <httplib.h>  // last: its <resolv.h> defines macros that break Eigen

namespace mapdelta::server {
namespace {

TEST(HttpFairness, BusyKeepAliveClientsDoNotStarveAnotherClient) {
  log::SetLevel(log::Level::kWarn);
  const auto dir =
      std::filesystem::temp_directory_path() / ("mds_fair_" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  ServerConfig config;
  config.http.threads = 2;
  config.storage.database = (dir / "db.sqlite").string();
  MapService service(config, OpenSqliteStorage(config.storage.database));
  const std::string vehicle =
      "Bearer " + CreateToken(service.storage(), "car", Role::kVehicle, NowMs()).secret;
  HttpServer http(service);
  const int port = http.Bind("127.0.0.1", 0);
  std::thread server([&] { http.Run(); });

  DepthImage depth(160, 90);
  for (float& d : depth.depth_m) d = 7.5f;
  const auto png_bytes = EncodeDepthPng(depth);
  const std::string png(png_bytes.begin(), png_bytes.end()),
      camera =
          R"({"vehicle_id":"v","camera":{"width":160,"height":90,"fx":80,"fy":80,"cx":80,"cy":45}})";
  std::atomic<bool> stop{false};
  std::atomic<int> uploads{0};
  auto vehicle_loop = [&] {
    httplib::Client c("127.0.0.1", port);
    c.set_keep_alive(true);
    const httplib::Headers h{{"Authorization", vehicle}};
    auto created = c.Post("/v1/sessions", h, camera, "application/json");
    ASSERT_TRUE(created && created->status == 201);
    const std::string path =
        "/v1/sessions/" + nlohmann::json::parse(created->body)["session_id"].dump() + "/keyframes/";
    for (int seq = 0; seq < 3000 && !stop; ++seq) {
      const std::string meta =
          R"({"t_ns":)" + std::to_string(seq + 1) + R"(,"T_map_cam":{"t":[0,0,1],"q":[1,0,0,0]}})";
      auto r =
          c.Put(path + std::to_string(seq), h,
                {{"meta", meta, "", "application/json"}, {"depth", png, "d.png", "image/png"}});
      ASSERT_TRUE(r && r->status == 201);
      ++uploads;
    }
  };
  std::thread a(vehicle_loop), b(vehicle_loop);
  while (uploads < 6)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));  // both workers taken

  httplib::Client third("127.0.0.1", port);
  third.set_read_timeout(3, 0);
  const auto t0 = std::chrono::steady_clock::now();
  auto health = third.Get("/health");
  const double waited_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const int uploads_meanwhile = uploads;
  stop = true;
  a.join();
  b.join();
  http.Stop();
  server.join();
  ASSERT_TRUE(health) << "a third client got no answer within 3 s while two vehicles uploaded";
  EXPECT_EQ(health->status, 200);
  std::printf("third client answered after %.3f s (%d uploads so far)\n", waited_s,
              uploads_meanwhile);
  std::filesystem::remove_all(dir);
}

// A load run lost 2 POST /v1/sessions to a full listen queue: the system's httplib library
// listens with a backlog of 5, and while its accept thread waits for the CPU further SYNs are
// dropped. The server's listening socket must have the system's limit instead (the backlog of
// a listening socket is what `ss` shows as its Send-Q).
TEST(HttpFairness, ListenBacklogIsTheSystemLimit) {
  log::SetLevel(log::Level::kWarn);
  const auto dir =
      std::filesystem::temp_directory_path() / ("mds_backlog_" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  ServerConfig config;
  config.storage.database = (dir / "db.sqlite").string();
  MapService service(config, OpenSqliteStorage(config.storage.database));
  HttpServer http(service);
  const int port = http.Bind("127.0.0.1", 0);
  const std::string command = "ss -Hltn 'sport = :" + std::to_string(port) + "' 2>/dev/null";
  std::string out;
  if (FILE* p = ::popen(command.c_str(), "r")) {
    char buf[512];
    while (std::fgets(buf, sizeof buf, p)) out += buf;
    ::pclose(p);
  }
  std::filesystem::remove_all(dir);
  if (out.empty()) GTEST_SKIP() << "no `ss` (iproute2) to read the listen backlog with";
  std::istringstream fields(out);
  std::string state;
  long queued = -1, backlog = -1;
  fields >> state >> queued >> backlog;
  ASSERT_EQ(state, "LISTEN") << out;
  long somaxconn = SOMAXCONN;
  std::ifstream("/proc/sys/net/core/somaxconn") >> somaxconn;
  EXPECT_EQ(backlog, std::min<long>(SOMAXCONN, somaxconn)) << out;
  EXPECT_GT(backlog, 5) << out;
}

}  // namespace
}  // namespace mapdelta::server
