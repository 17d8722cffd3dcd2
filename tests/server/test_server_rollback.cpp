// The rollback admin job through the facade, on the in-memory storage, SQLite and PostgreSQL
// (whose jobs tables need migration 004 for the job type): version latest + 1 reads exactly as the
// older version, is recorded with source "rollback", its parent and the cause, and every
// earlier version stays readable; bad requests are refused before a job is queued.
#include <gtest/gtest.h>
#include <sqlite3.h>
#include <unistd.h>

#include <array>
#include <filesystem>
#include <limits>
#include <set>

#include "blob_codec.hpp"
#include "changed_scene.hpp"
#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/server/map_service.hpp"
#include "mapdelta/server/memory_storage.hpp"
#include "mapdelta/server/storage.hpp"
#include "migrations.hpp"
#include "prior_points.hpp"
#include "server_backends.hpp"

namespace mapdelta::server {
namespace {

namespace fs = std::filesystem;
using testing::PointSet;
using testing::PriorPoints;

class Rollback : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    log::SetLevel(log::Level::kWarn);
    dir_ = fs::temp_directory_path() / ("mds_rollback_" + GetParam() + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    config_.storage.tile_size_m = 20;
    if (GetParam() == "memory") {
      service_ = std::make_unique<MapService>(config_, OpenMemoryStorage());
    } else {
      mapdelta::testing::UseFreshDatabase(GetParam(), dir_, &config_);
      service_ = std::make_unique<MapService>(config_, OpenConfiguredStorage(config_));
    }
  }
  void TearDown() override {
    service_.reset();
    fs::remove_all(dir_);
  }
  // Imports a scene's surface samples as the next prior version.
  void Import(const testing::BoxScene& scene, const std::string& name) {
    const fs::path file = dir_ / (name + ".pcd");
    WriteCloud(file.string(), scene.Sample(0.5));
    service_->ImportPriorFile(file.string(), name);
  }
  void ExpectRefused(const Json& body, ApiCode code) {
    const size_t jobs = service_->ListJobs(1, 100)["jobs"].size();
    try {
      service_->CreateJob(body);
      ADD_FAILURE() << "accepted " << body.dump();
    } catch (const ApiError& e) {
      EXPECT_EQ(e.code(), code) << body.dump() << ": " << e.what();
    }
    EXPECT_EQ(service_->ListJobs(1, 100)["jobs"].size(), jobs);
  }

