// Server pieces without a socket: stored-blob formats, config loading, schema versioning,
// and job cancellation through the MapService facade.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "blob_codec.hpp"
#include "mapdelta/common/depth_image.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/common/observed_area.hpp"
#include "mapdelta/server/config.hpp"
#include "mapdelta/server/map_service.hpp"
#include "mapdelta/server/memory_storage.hpp"
#include "schema_migrator.hpp"
#include "sqlite_db.hpp"

namespace mapdelta::server {
namespace {

namespace fs = std::filesystem;

fs::path TempDir(const std::string& name) {
  const fs::path d =
      fs::temp_directory_path() / ("mds_core_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

TEST(BlobCodec, RoundTripsAndRejectsCorruption) {
  const PointCloud cloud = {Point(1, 2, 3), Point(-4.5f, 0.25f, 1e6f)};
  EXPECT_EQ(DecodePoints(EncodePoints(cloud)), cloud);
  TileAggregate agg;
  agg[{1, -2, 3}] = AggregateVoxel{Point(0.5f, 0.5f, 0.5f), 7, 4, {3, 9}};
  const TileAggregate back = DecodeAggregate(EncodeAggregate(agg));
  ASSERT_EQ(back.size(), 1u);
  EXPECT_EQ(back.begin()->first, (VoxelKey{1, -2, 3}));
  EXPECT_EQ(back.begin()->second.point_count, 7u);
  EXPECT_EQ(back.begin()->second.keyframes, 4u);
  EXPECT_EQ(back.begin()->second.sessions, (std::vector<int64_t>{3, 9}));
  std::vector<ChangePoint> changes(1);
  changes[0].position = Point(1, 1, 1);
  changes[0].kind = ChangeKind::kRemoved;
  changes[0].confidence = 0.75f;
  changes[0].observed_by = {1, 2};
  changes[0].supported_by = {2};
  const auto c = DecodeChanges(EncodeChanges(changes));
  ASSERT_EQ(c.size(), 1u);
  EXPECT_EQ(c[0].kind, ChangeKind::kRemoved);
  EXPECT_EQ(c[0].observed_by, (std::vector<int64_t>{1, 2}));
  EXPECT_EQ(c[0].supported_by, (std::vector<int64_t>{2}));

  Bytes blob = EncodePoints(cloud);
  Bytes flipped = blob;
  flipped.back() ^= 0x5a;  // inside the zlib stream
  EXPECT_THROW(DecodePoints(flipped), Error);
  Bytes truncated(blob.begin(), blob.begin() + 10);
  EXPECT_THROW(DecodePoints(truncated), Error);
  EXPECT_THROW(DecodeAggregate(blob), Error);  // wrong kind
  Bytes future = blob;
  future[5] = 99;  // format version
  EXPECT_THROW(DecodePoints(future), Error);
}

// A small real octree: one keyframe of a wall 5 m ahead of an 8x6 camera.
std::string SmallOctreeBinary() {
  PinholeCamera camera;
  camera.width = 8;
  camera.height = 6;
  camera.fx = camera.fy = 4;
  camera.cx = 4;
  camera.cy = 3;
  DepthImage depth(8, 6);
  for (int v = 0; v < 6; ++v) {
    for (int u = 0; u < 8; ++u) depth.at(u, v) = 5.f;
  }
  ObservedArea area(0.8);
  area.InsertKeyframe(camera, SE3::Identity(), depth, ObservedAreaParams{});
  return area.SerializeBinary();
}

// Coverage bitsets (coverage.hpp): sizes that are not multiples of 64, the empty set, OR and
// count, and the checks a damaged blob must fail.
TEST(BlobCodec, PointBitsRoundTripAndForeignBitsAreRefused) {
  PointBits bits(130);
  for (size_t i : {size_t{0}, size_t{63}, size_t{64}, size_t{129}}) bits.Set(i);
  const PointBits back = DecodePointBits(EncodePointBits(bits));
  EXPECT_EQ(back.size(), 130u);
  EXPECT_EQ(back.words(), bits.words());
  EXPECT_EQ(back.Count(), 4u);
  EXPECT_TRUE(back.Test(129));
  EXPECT_FALSE(back.Test(128));
  EXPECT_EQ(DecodePointBits(EncodePointBits(PointBits(0))).size(), 0u);

  PointBits other(130);
  other.Set(1);
  other.Set(64);
  other.Or(bits);
  EXPECT_EQ(other.Count(), 5u);  // {0, 1, 63, 64, 129}
  EXPECT_THROW(other.Or(PointBits(129)), Error);

  // 130 bits take 3 words; a bit past the end (bit 133) or a wrong word count is damage.
  EXPECT_THROW(PointBits::FromWords(130, {0, 0, uint64_t{1} << 5}), Error);
  EXPECT_THROW(PointBits::FromWords(130, {0, 0}), Error);
  EXPECT_EQ(PointBits::FromWords(130, {0, 0, uint64_t{1} << 1}).Count(), 1u);

  Bytes blob = EncodePointBits(bits);
  Bytes flipped = blob;
  flipped.back() ^= 0x40;
  EXPECT_THROW(DecodePointBits(flipped), Error);
  EXPECT_THROW(DecodePointBits(Bytes(blob.begin(), blob.begin() + 15)), Error);
  EXPECT_THROW(DecodePoints(blob), Error);                               // another kind
  EXPECT_THROW(DecodePointBits(EncodePoints({Point(1, 2, 3)})), Error);  // and the other way
}

TEST(BlobCodec, SessionOctreesRoundTripAndCorruptionIsRefused) {
  const std::string octree = SmallOctreeBinary();
  ASSERT_GT(ObservedArea::DeserializeBinary(octree).NumKnownLeaves(), 0u);
  const Bytes blob = EncodeObserved(octree);
  ASSERT_EQ(std::string(blob.begin(), blob.begin() + 4), "MDB1");
  EXPECT_EQ(DecodeObserved(blob), octree);

  Bytes flipped = blob;
  flipped[flipped.size() / 2 + 10] ^= 0x01;  // inside the zlib stream
  EXPECT_THROW(DecodeObserved(flipped), Error);
  Bytes crc = blob;
  crc[4 + 1 + 2 + 8] ^= 0x01;  // the stored CRC-32: the payload decompresses but does not match
  try {
    DecodeObserved(crc);
    FAIL() << "checksum mismatch accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("checksum"), std::string::npos) << e.what();
  }
  EXPECT_THROW(DecodeObserved(Bytes(blob.begin(), blob.begin() + 12)), Error);
  EXPECT_THROW(DecodeObserved(EncodePoints({Point(1, 2, 3)})), Error);  // another kind
  Bytes future = blob;
  future[5] = 99;  // format version
  try {
    DecodeObserved(future);
    FAIL() << "unknown format version accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kUnsupported);
  }
  EXPECT_THROW(DecodeObserved(Bytes{'n', 'o', 't', ' ', 'a', 'n', ' ', 'o', 'c', 't',
                                    'r', 'e', 'e', 0,   0,   0,   0,   0,   0,   0}),
               Error);
  // A database written before octrees went through the codec holds the bare OctoMap stream.
  EXPECT_EQ(DecodeObserved(Bytes(octree.begin(), octree.end())), octree);
}

TEST(Config, ReportsEveryProblemAtOnceAndLoadsTheExample) {
  const fs::path d = TempDir("config");
  std::ofstream(d / "bad.yaml")
      << "http:\n  prot: 1\n  threads: many\n  observed_cache_bytes: -1\nstorage:\n"
      << "  tile_size_m: -3\nextra: 1\n";
  try {
    LoadServerConfig((d / "bad.yaml").string());
    FAIL() << "bad config accepted";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("5 problem(s)"), std::string::npos) << m;
    for (const char* key :
         {"http.prot: unknown key", "http.threads: expected an integer, got 'many'",
          "http.observed_cache_bytes: -1 is outside", "storage.tile_size_m: -3 is outside",
          "extra: unknown section"}) {
      EXPECT_NE(m.find(key), std::string::npos) << key << " missing in: " << m;
    }
  }
  const ServerConfig example =
      LoadServerConfig(std::string(MAPDELTA_SOURCE_DIR) + "/config/server.example.yaml");
  EXPECT_EQ(example.http.port, 8080);
  EXPECT_EQ(example.http.observed_cache_bytes, int64_t{64} << 20);  // as the example says
  EXPECT_DOUBLE_EQ(example.classify.th_ch_m, 3.2);
  // The effective config echoed at start-up is itself a valid config file.
  std::ofstream(d / "echo.yaml") << DumpServerConfig(example);
  EXPECT_EQ(LoadServerConfig((d / "echo.yaml").string()).storage.database,
            example.storage.database);
  fs::remove_all(d);
}

TEST(Storage, RefusesASchemaNewerThanItKnows) {
  const fs::path d = TempDir("schema");
  const std::string db = (d / "db.sqlite").string();
  { OpenSqliteStorage(db); }
  {
    sql::Db raw(db);
    raw.Exec("INSERT INTO schema_migrations VALUES (999, '999_future', 0)");
  }
  try {
    OpenSqliteStorage(db);
    FAIL() << "newer schema accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kUnsupported);
    EXPECT_NE(std::string(e.what()).find("999"), std::string::npos);
  }
  fs::remove_all(d);
}

// A backend's side of the migrator, recording what it was asked to do.
class RecordingSchemaTarget final : public SchemaTarget {
 public:
  explicit RecordingSchemaTarget(int64_t version) : version_(version) {}
  int64_t AppliedVersion() override { return version_; }
  void Apply(const Migration& m) override {
    applied.push_back(m.version);
    version_ = m.version;
  }
  std::vector<int> applied;

 private:
  int64_t version_;
};

TEST(SchemaMigrator, AppliesOnlyNewerMigrationsInOrderAndRefusesANewerDatabase) {
  const std::vector<Migration> migrations = {
      {1, "001_a", "A"}, {2, "002_b", "B"}, {3, "003_c", "C"}};
  RecordingSchemaTarget fresh(0), partial(2), current(3), future(4);
  EXPECT_EQ(MigrateSchema(fresh, migrations), 3);
  EXPECT_EQ(fresh.applied, (std::vector<int>{1, 2, 3}));
  EXPECT_EQ(MigrateSchema(partial, migrations), 1);
  EXPECT_EQ(partial.applied, (std::vector<int>{3}));
  EXPECT_EQ(MigrateSchema(current, migrations), 0);
  try {
    MigrateSchema(future, migrations);
    FAIL() << "newer schema accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kUnsupported);
    EXPECT_NE(std::string(e.what()).find("version 4 is newer than this server knows (3)"),
              std::string::npos)
        << e.what();
  }
  EXPECT_TRUE(future.applied.empty());
  EXPECT_EQ(KnownSchemaVersion(), NewestVersion(EmbeddedMigrations()));
  EXPECT_GE(KnownSchemaVersion(), 2);
}

TEST(MapService, CancelAQueuedCommitReopensTheSessionAndFinishedJobsRefuse) {
  log::SetLevel(log::Level::kWarn);
  ServerConfig config;
  MapService service(config, OpenMemoryStorage());
  const Json camera{{"width", 8}, {"height", 6}, {"fx", 4}, {"fy", 4}, {"cx", 4}, {"cy", 3}};
  const int64_t s = service.CreateSession({{"vehicle_id", "v"}, {"camera", camera}})["session_id"];
  EXPECT_THROW(service.CommitSession(s), ApiError);  // no keyframes yet
  DepthImage depth(8, 6);
  depth.at(1, 1) = 5.f;
  const auto png = EncodeDepthPng(depth);
  bool stored = false;
  const Json meta{{"t_ns", 1}, {"T_map_cam", {{"t", {0, 0, 0}}, {"q", {1, 0, 0, 0}}}}};
  service.PutKeyframe(s, 0, meta, Bytes(png.begin(), png.end()), &stored);
  ASSERT_TRUE(stored);
  const int64_t job = service.CommitSession(s)["job_id"];
  EXPECT_EQ(service.CancelJob(job)["state"], "cancelled");
  EXPECT_EQ(service.GetSession(s)["state"], "open");
  try {
    service.CancelJob(job);
    FAIL();
  } catch (const ApiError& e) {
    EXPECT_EQ(e.code(), ApiCode::kJobNotCancellable);
  }
  // Committing again works and the job runs to success (no prior: everything is new).
  const int64_t job2 = service.CommitSession(s)["job_id"];
  service.RunQueuedJobsNow();
  const Json j = service.GetJob(job2);
  EXPECT_EQ(j["state"], "succeeded") << j.dump();
  EXPECT_EQ(j["result"]["registration"]["status"], "skipped");
  EXPECT_EQ(service.GetSession(s)["state"], "committed");
}

}  // namespace
}  // namespace mapdelta::server
