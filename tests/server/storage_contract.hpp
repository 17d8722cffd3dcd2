#pragma once
// The fixture of the storage contract suite: every TEST_P runs once per backend in
// StorageBackends(), each time on a fresh, empty storage.
#include <gtest/gtest.h>

#include <filesystem>
#include <memory>
#include <string>

#include "mapdelta/common/error.hpp"
#include "mapdelta/server/storage.hpp"
#include "storage_backends.hpp"
#include "support/temp_dir.hpp"

namespace mapdelta::server::testing {

// The lease of job claims in the contract tests: long enough that no claim lapses unless a
// test moves the clock past it on purpose.
inline constexpr int64_t kLeaseMs = 1000;

class StorageContract : public ::testing::TestWithParam<StorageBackend> {
 protected:
  void SetUp() override {
    scratch_ = mapdelta::testing::FreshTempDir("mds_contract_" + GetParam().name);
    storage_ = GetParam().open(scratch_);
  }
  void TearDown() override {
    storage_.reset();
    std::filesystem::remove_all(scratch_);
  }
  Storage& s() { return *storage_; }

  // A session with a 2x2 camera (the stores do not look at it).
  int64_t NewSession(const std::string& vehicle = "car", int64_t created_ms = 100) {
    SessionRecord r;
    r.vehicle_id = vehicle;
    r.camera_json = R"({"width":2})";
    r.depth_scale = 500.0;
    r.created_ms = created_ms;
    return s().sessions().Create(r);
  }

  static KeyframeRecord Keyframe(int64_t seq, int64_t t_ns, const std::string& sha = "") {
    KeyframeRecord k;
    k.seq = seq;
    k.t_ns = t_ns;
    k.pose_json = "pose" + std::to_string(seq);
    k.depth_png = Bytes{1, 2, static_cast<uint8_t>(seq)};
    k.content_sha = sha.empty() ? "sha" + std::to_string(seq) : sha;
    k.cloud = Bytes{9, static_cast<uint8_t>(seq)};
    k.cloud_params = "params";
    return k;
  }

  static PriorTileRecord PriorTile(int32_t ix, int32_t iy, int64_t points) {
    PriorTileRecord t;
    t.tile = TileId(ix, iy);
    t.point_count = points;
    t.points = Bytes(static_cast<size_t>(points) + 1, static_cast<uint8_t>(ix * 16 + iy));
    return t;
  }

  static PriorVersionRecord Import(int64_t created_ms, const std::string& note = "") {
    PriorVersionRecord v;
    v.created_ms = created_ms;
    v.source = PriorSource::kImport;
    v.note = note;
    return v;
  }

  static TileChangesRecord Changes(int32_t ix, int32_t iy, int64_t added, int64_t removed,
                                   double confidence) {
    TileChangesRecord c;
    c.tile = TileId(ix, iy);
    c.prior_version = 1;
    c.new_count = added;
    c.removed_count = removed;
    c.max_confidence = confidence;
    c.changes = Bytes{7, static_cast<uint8_t>(added)};
    c.params_json = R"({"th_ch_m":3.2})";
    c.updated_ms = 40 + ix;
    return c;
  }

  static TileStateRecord State(int32_t ix, int32_t iy, std::set<int64_t> sessions, uint8_t tag) {
    TileStateRecord st;
    st.tile = TileId(ix, iy);
    st.aggregate = Bytes{tag, tag, 3};
    st.sessions = std::move(sessions);
    return st;
  }

 private:
  std::filesystem::path scratch_;
  std::unique_ptr<Storage> storage_;
};

// Runs fn and expects it to throw mapdelta::Error with the given code.
template <typename Fn>
void ExpectError(ErrorCode code, Fn&& fn) {
  try {
    fn();
    ADD_FAILURE() << "expected Error(" << ToString(code) << "), nothing thrown";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), code) << e.what();
  }
}

}  // namespace mapdelta::server::testing
