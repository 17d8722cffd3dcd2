// Limits on what a request (or a damaged stored blob) can make the server allocate or compute,
// each found while fuzzing or load-testing (tests/fuzz, bench/load.sh): JSON nesting depth,
// page numbers whose offset overflows, a blob header claiming more than deflate can expand to,
// coordinates too large for voxel and tile indices (a pose from fuzz_keyframe_meta, prior points).
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "api_json.hpp"
#include "blob_codec.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/server/map_service.hpp"

namespace mapdelta::server {
namespace {

ApiCode CodeOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const ApiError& e) {
    return e.code();
  }
  ADD_FAILURE() << "no ApiError thrown";
  return ApiCode::kInternal;
}

TEST(ParseApiJson, AcceptsRequestsAndRefusesDeepNestingBeforeBuildingIt) {
  const Json ok =
      ParseApiJson(R"({"t_ns":1,"T_map_cam":{"t":[0,0,0],"q":[1,0,0,0]}})", "part 'meta'");
  EXPECT_EQ(ok["T_map_cam"]["q"][0], 1);
  const std::string at_cap = std::string(kMaxJsonDepth, '[') + std::string(kMaxJsonDepth, ']');
  EXPECT_TRUE(ParseApiJson(at_cap, "body").is_array());
  // 1 MiB of '[' (the JSON body limit): refused, with the part named in the message.
  const std::string deep(1 << 20, '[');
  try {
    ParseApiJson(deep, "part 'meta'");
    FAIL() << "deep JSON accepted";
  } catch (const ApiError& e) {
    EXPECT_EQ(e.code(), ApiCode::kInvalidJson);
    EXPECT_NE(std::string(e.what()).find("part 'meta' nests deeper than 32"), std::string::npos)
        << e.what();
  }
  const std::string one_too_deep =
      std::string(kMaxJsonDepth + 1, '[') + std::string(kMaxJsonDepth + 1, ']');
  EXPECT_EQ(CodeOf([&] { ParseApiJson(one_too_deep, "body"); }), ApiCode::kInvalidJson);
  EXPECT_EQ(CodeOf([&] { ParseApiJson("{\"a\":", "body"); }), ApiCode::kInvalidJson);
}

TEST(MapService, PagesWhoseOffsetWouldOverflowAreRefused) {
  log::SetLevel(log::Level::kWarn);
  const auto dir =
      std::filesystem::temp_directory_path() / ("mds_limits_" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  {
    ServerConfig config;
    config.storage.database = (dir / "db.sqlite").string();
    MapService service(config, OpenSqliteStorage(config.storage.database));
    EXPECT_EQ(service.ListJobs(1, 50)["jobs"].size(), 0u);
    EXPECT_EQ(service.ListChangedTiles("-10,-10,10,10", 0.0, 1000000000, 1000)["tiles"].size(), 0u);
    // (page - 1) * page_size would not fit in int64 (9223372036854775807 / 1000 + 2).
    EXPECT_EQ(CodeOf([&] { service.ListJobs(9223372036854777LL, 1000); }),
              ApiCode::kInvalidArgument);
    EXPECT_EQ(CodeOf([&] { service.ListChangedTiles("-10,-10,10,10", 0.0, 1000000001, 1); }),
              ApiCode::kInvalidArgument);
    // A prior point beyond +-1e8 m would overflow the tile index: refused, nothing imported.
    const std::string far_pcd =
        "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 2\nHEIGHT 1\n"
        "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\nDATA ascii\n1 2 3\n1e30 0 0\n";
    EXPECT_EQ(
        CodeOf([&] { service.ImportPrior(Bytes(far_pcd.begin(), far_pcd.end()), "pcd", ""); }),
        ApiCode::kInvalidArgument);
    EXPECT_EQ(service.ListPriorVersions()["versions"].size(), 0u);
  }
  std::filesystem::remove_all(dir);
}

TEST(PoseFromJson, TranslationsBeyondTheMapAreRefusedBeforeVoxelArithmetic) {
  // The fuzz finding (tests/fuzz/regressions/fuzz_keyframe_meta/translation_2e35.json): z = 2e35
  // was accepted and the keyframe cloud's voxel filter cast 2.8e35 to int64 (undefined).
  const Json far =
      Json::parse(R"({"t":[0,0,222222222222222222222222222222222221.5],"q":[1,0,0,0]})");
  EXPECT_EQ(CodeOf([&] { PoseFromJson(far, "T_map_cam"); }), ApiCode::kInvalidPose);
  const Json edge = Json::parse(R"({"t":[-1e8,1e8,0],"q":[1,0,0,0]})");
  EXPECT_EQ(PoseFromJson(edge, "T_map_cam").translation().x(), -1e8);
  const Json beyond = Json::parse(R"({"t":[1.0000001e8,0,0],"q":[1,0,0,0]})");
  EXPECT_EQ(CodeOf([&] { PoseFromJson(beyond, "T_map_cam"); }), ApiCode::kInvalidPose);
}

TEST(ServerConfig, AKeyThatIsNotANameIsReportedNotAnAbort) {
  // tests/fuzz/regressions/fuzz_server_config/complex_key.yaml, shortened: "? threads: 8" is a
  // mapping used as a key; the old reader's destructor threw on it and the process aborted. The
  // shared strict reader (common config_reader) names such a key "?" among the unknown keys.
  const auto path =
      std::filesystem::temp_directory_path() / ("mds_cfg_" + std::to_string(getpid()) + ".yaml");
  std::ofstream(path) << "http:\n  port: 8080\n  ? threads: 8\n";
  try {
    LoadServerConfig(path.string());
    FAIL() << "a complex key was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);  // config problems exit 2, as usage errors
    EXPECT_NE(std::string(e.what()).find("http.?: unknown key"), std::string::npos) << e.what();
  }
  std::filesystem::remove(path);
}

TEST(BlobCodec, AHeaderClaimingMoreThanDeflateCanExpandToIsRefusedBeforeAllocating) {
  PointCloud cloud(1000, Point(1.f, 2.f, 3.f));
  Bytes blob = EncodePoints(cloud);
  EXPECT_EQ(DecodePoints(blob).size(), 1000u);  // 12 kB of equal points: a high ratio, still fine
  // The raw size field (bytes 7..14) claims 4 GiB: the old decoder allocated that first.
  const uint64_t claim = uint64_t{1} << 32;
  std::memcpy(blob.data() + 7, &claim, sizeof(claim));
  try {
    DecodePoints(blob);
    FAIL() << "a 4 GiB claim was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kParse);
    EXPECT_NE(std::string(e.what()).find("claims 4294967296 bytes"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace mapdelta::server