  fs::path dir_;
  ServerConfig config_;
  std::unique_ptr<MapService> service_;
};

TEST_P(Rollback, NewVersionIsACopyOfTheOlderOneWithItsCause) {
  Import(testing::PriorScene(), "prior");
  Import(testing::ChangedScene(), "changed");
  const PointSet v1 = PriorPoints(*service_, 1), v2 = PriorPoints(*service_, 2);
  ASSERT_NE(v1, v2);  // box A removed, box C added (and tiles only C reaches)

  const Json job =
      service_->CreateJob({{"type", "rollback"}, {"version", 1}, {"cause", "bad refresh"}});
  EXPECT_EQ(job["type"], "rollback");
  service_->RunQueuedJobsNow();
  const Json done = service_->GetJob(job["job_id"]);
  ASSERT_EQ(done["state"], "succeeded") << done.dump();
  EXPECT_EQ(done["result"]["prior_version"], 3);
  EXPECT_EQ(done["result"]["copy_of"], 1);

  EXPECT_EQ(PriorPoints(*service_, 3), v1);  // tiles only v2 had read as empty at v3
  EXPECT_EQ(PriorPoints(*service_, 2), v2);  // history kept
  EXPECT_EQ(PriorPoints(*service_, 1), v1);
  const Json versions = service_->ListPriorVersions()["versions"];
  ASSERT_EQ(versions.size(), 3u);
  const Json& v3 = versions[2];
  EXPECT_EQ(v3["source"], "rollback");
  EXPECT_EQ(v3["parent"], 2);
  EXPECT_EQ(v3["job_id"], job["job_id"]);
  EXPECT_NE(v3["note"].get<std::string>().find("copy of version 1, bad refresh"), std::string::npos)
      << v3.dump();

  // Rolling forward again (to v2) is a rollback like any other: v4 reads as v2.
  service_->CreateJob({{"type", "rollback"}, {"version", 2}});
  service_->RunQueuedJobsNow();
  EXPECT_EQ(PriorPoints(*service_, 4), v2);
}

TEST_P(Rollback, BadRequestsQueueNothing) {
  ExpectRefused({{"type", "rollback"}, {"version", 1}}, ApiCode::kNoPrior);
  Import(testing::PriorScene(), "prior");
  Import(testing::ChangedScene(), "changed");
  ExpectRefused({{"type", "rollback"}}, ApiCode::kInvalidArgument);                    // no version
  ExpectRefused({{"type", "rollback"}, {"version", "1"}}, ApiCode::kInvalidArgument);  // a string
  ExpectRefused({{"type", "rollback"}, {"version", 3}}, ApiCode::kNotFound);
  ExpectRefused({{"type", "rollback"}, {"version", 0}}, ApiCode::kNotFound);
  ExpectRefused({{"type", "rollback"}, {"version", 2}}, ApiCode::kInvalidArgument);  // current
  ExpectRefused({{"type", "rollback"}, {"version", 1}, {"bbox", {0, 0, 1, 1}}},
                ApiCode::kInvalidArgument);
  ExpectRefused({{"type", "rollback"}, {"version", 1}, {"cause", ""}}, ApiCode::kInvalidArgument);
  ExpectRefused({{"type", "refresh"}, {"version", 1}, {"bbox", {0, 0, 1, 1}}},
                ApiCode::kInvalidArgument);
  EXPECT_EQ(service_->storage().priors().LatestVersion(), 2);
}

// A database made by the previous release (schema 3) keeps its jobs, their leases and their
// tiles through 004's rebuild of the jobs table, and then takes rollback jobs.
TEST(RollbackMigration, SqliteAtVersion3KeepsItsJobsAndTheirTiles) {
  log::SetLevel(log::Level::kWarn);
  const fs::path path =
      fs::temp_directory_path() / ("mds_rollback_v3_" + std::to_string(::getpid()) + ".sqlite");
  fs::remove(path);
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  auto exec = [&](const std::string& sql) {
    char* error = nullptr;
    ASSERT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &error), SQLITE_OK)
        << (error ? error : "") << " in: " << sql.substr(0, 200);
  };
  exec("PRAGMA foreign_keys=ON");
  exec(
      "CREATE TABLE schema_migrations (version INTEGER PRIMARY KEY, name TEXT NOT NULL, "
      "applied_ms INTEGER NOT NULL)");
  for (const Migration& m : EmbeddedMigrations()) {
    if (m.version > 3) break;
    exec(std::string(m.sql));
    exec("INSERT INTO schema_migrations VALUES (" + std::to_string(m.version) + ", '" +
         std::string(m.name) + "', 0)");
  }
  exec(
      "INSERT INTO jobs (id, type, state, params_json, created_ms, lease_owner, "
      "lease_expires_ms) VALUES (7, 'commit', 'running', '{\"session_id\":1}', 5, 'host:1:ab', "
      "99)");
  exec("INSERT INTO job_tiles VALUES (7, '0_0'), (7, '1_-2')");
  sqlite3_close(db);

  ServerConfig config;
  MapService service(config, OpenSqliteStorage(path.string()));
  const auto job = service.storage().jobs().Get(7);
  ASSERT_TRUE(job);
  EXPECT_EQ(job->type, JobType::kCommit);
  EXPECT_EQ(job->params_json, "{\"session_id\":1}");
  EXPECT_EQ(service.storage().jobs().TilesDone(7), (std::set<std::string>{"0_0", "1_-2"}));
  const int64_t rollback =
      service.storage().jobs().Create(JobType::kRollback, "{\"version\":1}", 6);
  EXPECT_EQ(service.storage().jobs().Get(rollback)->type, JobType::kRollback);
  fs::remove(path);
}

INSTANTIATE_TEST_SUITE_P(Backends, Rollback, ::testing::Values("memory", "sqlite", "postgres"),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace mapdelta::server
