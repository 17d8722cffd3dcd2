// The storage contract, part 2: jobs, per-tile state and changes, the refresh, settings.
#include <algorithm>
#include <map>

#include "storage_contract.hpp"

namespace mapdelta::server::testing {
namespace {

std::map<JobState, int64_t> Counts(JobStore& jobs) {
  std::map<JobState, int64_t> out;
  for (const auto& [state, n] : jobs.CountByState()) out[state] = n;
  return out;
}

// ---------------------------------------------------------------- jobs

TEST_P(StorageContract, JobsAreClaimedOldestFirstAndListedNewestFirst) {
  JobStore& jobs = s().jobs();
  EXPECT_FALSE(jobs.ClaimNext(1, kLeaseMs));
  const int64_t a = jobs.Create(JobType::kRefresh, R"({"a":1})", 10);
  const int64_t b = jobs.Create(JobType::kReclassify, "{}", 11);
  const int64_t c = jobs.Create(JobType::kRefresh, "{}", 12);
  EXPECT_LT(a, b);
  EXPECT_LT(b, c);
  const auto first = jobs.ClaimNext(20, kLeaseMs);
  ASSERT_TRUE(first);
  EXPECT_EQ(first->id, a);
  EXPECT_EQ(first->type, JobType::kRefresh);
  EXPECT_EQ(first->state, JobState::kRunning);
  EXPECT_EQ(first->attempts, 1);
  EXPECT_EQ(first->started_ms, 20);
  EXPECT_EQ(first->params_json, R"({"a":1})");
  EXPECT_EQ(jobs.ClaimNext(21, kLeaseMs)->id, b);

  std::vector<int64_t> ids;
  for (const auto& j : jobs.List(10, 0)) ids.push_back(j.id);
  EXPECT_EQ(ids, (std::vector<int64_t>{c, b, a}));
  const auto page = jobs.List(1, 1);
  ASSERT_EQ(page.size(), 1u);
  EXPECT_EQ(page[0].id, b);
  EXPECT_EQ(page[0].type, JobType::kReclassify);
  EXPECT_TRUE(jobs.List(10, 3).empty());
  EXPECT_EQ(Counts(jobs),
            (std::map<JobState, int64_t>{{JobState::kQueued, 1}, {JobState::kRunning, 2}}));
  EXPECT_FALSE(jobs.Get(c + 1));
}

TEST_P(StorageContract, FinishingAJobRecordsItsOutcome) {
  JobStore& jobs = s().jobs();
  const int64_t a = jobs.Create(JobType::kRefresh, "{}", 1),
                b = jobs.Create(JobType::kRefresh, "{}", 2);
  jobs.ClaimNext(3, kLeaseMs);
  jobs.ClaimNext(3, kLeaseMs);
  jobs.UpdateProgress(a, 0.4, "half way");
  jobs.UpdateProgress(b, 0.3, "a third");
  EXPECT_EQ(jobs.Get(a)->progress, 0.4);
  EXPECT_EQ(jobs.Get(a)->message, "half way");
  jobs.Finish(a, JobState::kSucceeded, "done", R"({"ok":true})", 9);
  const auto done = jobs.Get(a);
  EXPECT_EQ(done->state, JobState::kSucceeded);
  EXPECT_EQ(done->progress, 1.0);
  EXPECT_EQ(done->message, "done");
  EXPECT_EQ(done->result_json, R"({"ok":true})");
  EXPECT_EQ(done->finished_ms, 9);
  jobs.Finish(b, JobState::kFailed, "broke", std::nullopt, 10);
  const auto failed = jobs.Get(b);
  EXPECT_EQ(failed->state, JobState::kFailed);
  EXPECT_EQ(failed->progress, 0.3);  // a failure keeps the progress it reached
  EXPECT_FALSE(failed->result_json);
  EXPECT_EQ(failed->finished_ms, 10);
}

TEST_P(StorageContract, CancellingAQueuedCommitReopensItsSession) {
  const int64_t session = NewSession();
  ASSERT_EQ(s().sessions().PutKeyframe(session, Keyframe(0, 1)), PutKeyframeOutcome::kStored);
  const int64_t job = *s().sessions().Commit(session, "{}", 5);
  EXPECT_EQ(s().jobs().RequestCancel(job, 6), JobState::kCancelled);
  const auto j = s().jobs().Get(job);
  EXPECT_EQ(j->state, JobState::kCancelled);
  EXPECT_TRUE(j->cancel_requested);
  EXPECT_EQ(j->finished_ms, 6);
  EXPECT_EQ(j->message, "cancelled before it started");
  const auto reopened = s().sessions().Get(session);
  EXPECT_EQ(reopened->state, SessionState::kOpen);
  EXPECT_FALSE(reopened->job_id);
  EXPECT_FALSE(s().jobs().ClaimNext(7, kLeaseMs));  // a cancelled job is never claimed
  EXPECT_EQ(s().jobs().RequestCancel(job, 8), JobState::kCancelled);  // repeat: unchanged
  EXPECT_EQ(s().jobs().Get(job)->finished_ms, 6);
  EXPECT_FALSE(s().jobs().RequestCancel(job + 1, 8));
  EXPECT_TRUE(s().sessions().Commit(session, "{}", 9));  // the vehicle may commit again
}

TEST_P(StorageContract, CancellingARunningJobOnlyFlagsIt) {
  JobStore& jobs = s().jobs();
  const int64_t a = jobs.Create(JobType::kReclassify, "{}", 1),
                b = jobs.Create(JobType::kReclassify, "{}", 1);
  jobs.ClaimNext(2, kLeaseMs);
  EXPECT_FALSE(jobs.IsCancelRequested(a));
  EXPECT_EQ(jobs.RequestCancel(a, 3), JobState::kRunning);
  EXPECT_TRUE(jobs.IsCancelRequested(a));
  EXPECT_EQ(jobs.Get(a)->state, JobState::kRunning);
  EXPECT_FALSE(jobs.Get(a)->finished_ms);
  jobs.ClaimNext(4, kLeaseMs);
  jobs.Finish(b, JobState::kSucceeded, "done", std::nullopt, 5);
  EXPECT_EQ(jobs.RequestCancel(b, 6), JobState::kSucceeded);  // finished: nothing to cancel
  EXPECT_FALSE(jobs.IsCancelRequested(b));
  EXPECT_FALSE(jobs.IsCancelRequested(b + 1));
}

TEST_P(StorageContract, InterruptedJobsAreRequeuedAndKeepTheirFirstStart) {
  JobStore& jobs = s().jobs();
  const int64_t a = jobs.Create(JobType::kRefresh, "{}", 1),
                b = jobs.Create(JobType::kRefresh, "{}", 1);
  jobs.Create(JobType::kRefresh, "{}", 1);
  jobs.ClaimNext(10, kLeaseMs);
  jobs.ClaimNext(11, kLeaseMs);
  jobs.Finish(b, JobState::kSucceeded, "done", std::nullopt, 12);
  EXPECT_EQ(jobs.RequeueInterrupted(5000), 1);
  EXPECT_EQ(jobs.RequeueInterrupted(5000), 0);
  const auto requeued = jobs.Get(a);
  EXPECT_EQ(requeued->state, JobState::kQueued);
  EXPECT_EQ(requeued->message, "resumed after restart");
  const auto again = jobs.ClaimNext(20, kLeaseMs);
  ASSERT_TRUE(again);
  EXPECT_EQ(again->id, a);
  EXPECT_EQ(again->attempts, 2);
  EXPECT_EQ(again->started_ms, 10);
  EXPECT_EQ(jobs.Get(b)->state, JobState::kSucceeded);
}

// ---------------------------------------------------------------- tiles

TEST_P(StorageContract, TileUpdatesStoreStateSessionsAndTheJobsTiles) {
  const int64_t s1 = NewSession(), s2 = NewSession();
  const int64_t job = s().jobs().Create(JobType::kRefresh, "{}", 1);
  EXPECT_FALSE(s().tiles().GetState(TileId(0, 0)));
  s().tiles().ApplyUpdates(
      job, {State(1, 0, {s1}, 1), State(0, 0, {s1, s2}, 2), State(-3, 5, {s2}, 3)}, 50);
  const auto a = s().tiles().GetState(TileId(0, 0));
  ASSERT_TRUE(a);
  EXPECT_EQ(a->aggregate, State(0, 0, {}, 2).aggregate);
  EXPECT_EQ(a->sessions, (std::set<int64_t>{s1, s2}));
  EXPECT_EQ(a->updated_ms, 50);
  EXPECT_EQ(s().jobs().TilesDone(job), (std::set<std::string>{"1_0", "0_0", "-3_5"}));
  EXPECT_TRUE(s().jobs().TilesDone(job + 1).empty());
  EXPECT_EQ(s().tiles().ListAggregated(std::nullopt),
            (std::vector<TileId>{TileId(-3, 5), TileId(0, 0), TileId(1, 0)}));
  EXPECT_EQ(s().tiles().ListAggregated(Rect{0, 0, 1, 0}),
            (std::vector<TileId>{TileId(0, 0), TileId(1, 0)}));

  s().tiles().ApplyUpdates(job, {State(0, 0, {s2}, 9)}, 60);  // replaces aggregate and session set
  const auto replaced = s().tiles().GetState(TileId(0, 0));
  EXPECT_EQ(replaced->sessions, (std::set<int64_t>{s2}));
  EXPECT_EQ(replaced->aggregate, State(0, 0, {}, 9).aggregate);
  EXPECT_EQ(replaced->updated_ms, 60);
}

TEST_P(StorageContract, TileUpdatesAreAllOrNothing) {
  const int64_t s1 = NewSession();
  const int64_t job = s().jobs().Create(JobType::kRefresh, "{}", 1);
  s().tiles().ApplyUpdates(job, {State(0, 0, {s1}, 1)}, 10);
  const int64_t job2 = s().jobs().Create(JobType::kRefresh, "{}", 1);
  // The second tile names a session that does not exist: neither tile may change.
  ExpectError(ErrorCode::kConflict, [&] {
    s().tiles().ApplyUpdates(job2, {State(0, 0, {s1}, 7), State(1, 1, {s1, s1 + 100}, 7)}, 20);
  });
  EXPECT_EQ(s().tiles().GetState(TileId(0, 0))->aggregate, State(0, 0, {}, 1).aggregate);
  EXPECT_EQ(s().tiles().GetState(TileId(0, 0))->updated_ms, 10);
  EXPECT_FALSE(s().tiles().GetState(TileId(1, 1)));
  EXPECT_TRUE(s().jobs().TilesDone(job2).empty());
  // So does an unknown job.
  ExpectError(ErrorCode::kConflict,
              [&] { s().tiles().ApplyUpdates(job2 + 10, {State(2, 2, {s1}, 7)}, 20); });
  EXPECT_FALSE(s().tiles().GetState(TileId(2, 2)));
}

TEST_P(StorageContract, ChangesAreListedByRectConfidenceAndPage) {
  TileStore& tiles = s().tiles();
  tiles.ApplyChanges(
      0, {Changes(2, 0, 5, 1, 0.9), Changes(0, 0, 3, 0, 0.6), Changes(1, 5, 0, 4, 0.75),
          Changes(1, -1, 0, 0, 0.95), Changes(9, 9, 2, 2, 0.99), Changes(0, 1, 1, 1, 0.3)});
  const auto full = tiles.GetChanges(TileId(2, 0));
  ASSERT_TRUE(full);
  EXPECT_EQ(full->changes, Changes(2, 0, 5, 1, 0.9).changes);
  EXPECT_EQ(full->params_json, R"({"th_ch_m":3.2})");
  EXPECT_EQ(full->prior_version, 1);
  EXPECT_EQ(full->updated_ms, 42);
  EXPECT_FALSE(tiles.GetChanges(TileId(5, 5)));

  const Rect rect{-1, -1, 2, 5};
  int64_t total = -1;
  auto listed = tiles.ListChanged(rect, 0.5, 100, 0, &total);
  EXPECT_EQ(total, 3);  // not (1,-1): no change; not (9,9): outside; not (0,1): confidence
  std::vector<TileId> order;
  for (const auto& c : listed) {
    order.push_back(c.tile);
    EXPECT_TRUE(c.changes.empty()) << "listings carry no change blobs";
  }
  EXPECT_EQ(order, (std::vector<TileId>{TileId(0, 0), TileId(1, 5), TileId(2, 0)}));
  EXPECT_EQ(listed[1].removed_count, 4);
  EXPECT_EQ(listed[1].max_confidence, 0.75);
  listed = tiles.ListChanged(rect, 0.5, 1, 1, &total);
  ASSERT_EQ(listed.size(), 1u);
  EXPECT_EQ(listed[0].tile, TileId(1, 5));
  EXPECT_EQ(total, 3);
  EXPECT_EQ(tiles.ListChanged(rect, 0.75, 100, 0, &total).size(), 2u);  // the bound is inclusive
  EXPECT_TRUE(tiles.ListChanged(rect, 0.5, 10, 3, &total).empty());
  EXPECT_EQ(total, 3);
}

TEST_P(StorageContract, ChangesOfAJobMarkItsTilesAndReplaceEarlierOnes) {
  const int64_t job = s().jobs().Create(JobType::kReclassify, "{}", 1);
  s().tiles().ApplyChanges(0, {Changes(0, 0, 1, 1, 0.5)});
  EXPECT_TRUE(s().jobs().TilesDone(job).empty());
  s().tiles().ApplyChanges(job, {Changes(0, 0, 6, 0, 0.8), Changes(3, 3, 1, 0, 0.5)});
  EXPECT_EQ(s().jobs().TilesDone(job), (std::set<std::string>{"0_0", "3_3"}));
  EXPECT_EQ(s().tiles().GetChanges(TileId(0, 0))->new_count, 6);
  ExpectError(ErrorCode::kConflict,
              [&] { s().tiles().ApplyChanges(job + 5, {Changes(4, 4, 1, 0, 0.5)}); });
  EXPECT_FALSE(s().tiles().GetChanges(TileId(4, 4)));
}

// A prior of two tiles, both aggregated and classified, and a running refresh job.
int64_t SetUpRefresh(Storage& s, int64_t session) {
  s.priors().CreateVersion(PriorVersionRecord{0, 1, PriorSource::kImport, "v1", {}, {}, {}},
                           {PriorTileRecord{TileId(0, 0), 0, 3, Bytes{1}},
                            PriorTileRecord{TileId(1, 0), 0, 4, Bytes{2}}},
                           true);
  const int64_t job = s.jobs().Create(JobType::kRefresh, "{}", 2);
  s.jobs().ClaimNext(3, kLeaseMs);
  TileStateRecord a{TileId(0, 0), Bytes{5}, {session}, 0}, b{TileId(1, 0), Bytes{6}, {session}, 0};
  s.tiles().ApplyUpdates(job, {a, b}, 4);
  TileChangesRecord ca{TileId(0, 0), 1, 2, 0, 4, 0.8, Bytes{7}, "{}"},
      cb{TileId(1, 0), 1, 1, 0, 4, 0.8, Bytes{8}, "{}"};
  s.tiles().ApplyChanges(0, {ca, cb});
  return job;
}

TEST_P(StorageContract, RefreshWritesItsVersionAndResetsItsTilesAtOnce) {
  const int64_t session = NewSession();
  const int64_t job = SetUpRefresh(s(), session);
  PriorVersionRecord meta;
  meta.note = "merge";
  const int64_t version =
      s().tiles().ApplyRefresh(job, meta, {RefreshTileWrite{TileId(0, 0), 1, 2, 1, 4, Bytes{9, 9}}},
                               R"({"prior_version":2})", 70);
  EXPECT_EQ(version, 2);
  const auto versions = s().priors().ListVersions();
  ASSERT_EQ(versions.size(), 2u);
  EXPECT_EQ(versions[1].version, 2);
  EXPECT_EQ(versions[1].source, PriorSource::kRefresh);
  EXPECT_EQ(versions[1].parent, 1);
  EXPECT_EQ(versions[1].job_id, job);
  EXPECT_EQ(versions[1].note, "merge");
  EXPECT_EQ(versions[1].created_ms, 70);
  EXPECT_EQ(s().priors().GetTile(TileId(0, 0), 2)->points, (Bytes{9, 9}));
  EXPECT_EQ(s().priors().GetTile(TileId(0, 0), 2)->point_count, 4);
  EXPECT_EQ(s().priors().GetTile(TileId(0, 0), 1)->points, (Bytes{1}));  // v1 still readable
  EXPECT_EQ(s().priors().GetTile(TileId(1, 0), 2)->version, 1);
  // The refreshed tile starts aggregating afresh; the other keeps its state.
  EXPECT_FALSE(s().tiles().GetState(TileId(0, 0)));
  EXPECT_FALSE(s().tiles().GetChanges(TileId(0, 0)));
  EXPECT_TRUE(s().tiles().GetState(TileId(1, 0)));
  EXPECT_TRUE(s().tiles().GetChanges(TileId(1, 0)));
  EXPECT_EQ(s().tiles().ListAggregated(std::nullopt), (std::vector<TileId>{TileId(1, 0)}));
  // The job stays running with its result kept (a resumed job finds its version by it).
  const auto j = s().jobs().Get(job);
  EXPECT_EQ(j->state, JobState::kRunning);
  EXPECT_EQ(j->progress, 0.9);
  EXPECT_EQ(j->result_json, R"({"prior_version":2})");
  EXPECT_NE(j->message.find("prior version 2"), std::string::npos) << j->message;
}

TEST_P(StorageContract, RefreshIsAllOrNothing) {
  const int64_t session = NewSession();
  const int64_t job = SetUpRefresh(s(), session);
  PriorVersionRecord meta;
  meta.note = "bad";
  ExpectError(ErrorCode::kConflict, [&] {
    s().tiles().ApplyRefresh(job, meta,
                             {RefreshTileWrite{TileId(1, 0), 1, 1, 0, 1, Bytes{3}},
                              RefreshTileWrite{TileId(0, 0), 1, 1, 0, 1, Bytes{3}},
                              RefreshTileWrite{TileId(0, 0), 1, 1, 0, 1, Bytes{4}}},
                             "{}", 80);
  });
  EXPECT_EQ(s().priors().LatestVersion(), 1);
  EXPECT_EQ(s().priors().GetTile(TileId(1, 0), 5)->points, (Bytes{2}));
  EXPECT_TRUE(s().tiles().GetState(TileId(0, 0)));
  EXPECT_TRUE(s().tiles().GetState(TileId(1, 0)));
  EXPECT_TRUE(s().tiles().GetChanges(TileId(1, 0)));
  const auto j = s().jobs().Get(job);
  EXPECT_FALSE(j->result_json);
  EXPECT_EQ(j->progress, 0.0);
}

TEST_P(StorageContract, SettingsAreStoredAndReplaced) {
  EXPECT_FALSE(s().tiles().GetSetting("classify"));
  s().tiles().PutSetting("classify", R"({"th_ch_m":2})");
  EXPECT_EQ(s().tiles().GetSetting("classify"), R"({"th_ch_m":2})");
  s().tiles().PutSetting("classify", R"({"th_ch_m":3})");
  EXPECT_EQ(s().tiles().GetSetting("classify"), R"({"th_ch_m":3})");
  EXPECT_FALSE(s().tiles().GetSetting("other"));
}

}  // namespace
}  // namespace mapdelta::server::testing
