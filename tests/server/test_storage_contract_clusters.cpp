// The storage contract, part 5: change clusters (issue #20). The lifecycle a publish runs is the
// service's (change_lifecycle.hpp); here a scripted one, so that the stores' side is tested
// alone: what a plan writes (new ids, one sequence number per transition in order), that it is
// written in the publish's own transaction (a failing plan leaves the publish unwritten), what
// the plan is given (the tile's clusters that are not expired, its sessions with their vehicles,
// days, commit jobs and localization weights; a refresh's version and points), the feed's order,
// and admin transitions.
#include <atomic>
#include <set>
#include <thread>

#include "storage_contract.hpp"

namespace mapdelta::server::testing {
namespace {

// Creates a candidate for a tile without clusters, confirms a candidate, applies on a refresh;
// throws when fail is set. Records what each call was given.
class ScriptedLifecycle final : public ClusterLifecycle {
 public:
  struct Call {
    TilePublication publication;  // its pointers are not kept: only the fields below
    bool classified = false;
    Bytes changes, refreshed_points;
    std::vector<ChangeClusterRecord> active;
  };
  std::vector<ClusterUpdate> Plan(const TilePublication& p,
                                  const std::vector<ChangeClusterRecord>& active) const override {
    Call call{p, p.classified != nullptr, {}, {}, active};
    call.publication.classified = nullptr;
    call.publication.refreshed = nullptr;
    if (p.classified) call.changes = p.classified->changes;
    if (p.refreshed) call.refreshed_points = p.refreshed->points;
    calls.push_back(call);
    if (fail) throw Error(ErrorCode::kInternal, "scripted failure");
    ClusterUpdate u;
    if (active.empty()) {
      u.cluster.tile = p.tile;
      u.cluster.kind = ClusterKind::kRemoved;
      u.cluster.point_count = 3;
      u.cluster.min = {1, 2, 3};
      u.cluster.max = {4, 5, 6.5};
      u.cluster.centroid = {2, 3, 4};
      u.cluster.voxels = Bytes{1, 2, 3};
      u.cluster.evidence_json = R"({"supporting":[])";
      u.cluster.prior_version = 1;
      u.cluster.created_ms = u.cluster.updated_ms = p.now_ms;
      u.transitions.push_back(Step(p, std::nullopt, ClusterState::kCandidate));
      return {u};
    }
    u.cluster = active.front();
    u.cluster.updated_ms = p.now_ms;
    const ClusterState to = p.refreshed ? ClusterState::kApplied : ClusterState::kConfirmed;
    if (u.cluster.state == to) return {u};  // geometry only: no transition
    if (p.refreshed) u.cluster.applied_version = p.refreshed_version;
    u.transitions.push_back(Step(p, u.cluster.state, to));
    u.cluster.state = to;
    return {u};
  }
  static ClusterTransitionRecord Step(const TilePublication& p, std::optional<ClusterState> from,
                                      ClusterState to) {
    ClusterTransitionRecord t;
    t.from = from;
    t.to = to;
    t.at_ms = p.now_ms;
    t.cause = "scripted " + std::string(ToString(to));
    if (p.job_id > 0) t.job_id = p.job_id;
    t.session_id = 77;
    t.actor = "job";
    return t;
  }
  mutable std::vector<Call> calls;
  bool fail = false;
};

TEST_P(StorageContract, WithoutALifecyclePublishesWriteNoClusters) {
  s().tiles().ApplyChanges(0, {Changes(0, 0, 1, 0, 0.5)});
  EXPECT_EQ(s().clusters().LastSeq(), 0);
  EXPECT_TRUE(s().clusters().Feed(0, 10).empty());
  EXPECT_FALSE(s().clusters().Get(1));
  EXPECT_TRUE(s().clusters().History(1).empty());
}

TEST_P(StorageContract, APublishWritesItsPlannedClustersWithOneSeqPerTransitionInOrder) {
  auto lifecycle = std::make_shared<ScriptedLifecycle>();
  s().tiles().SetClusterLifecycle(lifecycle);
  const int64_t a = NewSession("car-a", 86'400'000 * 3 + 5);
  const int64_t b = NewSession("car-b", 86'400'000 * 4);
  const int64_t job = s().jobs().Create(JobType::kCommit, "{}", 1);
  s().tiles().ApplyUpdates(job, {State(2, 0, {a, b}, 1), State(1, 0, {b}, 2)}, 5);

  s().tiles().ApplyChanges(job, {Changes(2, 0, 1, 0, 0.5), Changes(1, 0, 1, 0, 0.5)});
  ASSERT_EQ(lifecycle->calls.size(), 2u);
  const ScriptedLifecycle::Call& first = lifecycle->calls[0];
  EXPECT_TRUE(first.classified);
  EXPECT_EQ(first.publication.tile, TileId(2, 0));
  EXPECT_EQ(first.publication.job_id, job);
  EXPECT_EQ(first.publication.now_ms, Changes(2, 0, 1, 0, 0.5).updated_ms);
  EXPECT_EQ(first.changes, Changes(2, 0, 1, 0, 0.5).changes);
  EXPECT_TRUE(first.active.empty());
  ASSERT_EQ(first.publication.sessions.size(), 2u) << "the tile's sessions, with their facts";
  EXPECT_EQ(first.publication.sessions[0].id, a);
  EXPECT_EQ(first.publication.sessions[0].vehicle_id, "car-a");
  EXPECT_EQ(first.publication.sessions[0].created_ms, 86'400'000 * 3 + 5);
  EXPECT_EQ(first.publication.sessions[1].vehicle_id, "car-b");
  EXPECT_FALSE(first.publication.sessions[0].job_id);
  ASSERT_TRUE(s().sessions().Commit(a, "{}", 6));  // the session records its commit job
  const int64_t commit_job = *s().sessions().Get(a)->job_id;

  // Ids in creation order, seq 1 and 2 in the order the tiles were published.
  const auto c1 = s().clusters().Get(1), c2 = s().clusters().Get(2);
  ASSERT_TRUE(c1 && c2);
  EXPECT_EQ(c1->tile, TileId(2, 0));
  EXPECT_EQ(c1->seq, 1);
  EXPECT_EQ(c2->tile, TileId(1, 0));
  EXPECT_EQ(c2->seq, 2);
  EXPECT_EQ(c1->kind, ClusterKind::kRemoved);
  EXPECT_EQ(c1->state, ClusterState::kCandidate);
  EXPECT_EQ(c1->point_count, 3);
  EXPECT_EQ(c1->max, (std::array<double, 3>{4, 5, 6.5}));
  EXPECT_EQ(c1->centroid, (std::array<double, 3>{2, 3, 4}));
  EXPECT_EQ(c1->voxels, (Bytes{1, 2, 3}));
  EXPECT_EQ(c1->evidence_json, R"({"supporting":[])");
  EXPECT_FALSE(c1->applied_version);
  EXPECT_EQ(s().clusters().LastSeq(), 2);

  // The second publish of tile (2, 0) sees its cluster and confirms it under seq 3.
  s().tiles().ApplyChanges(commit_job, {Changes(2, 0, 2, 0, 0.6)});
  ASSERT_EQ(lifecycle->calls.size(), 3u);
  ASSERT_EQ(lifecycle->calls[2].active.size(), 1u);
  EXPECT_EQ(lifecycle->calls[2].active[0].id, 1);
  EXPECT_EQ(lifecycle->calls[2].publication.sessions[0].job_id, commit_job);
  EXPECT_EQ(s().clusters().Get(1)->state, ClusterState::kConfirmed);
  EXPECT_EQ(s().clusters().Get(1)->seq, 3);
  const std::vector<ClusterTransitionRecord> history = s().clusters().History(1);
  ASSERT_EQ(history.size(), 2u);
  EXPECT_EQ(history[0].seq, 1);
  EXPECT_FALSE(history[0].from);
  EXPECT_EQ(history[0].to, ClusterState::kCandidate);
  EXPECT_EQ(history[0].job_id, job);
  EXPECT_EQ(history[1].seq, 3);
  EXPECT_EQ(history[1].from, ClusterState::kCandidate);
  EXPECT_EQ(history[1].to, ClusterState::kConfirmed);
  EXPECT_EQ(history[1].cause, "scripted confirmed");
  EXPECT_EQ(history[1].job_id, commit_job);
  EXPECT_EQ(history[1].session_id, 77);
  EXPECT_EQ(history[1].actor, "job");

  // The feed: each cluster once, at its latest change, in seq order, paged by the cursor.
  std::vector<int64_t> ids;
  for (const auto& c : s().clusters().Feed(0, 10)) ids.push_back(c.id);
  EXPECT_EQ(ids, (std::vector<int64_t>{2, 1}));
  ASSERT_EQ(s().clusters().Feed(0, 1).size(), 1u);
  EXPECT_EQ(s().clusters().Feed(0, 1)[0].id, 2);
  EXPECT_EQ(s().clusters().Feed(2, 10).size(), 1u);
  EXPECT_TRUE(s().clusters().Feed(3, 10).empty());

  // A geometry-only update takes no number.
  s().tiles().ApplyChanges(0, {Changes(2, 0, 3, 0, 0.6)});
  EXPECT_EQ(s().clusters().LastSeq(), 3);
  EXPECT_EQ(s().clusters().Get(1)->updated_ms, Changes(2, 0, 3, 0, 0.6).updated_ms);
}

TEST_P(StorageContract, AFailingPlanLeavesTheWholePublishUnwritten) {
  auto lifecycle = std::make_shared<ScriptedLifecycle>();
  s().tiles().SetClusterLifecycle(lifecycle);
  s().tiles().ApplyChanges(0, {Changes(0, 0, 1, 0, 0.5)});
  lifecycle->fail = true;
  EXPECT_ANY_THROW(
      s().tiles().ApplyChanges(0, {Changes(5, 5, 1, 0, 0.5), Changes(0, 0, 9, 0, 0.9)}));
  EXPECT_FALSE(s().tiles().GetChanges(TileId(5, 5)))
      << "the publish was written without its clusters";
  EXPECT_EQ(s().tiles().GetChanges(TileId(0, 0))->new_count, 1);
  EXPECT_EQ(s().clusters().LastSeq(), 1);

  // A commit's tile work: refused while the plan fails, published once it does not.
  JobStore& jobs = s().jobs();
  const int64_t job = jobs.Create(JobType::kCommit, "{}", 1);
  ASSERT_TRUE(jobs.ClaimNext(1, kLeaseMs));
  jobs.AddTileWork(job, 1, {TileId(3, 3), TileId(4, 3)});
  for (int i = 0; i < 2; ++i) {
    const auto item = jobs.ClaimTileWork(job, 2, kLeaseMs);
    ASSERT_TRUE(item);
    ASSERT_TRUE(jobs.CompleteTileWork(*item, Changes(item->tile.ix(), 3, 2, 0, 0.6)));
  }
  EXPECT_ANY_THROW(s().tiles().PublishTileWork(job));
  EXPECT_FALSE(s().tiles().GetChanges(TileId(3, 3)));
  for (const TileWorkItem& w : jobs.ListTileWork(job)) EXPECT_FALSE(w.published);
  lifecycle->fail = false;
  const size_t before = lifecycle->calls.size();
  EXPECT_EQ(s().tiles().PublishTileWork(job), PublishOutcome::kPublished);
  ASSERT_EQ(lifecycle->calls.size(), before + 2);
  EXPECT_EQ(lifecycle->calls[before].publication.tile, TileId(3, 3)) << "tiles in (ix, iy) order";
  EXPECT_EQ(lifecycle->calls[before].changes, Changes(3, 3, 2, 0, 0.6).changes);
  EXPECT_EQ(lifecycle->calls[before + 1].publication.tile, TileId(4, 3));
  EXPECT_EQ(s().clusters().Get(2)->tile, TileId(3, 3));
  EXPECT_EQ(s().clusters().Get(3)->tile, TileId(4, 3));
  EXPECT_EQ(s().clusters().LastSeq(), 3);
}

TEST_P(StorageContract, ARefreshPlansItsTilesWithTheirSessionsBeforeTheyAreReset) {
  auto lifecycle = std::make_shared<ScriptedLifecycle>();
  s().tiles().SetClusterLifecycle(lifecycle);
  const int64_t session = NewSession("van");
  s().priors().CreateVersion(Import(1), {PriorTile(0, 0, 2)}, true);
  const int64_t job = s().jobs().Create(JobType::kRefresh, "{}", 2);
  ASSERT_TRUE(s().jobs().ClaimNext(3, kLeaseMs));
  s().tiles().ApplyUpdates(job, {State(0, 0, {session}, 1)}, 4);
  s().tiles().ApplyChanges(0, {Changes(0, 0, 1, 0, 0.8)});  // cluster 1, a candidate
  lifecycle->fail = true;
  EXPECT_ANY_THROW(s().tiles().ApplyRefresh(
      job, PriorVersionRecord{}, {RefreshTileWrite{TileId(0, 0), 1, 1, 0, 3, Bytes{4, 4}}}, "{}",
      90));
  EXPECT_EQ(s().priors().LatestVersion(), 1) << "the version was written without its clusters";
  EXPECT_TRUE(s().tiles().GetState(TileId(0, 0)));
  lifecycle->fail = false;
  const int64_t version =
      s().tiles().ApplyRefresh(job, PriorVersionRecord{},
                               {RefreshTileWrite{TileId(0, 0), 1, 1, 0, 3, Bytes{4, 4}}}, "{}", 90);
  const ScriptedLifecycle::Call& call = lifecycle->calls.back();
  EXPECT_FALSE(call.classified);
  EXPECT_EQ(call.publication.refreshed_version, version);
  EXPECT_EQ(call.refreshed_points, (Bytes{4, 4}));
  EXPECT_EQ(call.publication.now_ms, 90);
  ASSERT_EQ(call.publication.sessions.size(), 1u);
  EXPECT_EQ(call.publication.sessions[0].vehicle_id, "van");
  const auto cluster = s().clusters().Get(1);
  ASSERT_TRUE(cluster);
  EXPECT_EQ(cluster->state, ClusterState::kApplied);
  EXPECT_EQ(cluster->applied_version, version);
  EXPECT_EQ(s().clusters().History(1).back().job_id, job);
}

TEST_P(StorageContract, AnAdminTransitionChecksTheStateAndTakesTheNextSeq) {
  auto lifecycle = std::make_shared<ScriptedLifecycle>();
  s().tiles().SetClusterLifecycle(lifecycle);
  s().tiles().ApplyChanges(0, {Changes(0, 0, 1, 0, 0.5), Changes(1, 1, 1, 0, 0.5)});
  ClusterTransitionRecord t;
  t.to = ClusterState::kRejected;
  t.at_ms = 500;
  t.cause = "a parked truck";
  t.actor = "admin:ops";
  EXPECT_FALSE(s().clusters().Transition(99, {ClusterState::kCandidate}, t));
  ExpectError(ErrorCode::kConflict,
              [&] { s().clusters().Transition(1, {ClusterState::kConfirmed}, t); });
  EXPECT_EQ(s().clusters().LastSeq(), 2) << "a refused transition took a number";
  EXPECT_EQ(s().clusters().History(1).size(), 1u);

  const auto rejected =
      s().clusters().Transition(1, {ClusterState::kCandidate, ClusterState::kConfirmed}, t);
  ASSERT_TRUE(rejected);
  EXPECT_EQ(rejected->state, ClusterState::kRejected);
  EXPECT_EQ(rejected->seq, 3);
  EXPECT_EQ(rejected->updated_ms, 500);
  const auto history = s().clusters().History(1);
  ASSERT_EQ(history.size(), 2u);
  EXPECT_EQ(history[1].from, ClusterState::kCandidate);
  EXPECT_EQ(history[1].cause, "a parked truck");
  EXPECT_EQ(history[1].actor, "admin:ops");
  EXPECT_FALSE(history[1].job_id);
  EXPECT_FALSE(history[1].session_id);
  std::vector<int64_t> ids;
  for (const auto& c : s().clusters().Feed(0, 10)) ids.push_back(c.id);
  EXPECT_EQ(ids, (std::vector<int64_t>{2, 1}));

  // The next publish of the tile gives the plan the rejected cluster (only expired ones are
  // left out).
  s().tiles().ApplyChanges(0, {Changes(0, 0, 2, 0, 0.5)});
  ASSERT_EQ(lifecycle->calls.back().active.size(), 1u);
  EXPECT_EQ(lifecycle->calls.back().active[0].state, ClusterState::kRejected);
  t.to = ClusterState::kExpired;
  ASSERT_TRUE(s().clusters().Transition(2, {ClusterState::kCandidate}, t));
  s().tiles().ApplyChanges(0, {Changes(1, 1, 2, 0, 0.5)});
  EXPECT_TRUE(lifecycle->calls.back().active.empty()) << "an expired cluster was planned again";
}

TEST_P(StorageContract, ASessionsLocalizationWeightIsStoredAndGivenToThePlan) {
  auto lifecycle = std::make_shared<ScriptedLifecycle>();
  s().tiles().SetClusterLifecycle(lifecycle);
  const int64_t a = NewSession("car-a"), b = NewSession("car-b");
  ExpectError(ErrorCode::kConflict, [&] { s().sessions().PutLocalization(b + 1, 0.5, "{}"); });
  EXPECT_FALSE(s().sessions().Get(a)->localization_weight);
  EXPECT_FALSE(s().sessions().Get(a)->localization_json);
  s().sessions().PutLocalization(a, 0.25, R"({"weight":0.25})");
  EXPECT_DOUBLE_EQ(*s().sessions().Get(a)->localization_weight, 0.25);
  EXPECT_EQ(s().sessions().Get(a)->localization_json, R"({"weight":0.25})");
  const int64_t job = s().jobs().Create(JobType::kCommit, "{}", 1);
  s().tiles().ApplyUpdates(job, {State(0, 0, {a, b}, 1)}, 5);
  s().tiles().ApplyChanges(0, {Changes(0, 0, 1, 0, 0.5)});
  const std::vector<SessionFacts>& facts = lifecycle->calls.back().publication.sessions;
  ASSERT_EQ(facts.size(), 2u);
  EXPECT_DOUBLE_EQ(facts[0].weight, 0.25);
  EXPECT_DOUBLE_EQ(facts[1].weight, 1.0) << "a session without a weight counts fully";
}

// Several writers at once (PostgreSQL: one pool connection each, as several processes would
// be): every transition gets its own number, with none skipped, and each cluster's seq is its
// latest transition's.
TEST_P(StorageContract, ConcurrentTransitionsGetDistinctContiguousNumbers) {
  auto lifecycle = std::make_shared<ScriptedLifecycle>();
  s().tiles().SetClusterLifecycle(lifecycle);
  constexpr int kClusters = 4, kRounds = 6;
  std::vector<TileChangesRecord> tiles;
  for (int i = 0; i < kClusters; ++i) tiles.push_back(Changes(i, 0, 1, 0, 0.5));
  s().tiles().ApplyChanges(0, tiles);  // clusters 1..4, seq 1..4
  std::vector<std::thread> writers;
  std::atomic<int> failures{0};
  for (int id = 1; id <= kClusters; ++id) {
    writers.emplace_back([&, id] {
      for (int round = 0; round < kRounds; ++round) {
        ClusterTransitionRecord t;
        t.to = round % 2 == 0 ? ClusterState::kConfirmed : ClusterState::kRejected;
        t.at_ms = 100 + round;
        t.cause = "round " + std::to_string(round);
        t.actor = "admin:test";
        const auto from = round % 2 == 0 ? std::vector<ClusterState>{ClusterState::kCandidate,
                                                                     ClusterState::kRejected}
                                         : std::vector<ClusterState>{ClusterState::kConfirmed};
        try {
          if (!s().clusters().Transition(id, from, t)) ++failures;
        } catch (const std::exception&) {
          ++failures;
        }
      }
    });
  }
  // A publisher at the same time (tiles of their own).
  for (int i = 0; i < kRounds; ++i) s().tiles().ApplyChanges(0, {Changes(10 + i, 0, 1, 0, 0.5)});
  for (std::thread& w : writers) w.join();
  EXPECT_EQ(failures, 0);
  const int64_t total = kClusters + kClusters * kRounds + kRounds;
  EXPECT_EQ(s().clusters().LastSeq(), total);
  std::set<int64_t> seqs;
  for (int64_t id = 1; id <= kClusters + kRounds; ++id) {
    const std::vector<ClusterTransitionRecord> history = s().clusters().History(id);
    ASSERT_FALSE(history.empty());
    for (size_t i = 1; i < history.size(); ++i) EXPECT_LT(history[i - 1].seq, history[i].seq);
    for (const auto& t : history)
      EXPECT_TRUE(seqs.insert(t.seq).second) << "seq " << t.seq << " twice";
    EXPECT_EQ(s().clusters().Get(id)->seq, history.back().seq);
  }
  EXPECT_EQ(static_cast<int64_t>(seqs.size()), total);
  EXPECT_EQ(*seqs.begin(), 1);
  EXPECT_EQ(*seqs.rbegin(), total) << "a number was skipped";
  EXPECT_EQ(static_cast<int64_t>(s().clusters().Feed(0, 1000).size()), kClusters + kRounds);
}

TEST_P(StorageContract, ClustersAreListedByTileRectAndStateWithPaging) {
  auto lifecycle = std::make_shared<ScriptedLifecycle>();
  s().tiles().SetClusterLifecycle(lifecycle);
  s().tiles().ApplyChanges(0, {Changes(0, 0, 1, 0, 0.5), Changes(3, 1, 1, 0, 0.5),
                               Changes(-2, 4, 1, 0, 0.5), Changes(1, 1, 1, 0, 0.5)});
  s().tiles().ApplyChanges(0, {Changes(3, 1, 2, 0, 0.5)});  // cluster 2 confirmed
  int64_t total = 0;
  const auto ids = [](const std::vector<ChangeClusterRecord>& v) {
    std::vector<int64_t> out;
    for (const auto& c : v) out.push_back(c.id);
    return out;
  };
  EXPECT_EQ(ids(s().clusters().List(std::nullopt, std::nullopt, 10, 0, &total)),
            (std::vector<int64_t>{1, 2, 3, 4}));
  EXPECT_EQ(total, 4);
  EXPECT_EQ(ids(s().clusters().List(Rect{0, 0, 3, 1}, std::nullopt, 10, 0, &total)),
            (std::vector<int64_t>{1, 2, 4}));
  EXPECT_EQ(total, 3);
  EXPECT_EQ(ids(s().clusters().List(Rect{0, 0, 3, 1}, std::nullopt, 2, 1, &total)),
            (std::vector<int64_t>{2, 4}));
  EXPECT_EQ(total, 3);
  EXPECT_EQ(ids(s().clusters().List(std::nullopt, ClusterState::kConfirmed, 10, 0, &total)),
            (std::vector<int64_t>{2}));
  EXPECT_EQ(total, 1);
  EXPECT_TRUE(s().clusters().List(Rect{0, 0, 3, 1}, ClusterState::kApplied, 10, 0, &total).empty());
  EXPECT_EQ(total, 0);
  EXPECT_TRUE(s().clusters().List(std::nullopt, std::nullopt, 10, 7, &total).empty());
  EXPECT_EQ(total, 4);
}

}  // namespace
}  // namespace mapdelta::server::testing
