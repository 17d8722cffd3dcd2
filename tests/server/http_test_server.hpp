#pragma once
// The server tests' fixture: a MapService on a fresh database (SQLite by default; a suite that
// overrides Backend() runs on PostgreSQL too), the real HTTP server on a free loopback port
// (in-process), tokens of the three roles and an httplib client.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>

#include "auth.hpp"
#include "changed_scene.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/server/http_server.hpp"
#include "mapdelta/server/map_service.hpp"
#include "server_backends.hpp"

#include <httplib.h>  // last: its <resolv.h> defines macros that break Eigen

namespace mapdelta::server {

using namespace mapdelta::testing;  // NOLINT: the shared test scene

inline ServerConfig TestConfig(const std::string& db) {
  ServerConfig c;
  c.http.port = 0;
  c.http.threads = 4;
  c.http.max_body_bytes = 64 * 1024;
  c.storage.database = db;
  c.storage.tile_size_m = 20;
  c.pipeline.max_depth_m = kMaxDepth;
  c.pipeline.free_space_depth_m = 20;
  c.pipeline.pixel_stride = 1;
  c.classify.th_ch_m = 2.4;  // the reference evaluation's value
  return c;
}

class HttpServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    log::SetLevel(log::Level::kWarn);
    dir_ = std::filesystem::temp_directory_path() / ("mds_http_" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
    ServerConfig config = TestConfig("");
    UseFreshDatabase(Backend(), dir_, &config);
    service_ = std::make_unique<MapService>(config, OpenConfiguredStorage(config));
    admin_ = "Bearer " + CreateToken(service_->storage(), "admin", Role::kAdmin, NowMs()).secret;
    vehicle_ = "Bearer " + CreateToken(service_->storage(), "car", Role::kVehicle, NowMs()).secret;
    reader_ = "Bearer " + CreateToken(service_->storage(), "viewer", Role::kReader, NowMs()).secret;
    http_ = std::make_unique<HttpServer>(*service_);
    BeforeRun(*http_);
    port_ = http_->Bind("127.0.0.1", 0);
    service_->StartJobWorker();
    thread_ = std::thread([this] { http_->Run(); });
    client_ = std::make_unique<httplib::Client>("127.0.0.1", port_);
    client_->set_read_timeout(60, 0);
    for (int i = 0; i < 100 && !client_->Get("/health"); ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  void TearDown() override {
    service_->StopJobWorker();
    http_->Stop();
    thread_.join();
    http_.reset();
    service_.reset();
    std::filesystem::remove_all(dir_);
  }

  // The storage backend (one of kServerBackends); parameterized suites return their parameter.
  virtual std::string Backend() const { return "sqlite"; }

  // Lets a test set up the server (e.g. mount a web root) before it starts serving.
  virtual void BeforeRun(HttpServer&) {}

  httplib::Headers H(const std::string& auth) { return {{"Authorization", auth}}; }

  // Status and parsed JSON body of a response (error bodies must be JSON too).
  std::pair<int, Json> Call(const httplib::Result& r) {
    EXPECT_TRUE(r) << "no response";
    if (!r) return {0, Json()};
    Json body;
    if (r->get_header_value("Content-Type").rfind("application/json", 0) == 0)
      body = Json::parse(r->body);
    if (r->status >= 400) {
      EXPECT_TRUE(body.contains("error")) << r->body;
      EXPECT_TRUE(body["error"].contains("code"));
    }
    return {r->status, body};
  }

  std::filesystem::path dir_;
  std::unique_ptr<MapService> service_;
  std::unique_ptr<HttpServer> http_;
  std::unique_ptr<httplib::Client> client_;
  std::thread thread_;
  int port_ = 0;
  std::string admin_, vehicle_, reader_;
};

}  // namespace mapdelta::server
