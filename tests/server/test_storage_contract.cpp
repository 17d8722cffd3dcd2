// The storage contract, part 1: tokens, the prior map, sessions and keyframes. Every backend in
// StorageBackends() must pass it (part 2: test_storage_contract_jobs_tiles.cpp).
#include "storage_contract.hpp"

namespace mapdelta::server::testing {
namespace {

INSTANTIATE_TEST_SUITE_P(Backends, StorageContract, ::testing::ValuesIn(StorageBackends()),
                         [](const auto& info) { return info.param.name; });

// ---------------------------------------------------------------- tokens

TEST_P(StorageContract, TokensAreFoundByHashUntilRevokedAndListedByCreation) {
  TokenStore& tokens = s().tokens();
  tokens.Insert({"id-late", "ops", Role::kAdmin, 20, std::nullopt}, "hash-a");
  tokens.Insert({"id-early", "car", Role::kVehicle, 10, std::nullopt}, "hash-b");
  const auto found = tokens.FindActiveByHash("hash-a");
  ASSERT_TRUE(found);
  EXPECT_EQ(found->id, "id-late");
  EXPECT_EQ(found->name, "ops");
  EXPECT_EQ(found->role, Role::kAdmin);
  EXPECT_EQ(found->created_ms, 20);
  EXPECT_FALSE(found->revoked_ms);
  EXPECT_FALSE(tokens.FindActiveByHash("hash-unknown"));

  EXPECT_TRUE(tokens.Revoke("id-late", 30));
  EXPECT_FALSE(tokens.Revoke("id-late", 31));  // already revoked
  EXPECT_FALSE(tokens.Revoke("id-none", 31));
  EXPECT_FALSE(tokens.FindActiveByHash("hash-a"));
  const auto listed = tokens.List();
  ASSERT_EQ(listed.size(), 2u);
  EXPECT_EQ(listed[0].id, "id-early");
  EXPECT_EQ(listed[0].role, Role::kVehicle);
  EXPECT_EQ(listed[1].id, "id-late");
  EXPECT_EQ(listed[1].revoked_ms, 30);
}

TEST_P(StorageContract, TokenWithATakenIdOrHashIsRefused) {
  s().tokens().Insert({"id", "a", Role::kReader, 1, std::nullopt}, "hash");
  ExpectError(ErrorCode::kConflict, [&] {
    s().tokens().Insert({"id", "b", Role::kReader, 2, std::nullopt}, "other");
  });
  ExpectError(ErrorCode::kConflict, [&] {
    s().tokens().Insert({"id2", "c", Role::kReader, 3, std::nullopt}, "hash");
  });
  ASSERT_EQ(s().tokens().List().size(), 1u);
  EXPECT_EQ(s().tokens().List()[0].name, "a");
}

// ---------------------------------------------------------------- prior map

TEST_P(StorageContract, PriorVersionsCountFromOneWithTheirParents) {
  PriorStore& priors = s().priors();
  EXPECT_FALSE(priors.LatestVersion());
  EXPECT_TRUE(priors.ListVersions().empty());
  EXPECT_EQ(priors.CreateVersion(Import(5, "first"), {PriorTile(0, 0, 3)}, true), 1);
  PriorVersionRecord second = Import(6, "second");
  second.job_id = 42;
  EXPECT_EQ(priors.CreateVersion(second, {PriorTile(0, 0, 4)}, false), 2);
  EXPECT_EQ(priors.LatestVersion(), 2);
  const auto versions = priors.ListVersions();
  ASSERT_EQ(versions.size(), 2u);
  EXPECT_EQ(versions[0].version, 1);
  EXPECT_FALSE(versions[0].parent);
  EXPECT_FALSE(versions[0].job_id);
  EXPECT_EQ(versions[0].note, "first");
  EXPECT_EQ(versions[0].source, PriorSource::kImport);
  EXPECT_EQ(versions[0].created_ms, 5);
  EXPECT_EQ(versions[1].version, 2);
  EXPECT_EQ(versions[1].parent, 1);
  EXPECT_EQ(versions[1].job_id, 42);
}

TEST_P(StorageContract, PriorTilesReadAsTheyWereAtOlderVersions) {
  PriorStore& priors = s().priors();
  priors.CreateVersion(Import(1), {PriorTile(0, 0, 3), PriorTile(1, 0, 5)}, true);
  priors.CreateVersion(Import(2), {PriorTile(0, 0, 8)}, /*replace_all=*/false);
  const auto a1 = priors.GetTile(TileId(0, 0), 1), a2 = priors.GetTile(TileId(0, 0), 2);
  ASSERT_TRUE(a1 && a2);
  EXPECT_EQ(a1->version, 1);
  EXPECT_EQ(a1->point_count, 3);
  EXPECT_EQ(a1->points, PriorTile(0, 0, 3).points);
  EXPECT_EQ(a2->version, 2);
  EXPECT_EQ(a2->points, PriorTile(0, 0, 8).points);
  const auto b2 = priors.GetTile(TileId(1, 0), 2);  // untouched by version 2: version 1's row
  ASSERT_TRUE(b2);
  EXPECT_EQ(b2->version, 1);
  EXPECT_EQ(b2->point_count, 5);
  EXPECT_FALSE(priors.GetTile(TileId(0, 0), 0));
  EXPECT_FALSE(priors.GetTile(TileId(7, 7), 2));
  EXPECT_EQ(priors.GetTile(TileId(0, 0), 99)->version, 2);  // later versions read the latest row
}

TEST_P(StorageContract, ReplaceAllEmptiesTheTilesItLeavesOut) {
  PriorStore& priors = s().priors();
  priors.CreateVersion(Import(1), {PriorTile(0, 0, 3), PriorTile(1, 0, 5)}, true);
  priors.CreateVersion(Import(2), {PriorTile(0, 0, 4)}, /*replace_all=*/true);
  const auto gone = priors.GetTile(TileId(1, 0), 2);
  ASSERT_TRUE(gone);
  EXPECT_EQ(gone->version, 2);
  EXPECT_EQ(gone->point_count, 0);
  EXPECT_TRUE(gone->points.empty());
  EXPECT_EQ(priors.GetTile(TileId(1, 0), 1)->point_count, 5);
  const Rect all{-10, -10, 10, 10};
  ASSERT_EQ(priors.ListTiles(all, 2).size(), 1u);  // empty rows are not listed
  EXPECT_EQ(priors.ListTiles(all, 1).size(), 2u);
  // A third import that leaves the emptied tile out again writes nothing more for it.
  priors.CreateVersion(Import(3), {PriorTile(0, 0, 4)}, true);
  EXPECT_EQ(priors.GetTile(TileId(1, 0), 3)->version, 2);
}

TEST_P(StorageContract, PriorTileListingFiltersByTileRectAndOrdersByIxThenIy) {
  s().priors().CreateVersion(Import(1),
                             {PriorTile(3, 3, 1), PriorTile(0, 0, 2), PriorTile(-1, 2, 3),
                              PriorTile(0, -1, 4), PriorTile(1, 0, 5), PriorTile(2, 0, 6)},
                             true);
  const auto listed = s().priors().ListTiles(Rect{-1, -1, 1, 2}, 1);
  std::vector<TileId> tiles;
  for (const auto& t : listed) {
    tiles.push_back(t.tile);
    EXPECT_TRUE(t.points.empty()) << "listings carry no points";
    EXPECT_EQ(t.version, 1);
    EXPECT_GT(t.point_count, 0);
  }
  EXPECT_EQ(tiles, (std::vector<TileId>{TileId(-1, 2), TileId(0, -1), TileId(0, 0), TileId(1, 0)}));
  EXPECT_EQ(listed[2].point_count, 2);
}

// ---------------------------------------------------------------- the map's frame

MapFrame Utm(double x, double y, double z) {
  return MapFrame{"EPSG:32632", Eigen::Vector3d(x, y, z)};
}

TEST_P(StorageContract, MapFrameIsSetByTheFirstVersionCarryingOneAndReadBackExactly) {
  PriorStore& priors = s().priors();
  EXPECT_FALSE(priors.Frame());
  priors.CreateVersion(Import(1), {PriorTile(0, 0, 3)}, true);  // a version without a frame
  EXPECT_FALSE(priors.Frame());
  PriorVersionRecord second = Import(2);
  // Not representable in float32, and a digit past what 15 significant digits keep.
  second.frame = Utm(500000.123456789, 5400000.987654321, 100.0000001);
  priors.CreateVersion(second, {PriorTile(0, 0, 4)}, true);
  const auto frame = priors.Frame();
  ASSERT_TRUE(frame);
  EXPECT_EQ(frame->crs, "EPSG:32632");
  EXPECT_EQ(frame->origin.x(), 500000.123456789);  // bit for bit: doubles in, doubles out
  EXPECT_EQ(frame->origin.y(), 5400000.987654321);
  EXPECT_EQ(frame->origin.z(), 100.0000001);
  PriorVersionRecord same = Import(3);
  same.frame = second.frame;
  EXPECT_EQ(priors.CreateVersion(same, {PriorTile(0, 0, 5)}, true), 3);
  EXPECT_EQ(priors.CreateVersion(Import(4), {PriorTile(0, 0, 6)}, true), 4);  // none: kept
  EXPECT_EQ(priors.Frame()->origin, second.frame->origin);
}

TEST_P(StorageContract, PriorVersionInADifferentFrameWritesNothing) {
  PriorStore& priors = s().priors();
  PriorVersionRecord first = Import(1);
  first.frame = Utm(500000, 5400000, 100);
  priors.CreateVersion(first, {PriorTile(0, 0, 3)}, true);
  for (const MapFrame& other :
       {Utm(500000.001, 5400000, 100), MapFrame{"EPSG:32633", first.frame->origin}}) {
    PriorVersionRecord second = Import(2);
    second.frame = other;
    ExpectError(ErrorCode::kConflict,
                [&] { priors.CreateVersion(second, {PriorTile(1, 1, 4)}, true); });
  }
  EXPECT_EQ(priors.LatestVersion(), 1);
  EXPECT_FALSE(priors.GetTile(TileId(1, 1), 5));
  EXPECT_EQ(priors.Frame()->crs, "EPSG:32632");
  EXPECT_EQ(priors.Frame()->origin, first.frame->origin);
}

TEST_P(StorageContract, PriorVersionWithATileTwiceWritesNothing) {
  s().priors().CreateVersion(Import(1), {PriorTile(0, 0, 3)}, true);
  ExpectError(ErrorCode::kConflict, [&] {
    s().priors().CreateVersion(Import(2),
                               {PriorTile(1, 1, 1), PriorTile(0, 0, 9), PriorTile(0, 0, 8)}, true);
  });
  EXPECT_EQ(s().priors().LatestVersion(), 1);
  EXPECT_EQ(s().priors().ListVersions().size(), 1u);
  EXPECT_FALSE(s().priors().GetTile(TileId(1, 1), 5));
  EXPECT_EQ(s().priors().GetTile(TileId(0, 0), 5)->point_count, 3);
}

// ---------------------------------------------------------------- sessions and keyframes

TEST_P(StorageContract, SessionsStartOpenWithIncreasingIds) {
  const int64_t a = NewSession("car-a", 100), b = NewSession("car-b", 200);
  EXPECT_GT(a, 0);
  EXPECT_GT(b, a);
  const auto r = s().sessions().Get(a);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->id, a);
  EXPECT_EQ(r->vehicle_id, "car-a");
  EXPECT_EQ(r->camera_json, R"({"width":2})");
  EXPECT_EQ(r->depth_scale, 500.0);
  EXPECT_EQ(r->state, SessionState::kOpen);
  EXPECT_EQ(r->created_ms, 100);
  EXPECT_EQ(r->keyframe_count, 0);
  EXPECT_EQ(r->last_t_ns, 0);
  EXPECT_FALSE(r->job_id || r->committed_ms || r->registration_json);
  EXPECT_FALSE(s().sessions().Get(b + 100));
}

TEST_P(StorageContract, KeyframeOutcomesAndOnlyStoredOnesCount) {
  SessionStore& sessions = s().sessions();
  const int64_t id = NewSession();
  EXPECT_EQ(sessions.PutKeyframe(id, Keyframe(0, 1000)), PutKeyframeOutcome::kStored);
  EXPECT_EQ(sessions.PutKeyframe(id, Keyframe(0, 1000)), PutKeyframeOutcome::kIdentical);
  EXPECT_EQ(sessions.PutKeyframe(id, Keyframe(0, 1000, "other")), PutKeyframeOutcome::kConflict);
  EXPECT_EQ(sessions.PutKeyframe(id, Keyframe(2, 3000)), PutKeyframeOutcome::kOutOfOrder);
  EXPECT_EQ(sessions.PutKeyframe(id, Keyframe(1, 1000)), PutKeyframeOutcome::kTimeNotIncreasing);
  EXPECT_EQ(sessions.PutKeyframe(id, Keyframe(1, 999)), PutKeyframeOutcome::kTimeNotIncreasing);
  EXPECT_EQ(sessions.PutKeyframe(id + 1, Keyframe(0, 1)), PutKeyframeOutcome::kNoSession);
  EXPECT_EQ(sessions.PutKeyframe(id, Keyframe(1, 2000)), PutKeyframeOutcome::kStored);
  auto r = sessions.Get(id);
  EXPECT_EQ(r->keyframe_count, 2);
  EXPECT_EQ(r->last_t_ns, 2000);

  ASSERT_TRUE(sessions.Commit(id, "{}", 5));
  EXPECT_EQ(sessions.PutKeyframe(id, Keyframe(2, 3000)), PutKeyframeOutcome::kSessionNotOpen);
  // A retry of a stored keyframe after the commit is still a harmless repeat.
  EXPECT_EQ(sessions.PutKeyframe(id, Keyframe(1, 2000)), PutKeyframeOutcome::kIdentical);
  EXPECT_EQ(sessions.PutKeyframe(id, Keyframe(1, 2000, "other")),
            PutKeyframeOutcome::kSessionNotOpen);
  EXPECT_EQ(sessions.Get(id)->keyframe_count, 2);
}

TEST_P(StorageContract, KeyframesAreReadBackInSeqOrderWithinTheRange) {
  SessionStore& sessions = s().sessions();
  const int64_t id = NewSession(), other = NewSession();
  for (int64_t seq = 0; seq < 5; ++seq) {
    KeyframeRecord k = Keyframe(seq, 100 * (seq + 1));
    if (seq == 2) k.covariance_json = "[1,0]";
    if (seq == 3) k.cloud.clear();  // no upload-time cloud: its parameters are not kept either
    ASSERT_EQ(sessions.PutKeyframe(id, k), PutKeyframeOutcome::kStored);
  }
  ASSERT_EQ(sessions.PutKeyframe(other, Keyframe(0, 1)), PutKeyframeOutcome::kStored);
  std::vector<KeyframeRecord> read;
  sessions.ForEachKeyframe(id, 1, 4, /*with_depth=*/true,
                           [&](const KeyframeRecord& k) { read.push_back(k); });
  ASSERT_EQ(read.size(), 3u);
  for (size_t i = 0; i < read.size(); ++i) {
    const KeyframeRecord want =
        Keyframe(static_cast<int64_t>(i) + 1, 100 * (static_cast<int64_t>(i) + 2));
    EXPECT_EQ(read[i].seq, want.seq);
    EXPECT_EQ(read[i].t_ns, want.t_ns);
    EXPECT_EQ(read[i].pose_json, want.pose_json);
    EXPECT_EQ(read[i].depth_png, want.depth_png);
    EXPECT_EQ(read[i].content_sha, want.content_sha);
  }
  EXPECT_FALSE(read[0].covariance_json);
  EXPECT_EQ(read[1].covariance_json, "[1,0]");
  EXPECT_EQ(read[0].cloud, Keyframe(1, 0).cloud);
  EXPECT_EQ(read[0].cloud_params, "params");
  EXPECT_TRUE(read[2].cloud.empty());
  EXPECT_EQ(read[2].cloud_params, "");

  std::vector<int64_t> seqs;
  sessions.ForEachKeyframe(id, 0, 100, /*with_depth=*/false, [&](const KeyframeRecord& k) {
    seqs.push_back(k.seq);
    EXPECT_TRUE(k.depth_png.empty());
    EXPECT_FALSE(k.content_sha.empty());
  });
  EXPECT_EQ(seqs, (std::vector<int64_t>{0, 1, 2, 3, 4}));
  int calls = 0;
  sessions.ForEachKeyframe(id, 5, 10, true, [&](const KeyframeRecord&) { ++calls; });
  sessions.ForEachKeyframe(id + 100, 0, 10, true, [&](const KeyframeRecord&) { ++calls; });
  EXPECT_EQ(calls, 0);
}

TEST_P(StorageContract, CommitMovesTheSessionAndQueuesItsJobOnce) {
  const int64_t id = NewSession();
  ASSERT_EQ(s().sessions().PutKeyframe(id, Keyframe(0, 1)), PutKeyframeOutcome::kStored);
  const auto job = s().sessions().Commit(id, R"({"session_id":1})", 77);
  ASSERT_TRUE(job);
  const auto session = s().sessions().Get(id);
  EXPECT_EQ(session->state, SessionState::kCommitting);
  EXPECT_EQ(session->job_id, *job);
  const auto j = s().jobs().Get(*job);
  ASSERT_TRUE(j);
  EXPECT_EQ(j->type, JobType::kCommit);
  EXPECT_EQ(j->state, JobState::kQueued);
  EXPECT_EQ(j->params_json, R"({"session_id":1})");
  EXPECT_EQ(j->created_ms, 77);
  EXPECT_EQ(j->attempts, 0);
  EXPECT_FALSE(s().sessions().Commit(id, "{}", 78));  // not open any more: no second job
  EXPECT_FALSE(s().sessions().Commit(id + 1, "{}", 78));
  EXPECT_EQ(s().jobs().List(100, 0).size(), 1u);
}

TEST_P(StorageContract, FinishingACommitDropsTheUploadTimeCloudsOnly) {
  SessionStore& sessions = s().sessions();
  const int64_t id = NewSession();
  ASSERT_EQ(sessions.PutKeyframe(id, Keyframe(0, 1)), PutKeyframeOutcome::kStored);
  sessions.Finish(id, SessionState::kFailed, R"({"status":"rejected"})", 50);
  auto r = sessions.Get(id);
  EXPECT_EQ(r->state, SessionState::kFailed);
  EXPECT_EQ(r->committed_ms, 50);
  EXPECT_EQ(r->registration_json, R"({"status":"rejected"})");
  sessions.ForEachKeyframe(id, 0, 1, true,
                           [](const KeyframeRecord& k) { EXPECT_FALSE(k.cloud.empty()); });

  sessions.Finish(id, SessionState::kCommitted, std::nullopt,
                  60);  // nullopt keeps the registration
  r = sessions.Get(id);
  EXPECT_EQ(r->state, SessionState::kCommitted);
  EXPECT_EQ(r->committed_ms, 60);
  EXPECT_EQ(r->registration_json, R"({"status":"rejected"})");
  int seen = 0;
  sessions.ForEachKeyframe(id, 0, 1, true, [&](const KeyframeRecord& k) {
    ++seen;
    EXPECT_TRUE(k.cloud.empty());
    EXPECT_EQ(k.cloud_params, "");
    EXPECT_EQ(k.depth_png, Keyframe(0, 1).depth_png);
  });
  EXPECT_EQ(seen, 1);
}

TEST_P(StorageContract, ObservedOctreeIsStoredPerSessionAndReplaced) {
  const int64_t id = NewSession();
  EXPECT_FALSE(s().sessions().GetObserved(id));
  s().sessions().PutObserved(id, Bytes{1, 2, 3});
  EXPECT_EQ(s().sessions().GetObserved(id), (Bytes{1, 2, 3}));
  s().sessions().PutObserved(id, Bytes{4});
  EXPECT_EQ(s().sessions().GetObserved(id), (Bytes{4}));
  ExpectError(ErrorCode::kConflict, [&] { s().sessions().PutObserved(id + 1, Bytes{5}); });
  EXPECT_FALSE(s().sessions().GetObserved(id + 1));
}

}  // namespace
}  // namespace mapdelta::server::testing
