#pragma once
// One MapService on a throw-away SQLite database in /dev/shm (no fsync cost per accepted
// input), shared by every input of a fuzz run, with one open session whose camera is small
// (64x48) so that a PNG that passes validation decodes quickly. The job worker is not started:
// the targets exercise request validation, not jobs.
#include <unistd.h>

#include <filesystem>
#include <memory>
#include <string>

#include "mapdelta/common/log.hpp"
#include "mapdelta/server/map_service.hpp"

namespace mapdelta::fuzz {

class ServiceFixture {
 public:
  static constexpr int kWidth = 64;
  static constexpr int kHeight = 48;

  static ServiceFixture& Get() {
    static ServiceFixture fixture;
    return fixture;
  }
  server::MapService& service() { return *service_; }
  int64_t session_id() const { return session_id_; }

  ~ServiceFixture() {
    service_.reset();
    std::error_code ignored;
    std::filesystem::remove_all(dir_, ignored);
  }

 private:
  ServiceFixture() {
    log::SetLevel(log::Level::kError);  // rejected inputs are the point, not news
    const std::filesystem::path shm = std::filesystem::exists("/dev/shm") ? "/dev/shm" : "/tmp";
    dir_ = shm / ("mapdelta-fuzz-" + std::to_string(getpid()));
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
    server::ServerConfig config;
    config.storage.database = (dir_ / "db.sqlite").string();
    service_ = std::make_unique<server::MapService>(
        config, server::OpenSqliteStorage(config.storage.database));
    const server::Json camera{{"width", kWidth}, {"height", kHeight}, {"fx", 40},
                              {"fy", 40},        {"cx", kWidth / 2},  {"cy", kHeight / 2}};
    session_id_ =
        service_->CreateSession({{"vehicle_id", "fuzz"}, {"camera", camera}})["session_id"];
  }

  std::filesystem::path dir_;
  std::unique_ptr<server::MapService> service_;
  int64_t session_id_ = 0;
};

}  // namespace mapdelta::fuzz
