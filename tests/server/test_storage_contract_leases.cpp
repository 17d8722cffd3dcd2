// The storage contract, part 3: job leases, by which several worker processes share one job
// queue (a claim is a lease; a lapsed lease is claimed again) and jobs apply in id order.
#include "storage_contract.hpp"

namespace mapdelta::server::testing {
namespace {

TEST_P(StorageContract, AClaimIsALeaseThatItsWorkerRenewsAndThatIsClaimedAgainOnceItLapsed) {
  JobStore& jobs = s().jobs();
  const int64_t a = jobs.Create(JobType::kRefresh, "{}", 1);
  const auto claimed = jobs.ClaimNext(10, 5);
  ASSERT_TRUE(claimed);
  EXPECT_EQ(claimed->lease_owner, jobs.worker_id());
  EXPECT_EQ(claimed->lease_expires_ms, 15);
  EXPECT_FALSE(jobs.ClaimNext(14, 5)) << "a leased job was claimed twice";
  EXPECT_TRUE(jobs.RenewLease(a, 14, 5));
  EXPECT_EQ(jobs.Get(a)->lease_expires_ms, 19);
  EXPECT_FALSE(jobs.ClaimNext(18, 5));
  // Lapsed (its worker died): claimed again, a second attempt, first start kept.
  const auto again = jobs.ClaimNext(30, 5);
  ASSERT_TRUE(again);
  EXPECT_EQ(again->id, a);
  EXPECT_EQ(again->attempts, 2);
  EXPECT_EQ(again->started_ms, 10);
  // Finishing ends the lease: nothing to renew, nothing to claim.
  jobs.Finish(a, JobState::kSucceeded, "done", std::nullopt, 31);
  EXPECT_FALSE(jobs.RenewLease(a, 32, 5));
  EXPECT_FALSE(jobs.Get(a)->lease_owner);
  EXPECT_FALSE(jobs.ClaimNext(100, 5));
}

TEST_P(StorageContract, AReleasedJobGoesBackToTheQueue) {
  JobStore& jobs = s().jobs();
  const int64_t a = jobs.Create(JobType::kReclassify, "{}", 1);
  jobs.ClaimNext(2, kLeaseMs);
  jobs.Release(a);
  const auto job = jobs.Get(a);
  EXPECT_EQ(job->state, JobState::kQueued);
  EXPECT_FALSE(job->lease_owner);
  EXPECT_FALSE(jobs.RenewLease(a, 3, kLeaseMs));
  const auto again = jobs.ClaimNext(4, kLeaseMs);
  ASSERT_TRUE(again);
  EXPECT_EQ(again->id, a);
  EXPECT_EQ(again->attempts, 2);
}

TEST_P(StorageContract, TheOldestUnfinishedEarlierJobIsFoundWithWhetherItIsClaimable) {
  JobStore& jobs = s().jobs();
  const int64_t refresh = jobs.Create(JobType::kRefresh, "{}", 1);
  const int64_t reclassify = jobs.Create(JobType::kReclassify, "{}", 1);
  const int64_t last = jobs.Create(JobType::kRefresh, "{}", 1);
  EXPECT_FALSE(jobs.UnfinishedBefore(refresh, 5, std::nullopt));
  auto earlier = jobs.UnfinishedBefore(last, 5, std::nullopt);
  ASSERT_TRUE(earlier);
  EXPECT_EQ(earlier->id, refresh);
  EXPECT_TRUE(earlier->claimable);  // queued
  jobs.ClaimNext(5, 10);            // refresh: running, leased until 15
  earlier = jobs.UnfinishedBefore(last, 6, std::nullopt);
  ASSERT_TRUE(earlier);
  EXPECT_EQ(earlier->id, refresh);
  EXPECT_FALSE(earlier->claimable);
  EXPECT_TRUE(jobs.UnfinishedBefore(last, 16, std::nullopt)->claimable);  // lease lapsed
  EXPECT_EQ(jobs.UnfinishedBefore(last, 6, JobType::kReclassify)->id, reclassify);
  jobs.Finish(refresh, JobState::kSucceeded, "done", std::nullopt, 7);
  EXPECT_EQ(jobs.UnfinishedBefore(last, 8, std::nullopt)->id, reclassify);
  EXPECT_FALSE(jobs.UnfinishedBefore(last, 8, JobType::kRefresh));
  jobs.RequestCancel(reclassify, 9);
  EXPECT_FALSE(jobs.UnfinishedBefore(last, 10, std::nullopt));
}

}  // namespace
}  // namespace mapdelta::server::testing
