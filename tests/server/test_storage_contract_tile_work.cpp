// The storage contract, part 4: per-tile work items of a commit job (issue #19). Items are
// claimed one at a time per tile (lowest tile of the oldest job first, only of running jobs),
// a claim is a lease with a fencing token, and the results of all the job's items become
// visible together or not at all.
#include "storage_contract.hpp"

namespace mapdelta::server::testing {
namespace {

// A running commit job (claimed by this storage's worker at now_ms).
int64_t RunningJob(JobStore& jobs, int64_t now_ms) {
  const int64_t id = jobs.Create(JobType::kCommit, "{}", now_ms);
  const auto claimed = jobs.ClaimNext(now_ms, kLeaseMs);
  EXPECT_TRUE(claimed && claimed->id == id);
  return id;
}

std::vector<TileId> TilesOf(const std::vector<TileWorkItem>& items) {
  std::vector<TileId> out;
  for (const TileWorkItem& w : items) out.push_back(w.tile);
  return out;
}

TEST_P(StorageContract, TileWorkIsClaimedOncePerTileLowestTileFirstAndOnlyOfRunningJobs) {
  JobStore& jobs = s().jobs();
  const int64_t queued = jobs.Create(JobType::kCommit, "{}", 1);
  jobs.AddTileWork(queued, 3, {TileId(0, 0)});
  EXPECT_FALSE(jobs.ClaimTileWork(std::nullopt, 2, kLeaseMs)) << "an item of a queued job";
  jobs.RequestCancel(queued, 2);  // a cancelled job's items are never claimed either

  const int64_t job = RunningJob(jobs, 3);
  jobs.AddTileWork(job, 7, {TileId(1, 0), TileId(0, 0), TileId(-3, 5)});
  jobs.AddTileWork(job, 8, {TileId(0, 0), TileId(2, 2)});  // (0,0) stays as it was
  const std::vector<TileWorkItem> listed = jobs.ListTileWork(job);
  EXPECT_EQ(TilesOf(listed),
            (std::vector<TileId>{TileId(-3, 5), TileId(0, 0), TileId(1, 0), TileId(2, 2)}));
  ASSERT_EQ(listed.size(), 4u);
  EXPECT_EQ(listed[1].prior_version, 7);
  EXPECT_EQ(listed[3].prior_version, 8);
  for (const TileWorkItem& w : listed) {
    EXPECT_EQ(w.claims, 0);
    EXPECT_FALSE(w.lease_owner || w.done_by || w.published);
  }
  EXPECT_FALSE(jobs.ClaimTileWork(queued, 4, kLeaseMs));

  std::vector<TileId> claimed;
  for (int i = 0; i < 4; ++i) {
    const auto w = jobs.ClaimTileWork(job, 10, kLeaseMs);
    ASSERT_TRUE(w);
    EXPECT_EQ(w->job_id, job);
    EXPECT_EQ(w->claims, 1);
    EXPECT_EQ(w->lease_owner, jobs.worker_id());
    EXPECT_EQ(w->lease_expires_ms, 10 + kLeaseMs);
    claimed.push_back(w->tile);
  }
  EXPECT_EQ(claimed, TilesOf(listed)) << "claimed in tile order, each once";
  EXPECT_FALSE(jobs.ClaimTileWork(std::nullopt, 11, kLeaseMs)) << "an item was claimed twice";
}

TEST_P(StorageContract, ALapsedTileClaimIsTakenOverAndTheStaleResultIsRefused) {
  JobStore& jobs = s().jobs();
  const int64_t job = RunningJob(jobs, 1);
  jobs.AddTileWork(job, 2, {TileId(4, 4)});
  const auto first = jobs.ClaimTileWork(job, 10, 5);
  ASSERT_TRUE(first);
  EXPECT_FALSE(jobs.ClaimTileWork(job, 14, 5));        // still leased
  const auto second = jobs.ClaimTileWork(job, 16, 5);  // lapsed: its worker died or stalled
  ASSERT_TRUE(second);
  EXPECT_EQ(second->tile, TileId(4, 4));
  EXPECT_EQ(second->claims, 2);
  EXPECT_FALSE(jobs.CompleteTileWork(*first, Changes(4, 4, 9, 9, 0.9)))
      << "the first claim's late result was taken";
  EXPECT_FALSE(jobs.ListTileWork(job)[0].done_by);
  EXPECT_TRUE(jobs.CompleteTileWork(*second, Changes(4, 4, 3, 1, 0.7)));
  const TileWorkItem done = jobs.ListTileWork(job)[0];
  EXPECT_EQ(done.done_by, jobs.worker_id());
  EXPECT_FALSE(done.lease_owner);
  EXPECT_EQ(done.new_count, 3);
  EXPECT_EQ(done.removed_count, 1);
  EXPECT_FALSE(jobs.CompleteTileWork(*second, Changes(4, 4, 5, 5, 0.5))) << "completed twice";
  EXPECT_FALSE(jobs.ClaimTileWork(job, 100, 5)) << "a done item was claimed again";
}

TEST_P(StorageContract, ACommitsTileResultsAreVisibleTogetherOnceEveryItemIsDone) {
  JobStore& jobs = s().jobs();
  TileStore& tiles = s().tiles();
  tiles.ApplyChanges(0, {Changes(0, 0, 50, 50, 0.1), Changes(8, 8, 1, 1, 0.2)});
  const int64_t job = RunningJob(jobs, 1);
  EXPECT_EQ(tiles.PublishTileWork(job), PublishOutcome::kNotReady) << "a job without items";
  jobs.AddTileWork(job, 1, {TileId(0, 0), TileId(1, 0)});
  const auto a = jobs.ClaimTileWork(job, 2, kLeaseMs);
  const auto b = jobs.ClaimTileWork(job, 2, kLeaseMs);
  ASSERT_TRUE(a && b);
  ASSERT_TRUE(jobs.CompleteTileWork(*a, Changes(0, 0, 3, 1, 0.75)));
  EXPECT_EQ(tiles.PublishTileWork(job), PublishOutcome::kNotReady);
  EXPECT_EQ(tiles.GetChanges(TileId(0, 0))->new_count, 50) << "half a commit is visible";
  EXPECT_FALSE(tiles.GetChanges(TileId(1, 0)));

  ASSERT_TRUE(jobs.CompleteTileWork(*b, Changes(1, 0, 2, 0, 0.6)));
  EXPECT_EQ(tiles.PublishTileWork(job), PublishOutcome::kPublished);
  for (const TileChangesRecord& want : {Changes(0, 0, 3, 1, 0.75), Changes(1, 0, 2, 0, 0.6)}) {
    const auto got = tiles.GetChanges(want.tile);
    ASSERT_TRUE(got) << want.tile.ToString();
    EXPECT_EQ(got->new_count, want.new_count);
    EXPECT_EQ(got->removed_count, want.removed_count);
    EXPECT_DOUBLE_EQ(got->max_confidence, want.max_confidence);
    EXPECT_EQ(got->changes, want.changes);
    EXPECT_EQ(got->params_json, want.params_json);
    EXPECT_EQ(got->updated_ms, want.updated_ms);
  }
  EXPECT_EQ(tiles.GetChanges(TileId(8, 8))->new_count, 1) << "another tile was touched";
  for (const TileWorkItem& w : jobs.ListTileWork(job)) EXPECT_TRUE(w.published);
  EXPECT_EQ(tiles.PublishTileWork(job), PublishOutcome::kAlreadyPublished);
}

TEST_P(StorageContract, TileWorkOfTheOldestJobIsClaimedFirstAndOfAFinishedJobNever) {
  JobStore& jobs = s().jobs();
  const int64_t older = RunningJob(jobs, 1);
  const int64_t newer = RunningJob(jobs, 2);
  jobs.AddTileWork(newer, 1, {TileId(-9, -9)});
  jobs.AddTileWork(older, 1, {TileId(5, 5)});
  const auto first = jobs.ClaimTileWork(std::nullopt, 3, kLeaseMs);
  ASSERT_TRUE(first);
  EXPECT_EQ(first->job_id, older);
  jobs.Finish(newer, JobState::kFailed, "failed", std::nullopt, 4);
  EXPECT_FALSE(jobs.ClaimTileWork(std::nullopt, 5, kLeaseMs));
}

}  // namespace
}  // namespace mapdelta::server::testing
