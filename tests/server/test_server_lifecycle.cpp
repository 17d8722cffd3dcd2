// Change clusters' lifecycle (issue #20) through the facade, on the in-memory storage, SQLite and
// PostgreSQL: real commits of the box scene (analytic depth; box A removed, box C added) by
// different vehicles, a refresh, and drives over the original scene again. Every transition:
// candidate -> confirmed (two vehicles), -> applied (refresh), -> expired (the place is back as
// before the refresh), candidate -> rejected (two vehicles see nothing there), and an admin's
// confirm / reject; the feed's order and cursor, also across a restart of the service on the
// same database.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <map>

#include "change_evidence.hpp"
#include "changed_scene.hpp"
#include "localization_quality.hpp"
#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/server/map_service.hpp"
#include "mapdelta/server/memory_storage.hpp"
#include "server_backends.hpp"

namespace mapdelta::server {
namespace {

namespace fs = std::filesystem;
using namespace mapdelta::testing;  // NOLINT: the shared test scene

ServerConfig LifecycleConfigFor(const fs::path& dir) {
  ServerConfig c;
  c.storage.database = (dir / "lifecycle.db").string();
  c.storage.tile_size_m = 20;
  c.pipeline.max_depth_m = kMaxDepth;
  c.pipeline.free_space_depth_m = 20;
  c.pipeline.pixel_stride = 1;
  c.pipeline.gicp_enabled = false;  // exact poses: the test is about the lifecycle
  c.classify.th_ch_m = 2.4;
  return c;
}

// Whether a cluster's box (user coordinates) comes within 1 m of the box.
bool Near(const Json& cluster, const Box& box) {
  const Json& b = cluster["bbox"];
  for (int i = 0; i < 3; ++i) {
    if (b[i].get<double>() > box.max[i] + 1 || b[i + 3].get<double>() < box.min[i] - 1)
      return false;
  }
  return true;
}

// How a drive's poses are uploaded: shifted along x from the truth the depth was rendered at
// (a badly localized vehicle), with a position standard deviation (0: no covariance).
struct Localization {
  double shift_x_m = 0, sigma_m = 0;
};

// One drive of `vehicle` along y = y_cam over `scene`, committed; returns the session id.
int64_t DriveOn(MapService& service, const std::string& vehicle, const BoxScene& scene,
                double y_cam, Localization loc = {}) {
  const Json camera{{"width", 160}, {"height", 90}, {"fx", 80}, {"fy", 80}, {"cx", 80}, {"cy", 45}};
  const int64_t s =
      service.CreateSession({{"vehicle_id", vehicle}, {"camera", camera}})["session_id"];
  int64_t seq = 0;
  for (double x = -5; x <= 45; x += 2.5, ++seq) {
    const SE3 T = CameraLookingMinusY(x, y_cam, kCameraHeight, kPitch);
    const auto png = EncodeDepthPng(scene.Render(TestCamera(), T, kMaxDepth));
    SE3 uploaded = T;
    uploaded.translation().x() += loc.shift_x_m;
    Json meta = MetaJson(1000000000LL * (seq + 1), uploaded);
    if (loc.sigma_m > 0) {
      Json cov = Json::array();
      for (int i = 0; i < 36; ++i) {
        cov.push_back(i % 7 != 0 ? 0.0 : i < 18 ? 1e-4 : loc.sigma_m * loc.sigma_m);
      }
      meta["covariance"] = cov;
    }
    bool created = false;
    service.PutKeyframe(s, seq, meta, Bytes(png.begin(), png.end()), &created);
  }
  const int64_t job = service.CommitSession(s)["job_id"];
  service.RunQueuedJobsNow();
  EXPECT_EQ(service.GetJob(job)["state"], "succeeded") << service.GetJob(job).dump(2);
  return s;
}

class Lifecycle : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    log::SetLevel(log::Level::kWarn);
    dir_ = fs::temp_directory_path() / ("mds_lifecycle_" + GetParam() + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    config_ = LifecycleConfigFor(dir_);
    if (GetParam() != "memory") UseFreshDatabase(GetParam(), dir_, &config_);
    Open();
    ImportPrior();
  }
  void ImportPrior() {
    const fs::path prior = dir_ / "prior.pcd";
    WriteCloud(prior.string(), PriorScene().Sample(0.5));
    service_->ImportPriorFile(prior.string(), "prior");
  }
  void TearDown() override {
    service_.reset();
    fs::remove_all(dir_);
  }
  void Open() {
    service_.reset();
    service_ = std::make_unique<MapService>(
        config_, GetParam() == "memory" ? OpenMemoryStorage() : OpenConfiguredStorage(config_));
  }

  int64_t Drive(const std::string& vehicle, const BoxScene& scene, double y_cam,
                Localization loc = {}) {
    return DriveOn(*service_, vehicle, scene, y_cam, loc);
  }
  Json Clusters(std::optional<std::string> state = std::nullopt) {
    return service_->ListClusters(std::nullopt, state, 1, 1000)["clusters"];
  }
  // The id of the cluster of `kind` nearest the box (most points among those near it), or -1.
  int64_t ClusterAt(const Box& box, const std::string& kind) {
    int64_t best = -1, most = 0;
    for (const Json& c : Clusters()) {
      if (c["kind"] != kind || !Near(c, box) || c["point_count"].get<int64_t>() <= most) continue;
      best = c["cluster_id"];
      most = c["point_count"];
    }
    return best;
  }
  std::string StateOf(int64_t id) { return service_->GetCluster(id)["state"]; }

  fs::path dir_;
  ServerConfig config_;
  std::unique_ptr<MapService> service_;
};

TEST_P(Lifecycle, ConfirmedByTwoVehiclesAppliedByRefreshExpiredWhenThePlaceIsBack) {
  // 1. One vehicle: candidates on box C (new) and box A (removed).
  const int64_t s1 = Drive("car-1", ChangedScene(), 25.0);
  const int64_t c = ClusterAt(kBoxC, "new"), a = ClusterAt(kBoxA, "removed");
  ASSERT_GT(c, 0) << Clusters().dump(1);
  ASSERT_GT(a, 0) << Clusters().dump(1);
  EXPECT_EQ(StateOf(c), "candidate");
  EXPECT_EQ(StateOf(a), "candidate");
  const Json created = service_->GetCluster(c);
  ASSERT_EQ(created["transitions"].size(), 1u);
  EXPECT_TRUE(created["transitions"][0]["from"].is_null());
  EXPECT_EQ(created["transitions"][0]["to"], "candidate");
  EXPECT_EQ(created["transitions"][0]["session_id"], s1);
  EXPECT_EQ(created["transitions"][0]["actor"], "job");
  EXPECT_EQ(created["evidence"]["supporting"]["sessions"], Json::array({s1}));
  EXPECT_GT(created["point_count"].get<int64_t>(), 20);

  // 2. A second vehicle: the same clusters (ids kept) are confirmed.
  const int64_t s2 = Drive("car-2", ChangedScene(), 24.0);
  EXPECT_EQ(ClusterAt(kBoxC, "new"), c);
  EXPECT_EQ(ClusterAt(kBoxA, "removed"), a);
  const Json confirmed = service_->GetCluster(c);
  EXPECT_EQ(confirmed["state"], "confirmed") << confirmed.dump(1);
  ASSERT_EQ(confirmed["transitions"].size(), 2u);
  EXPECT_EQ(confirmed["transitions"][1]["from"], "candidate");
  EXPECT_EQ(confirmed["transitions"][1]["session_id"], s2);
  EXPECT_NE(confirmed["transitions"][1]["cause"].get<std::string>().find(
                "supported by 2 sessions (" + std::to_string(s1) + ", " + std::to_string(s2) +
                ") from 2 vehicles"),
            std::string::npos)
      << confirmed["transitions"][1]["cause"];
  EXPECT_EQ(StateOf(a), "confirmed");

  // 3. A refresh merges them into prior version 2: applied.
  const int64_t refresh = service_->CreateJob(
      {{"type", "refresh"}, {"bbox", {-30, -10, 70, 40}}, {"min_confidence", 0.7}})["job_id"];
  service_->RunQueuedJobsNow();
  ASSERT_EQ(service_->GetJob(refresh)["state"], "succeeded");
  for (int64_t id : {c, a}) {
    const Json applied = service_->GetCluster(id);
    EXPECT_EQ(applied["state"], "applied") << applied.dump(1);
    EXPECT_EQ(applied["applied_version"], 2);
    const Json& last = applied["transitions"].back();
    EXPECT_EQ(last["from"], "confirmed");
    EXPECT_EQ(last["job_id"], refresh);
    EXPECT_NE(last["cause"].get<std::string>().find("into prior version 2"), std::string::npos);
  }

  // 4. Two drives over the original scene (box A back, box C gone): against version 2 that is
  // the opposite change where each applied cluster is, so both expire.
  Drive("car-3", PriorScene(), 25.0);
  Drive("car-4", PriorScene(), 24.0);
  for (int64_t id : {c, a}) {
    const Json expired = service_->GetCluster(id);
    EXPECT_EQ(expired["state"], "expired") << expired.dump(1);
    EXPECT_EQ(expired["transitions"].back()["from"], "applied");
  }
  // The reverse changes are clusters of their own.
  EXPECT_GT(ClusterAt(kBoxC, "removed"), c);
  EXPECT_GT(ClusterAt(kBoxA, "new"), a);
}

// With voxel consensus (the default) two vehicles that see C's place free outvote the one that
// filled it: its voxels leave the global cloud, the new points are no longer detected, and the
// candidate is rejected for that. Without it the points stay and the two contradict them.
TEST_P(Lifecycle, AFilledPlaceTwoVehiclesSeeFreeIsNoLongerDetectedAndItsCandidateRejected) {
  Drive("car-1", ChangedScene(), 25.0);
  const int64_t c = ClusterAt(kBoxC, "new");
  ASSERT_GT(c, 0);
  Drive("car-2", PriorScene(), 25.0);
  Drive("car-3", PriorScene(), 24.0);
  const Json rejected = service_->GetCluster(c);
  EXPECT_EQ(rejected["state"], "rejected") << rejected.dump(1);
  EXPECT_NE(rejected["transitions"].back()["cause"].get<std::string>().find("no longer detects it"),
            std::string::npos)
      << rejected.dump(1);
}

TEST_P(Lifecycle, ContradictedCandidatesAreRejectedAndAnAdminDecidesByHand) {
  config_.classify.voxel_consensus = false;  // keep C's voxels: the evidence path is tested
  Open();
  if (GetParam() == "memory") ImportPrior();  // a new in-memory storage is empty
  const int64_t s1 = Drive("car-1", ChangedScene(), 25.0);
  const int64_t c = ClusterAt(kBoxC, "new"), a = ClusterAt(kBoxA, "removed");
  ASSERT_GT(c, 0);
  ASSERT_GT(a, 0);
  const int64_t a_points = service_->GetCluster(a)["point_count"];
  // Two other vehicles see the prior's scene: nothing on C's place, box A standing.
  const int64_t s2 = Drive("car-2", PriorScene(), 25.0);
  const int64_t s3 = Drive("car-3", PriorScene(), 24.0);
  const Json rejected = service_->GetCluster(c);
  EXPECT_EQ(rejected["state"], "rejected") << rejected.dump(1);
  EXPECT_EQ(rejected["evidence"]["supporting"]["sessions"], Json::array({s1}));
  EXPECT_EQ(rejected["evidence"]["contradicting"]["sessions"], Json::array({s2, s3}));
  EXPECT_NE(rejected["transitions"].back()["cause"].get<std::string>().find("contradicted by 2"),
            std::string::npos);
  // Box A is seen standing again: what is left removed is its back, which only the first
  // vehicle's rays crossed (the others cannot see behind the box), so it stays a candidate.
  EXPECT_EQ(StateOf(a), "candidate");
  EXPECT_LT(service_->GetCluster(a)["point_count"].get<int64_t>(), a_points);

  // An admin confirms the rejected one; confirming it again or rejecting an unknown one fails.
  const Json by_hand = service_->DecideCluster(c, ClusterState::kConfirmed,
                                               {{"cause", "surveyed: the shed is there"}}, "ops");
  EXPECT_EQ(by_hand["state"], "confirmed");
  EXPECT_EQ(by_hand["transitions"].back()["actor"], "admin:ops");
  EXPECT_EQ(by_hand["transitions"].back()["cause"], "surveyed: the shed is there");
  EXPECT_TRUE(by_hand["transitions"].back()["job_id"].is_null());
  const auto expect_code = [&](ApiCode code, auto fn) {
    try {
      fn();
      ADD_FAILURE() << "accepted";
    } catch (const ApiError& e) {
      EXPECT_EQ(e.code(), code) << e.what();
    }
  };
  expect_code(ApiCode::kClusterState, [&] {
    service_->DecideCluster(c, ClusterState::kConfirmed, {{"cause", "again"}}, "ops");
  });
  expect_code(ApiCode::kNotFound, [&] {
    service_->DecideCluster(999999, ClusterState::kRejected, {{"cause", "x"}}, "ops");
  });
  expect_code(ApiCode::kInvalidArgument,
              [&] { service_->DecideCluster(c, ClusterState::kRejected, Json::object(), "ops"); });
  expect_code(ApiCode::kInvalidArgument, [&] {
    service_->DecideCluster(c, ClusterState::kRejected, {{"cause", ""}}, "ops");
  });
  expect_code(ApiCode::kInvalidArgument, [&] {
    service_->DecideCluster(c, ClusterState::kRejected, {{"cause", "x"}, {"why", 1}}, "ops");
  });
  const Json by_admin =
      service_->DecideCluster(c, ClusterState::kRejected, {{"cause", "a parked trailer"}}, "ops");
  EXPECT_EQ(by_admin["state"], "rejected");
  EXPECT_EQ(by_admin["transitions"].back()["from"], "confirmed");

  // A reclassify with th_ch 10 m no longer finds box A's back removed (the standing front is
  // within 10 m): the candidate whose supporting session is still in the tile is rejected.
  const int64_t reclassify =
      service_->CreateJob({{"type", "reclassify"}, {"params", {{"th_ch_m", 10.0}}}})["job_id"];
  service_->RunQueuedJobsNow();
  ASSERT_EQ(service_->GetJob(reclassify)["state"], "succeeded");
  const Json vanished = service_->GetCluster(a);
  EXPECT_EQ(vanished["state"], "rejected") << vanished.dump(1);
  EXPECT_EQ(vanished["transitions"].back()["job_id"], reclassify);
  EXPECT_NE(vanished["transitions"].back()["cause"].get<std::string>().find("no longer detects it"),
            std::string::npos);
  EXPECT_EQ(StateOf(c), "rejected") << "a rejected cluster moved without a decision";
}

// A refresh with confirmed_only merges the changes of confirmed clusters only: with one vehicle's
// candidates nothing, after a second vehicle confirmed them box C and box A's removal.
TEST_P(Lifecycle, ARefreshOfConfirmedClustersOnlyWaitsForTheirConfirmation) {
  const Json refresh{{"type", "refresh"},
                     {"bbox", {-30, -10, 70, 40}},
                     {"min_confidence", 0.0},
                     {"confirmed_only", true}};
  Drive("car-1", ChangedScene(), 25.0);
  const int64_t c = ClusterAt(kBoxC, "new");
  ASSERT_GT(c, 0);
  const int64_t early = service_->CreateJob(refresh)["job_id"];
  service_->RunQueuedJobsNow();
  const Json not_yet = service_->GetJob(early);
  ASSERT_EQ(not_yet["state"], "succeeded");
  EXPECT_EQ(not_yet["result"]["prior_version"], 1) << not_yet.dump(1);
  EXPECT_EQ(service_->storage().priors().LatestVersion(), 1);
  EXPECT_EQ(StateOf(c), "candidate");

  Drive("car-2", ChangedScene(), 24.0);
  ASSERT_EQ(StateOf(c), "confirmed");
  const int64_t job = service_->CreateJob(refresh)["job_id"];
  service_->RunQueuedJobsNow();
  const Json merged = service_->GetJob(job);
  ASSERT_EQ(merged["state"], "succeeded");
  EXPECT_EQ(merged["result"]["prior_version"], 2);
  EXPECT_EQ(merged["result"]["confirmed_only"], true);
  EXPECT_EQ(StateOf(c), "applied");
  for (const Json& t : merged["result"]["tiles"]) {
    EXPECT_GT(t["added"].get<int64_t>() + t["removed"].get<int64_t>(), 0) << t.dump();
  }
  // The job's parameters are checked before it is queued.
  for (const Json& bad :
       {Json{{"type", "refresh"}, {"bbox", {0, 0, 1, 1}}, {"confirmed_only", "yes"}},
        Json{{"type", "reclassify"}, {"confirmed_only", true}},
        Json{{"type", "rollback"}, {"version", 1}, {"confirmed_only", true}}}) {
    EXPECT_THROW(service_->CreateJob(bad), ApiError) << bad.dump();
  }
}

// A rollback takes the map back to an older version's content, so the clusters a later refresh
// applied are no longer applied (back to confirmed, the state they had); rolling forward to the
// refresh's version again re-applies them. Each is one transition by the rollback job.
TEST_P(Lifecycle, ARollbackUnappliesTheClustersItsTargetDoesNotHoldAndRollingForwardReappliesThem) {
  Drive("car-1", ChangedScene(), 25.0);
  Drive("car-2", ChangedScene(), 24.0);
  const int64_t c = ClusterAt(kBoxC, "new"), a = ClusterAt(kBoxA, "removed");
  ASSERT_EQ(StateOf(c), "confirmed");
  ASSERT_EQ(StateOf(a), "confirmed");
  auto run = [&](const Json& body) {
    const int64_t job = service_->CreateJob(body)["job_id"];
    service_->RunQueuedJobsNow();
    const Json done = service_->GetJob(job);
    EXPECT_EQ(done["state"], "succeeded") << done.dump(1);
    return done;
  };
  run({{"type", "refresh"}, {"bbox", {-30, -10, 70, 40}}, {"confirmed_only", true}});
  ASSERT_EQ(StateOf(c), "applied");
  const size_t applied_transitions = service_->GetCluster(c)["transitions"].size();

  const Json back = run({{"type", "rollback"}, {"version", 1}});
  EXPECT_EQ(back["result"]["prior_version"], 3);
  EXPECT_GE(back["result"]["clusters"]["unapplied"].get<int64_t>(), 2) << back.dump(1);
  EXPECT_EQ(back["result"]["clusters"]["reapplied"], 0);
  for (int64_t id : {c, a}) {
    const Json cluster = service_->GetCluster(id);
    EXPECT_EQ(cluster["state"], "confirmed") << cluster.dump(1);
    EXPECT_EQ(cluster["applied_version"], 2);  // kept: the refresh that merged it
    ASSERT_EQ(cluster["transitions"].size(), applied_transitions + 1);
    const Json& last = cluster["transitions"].back();
    EXPECT_EQ(last["from"], "applied");
    EXPECT_EQ(last["job_id"], back["job_id"]);
    EXPECT_NE(last["cause"].get<std::string>().find("does not hold refresh version 2"),
              std::string::npos)
        << last["cause"];
  }
  // Nothing applied is left for a rollback to 1 to undo: a second one changes no cluster.
  const Json again = run({{"type", "rollback"}, {"version", 1}});
  EXPECT_EQ(again["result"]["clusters"]["unapplied"], 0);
  EXPECT_EQ(service_->GetCluster(c)["transitions"].size(), applied_transitions + 1);

  // Version 2 holds the refresh's merge: rolling forward to it applies them again.
  const Json forward = run({{"type", "rollback"}, {"version", 2}});
  EXPECT_GE(forward["result"]["clusters"]["reapplied"].get<int64_t>(), 2) << forward.dump(1);
  for (int64_t id : {c, a}) {
    const Json cluster = service_->GetCluster(id);
    EXPECT_EQ(cluster["state"], "applied") << cluster.dump(1);
    EXPECT_NE(cluster["transitions"].back()["cause"].get<std::string>().find(
                  "holds refresh version 2's merge of this change again"),
              std::string::npos);
  }
}

// The tile change query's state filter gives the points of the clusters in those states, each
// with its cluster id, and as many as the cluster counts.
TEST_P(Lifecycle, TileChangesFilteredByClusterStateAreThePointsOfThoseClusters) {
  auto points_by_cluster = [&](const std::string& states) {
    std::map<int64_t, int64_t> count;
    const Json tiles = service_->ListChangedTiles("-1000,-1000,1000,1000", 0.0, 1, 1000)["tiles"];
    for (const Json& t : tiles) {
      const FilePayload p = service_->GetTileChanges(t["tile"], "json", "", 0.0, 0, states);
      const Json j = Json::parse(std::string(p.bytes.begin(), p.bytes.end()));
      for (const char* kind : {"new", "removed"}) {
        for (const Json& point : j[kind]) {
          const Json cluster = service_->GetCluster(point["cluster_id"]);
          EXPECT_EQ(cluster["kind"], kind);
          EXPECT_NE(states.find(cluster["state"].get<std::string>()), std::string::npos);
          ++count[point["cluster_id"].get<int64_t>()];
        }
      }
    }
    return count;
  };
  Drive("car-1", ChangedScene(), 25.0);
  EXPECT_TRUE(points_by_cluster("confirmed").empty());
  const std::map<int64_t, int64_t> candidates = points_by_cluster("candidate");
  EXPECT_GE(candidates.size(), 2u);
  for (const auto& [id, n] : candidates) EXPECT_EQ(service_->GetCluster(id)["point_count"], n);

  Drive("car-2", ChangedScene(), 24.0);
  const std::map<int64_t, int64_t> confirmed = points_by_cluster("confirmed");
  EXPECT_TRUE(confirmed.count(ClusterAt(kBoxC, "new")));
  EXPECT_TRUE(confirmed.count(ClusterAt(kBoxA, "removed")));
  for (const auto& [id, n] : confirmed) EXPECT_EQ(service_->GetCluster(id)["point_count"], n);
  EXPECT_EQ(points_by_cluster("candidate,confirmed").size(),
            points_by_cluster("candidate").size() + confirmed.size());

  const std::string tile =
      service_->ListChangedTiles("-1000,-1000,1000,1000", 0.0, 1, 1)["tiles"][0]["tile"];
  for (const char* bad : {"", "confirmed,", "bogus", "confirmed,,applied"}) {
    EXPECT_THROW(service_->GetTileChanges(tile, "json", "", 0.0, 0, std::string(bad)), ApiError)
        << bad;
  }
}

TEST_P(Lifecycle, TheFeedListsEachChangedClusterOnceInOrderAndItsCursorSurvivesARestart) {
  if (GetParam() == "memory") GTEST_SKIP() << "nothing survives a restart in memory";
  Drive("car-1", ChangedScene(), 25.0);
  Drive("car-2", ChangedScene(), 24.0);
  // Paged one at a time: the same clusters as one big page, each once, seq increasing.
  const Json all = service_->ChangeFeed(std::nullopt, std::string("1000"));
  ASSERT_GE(all["clusters"].size(), 2u);
  EXPECT_FALSE(all["more"].get<bool>());
  std::vector<int64_t> paged;
  std::string cursor = "0";
  for (int guard = 0; guard < 1000; ++guard) {
    const Json page = service_->ChangeFeed(cursor, std::string("1"));
    if (page["clusters"].empty()) {
      EXPECT_EQ(page["next"].get<int64_t>(), std::stoll(cursor)) << "an empty page moved on";
      break;
    }
    ASSERT_EQ(page["clusters"].size(), 1u);
    EXPECT_GT(page["next"].get<int64_t>(), std::stoll(cursor));
    EXPECT_EQ(page["next"], page["clusters"][0]["seq"]);
    paged.push_back(page["clusters"][0]["cluster_id"]);
    cursor = std::to_string(page["next"].get<int64_t>());
  }
  std::vector<int64_t> whole;
  int64_t previous = 0;
  for (const Json& c : all["clusters"]) {
    whole.push_back(c["cluster_id"]);
    EXPECT_GT(c["seq"].get<int64_t>(), previous);
    previous = c["seq"];
  }
  EXPECT_EQ(paged, whole);
  const std::string end = cursor;

  // A restart on the same database: the cursor still means the same position, and the changes
  // made afterwards come after it.
  Open();
  EXPECT_TRUE(service_->ChangeFeed(end, std::nullopt)["clusters"].empty());
  EXPECT_EQ(service_->ChangeFeed(std::string("0"), std::string("1000"))["clusters"],
            all["clusters"]);
  const int64_t rejected = whole.front();
  service_->DecideCluster(rejected, ClusterState::kRejected, {{"cause", "after the restart"}},
                          "ops");
  const Json after = service_->ChangeFeed(end, std::nullopt);
  ASSERT_EQ(after["clusters"].size(), 1u);
  EXPECT_EQ(after["clusters"][0]["cluster_id"], rejected);
  EXPECT_EQ(after["clusters"][0]["state"], "rejected");
  EXPECT_EQ(after["next"].get<int64_t>(), std::stoll(end) + 1);
}

// Issue #20 item 2: two vehicles whose uploaded poses are 2 m off (and say so in their
// covariance, sigma 1.5 m) see the prior's boxes displaced: false changes. Weighted by their
// localization they cannot confirm them (beside them the same drives with a small covariance do,
// which is what the weighting prevents); a well-localized vehicle then rejects those it
// contradicts, and after two of them none of the false changes is confirmed.
TEST_P(Lifecycle, ShiftedSessionsCannotConfirmAFalseChangeThatWellLocalizedOnesContradict) {
  config_.classify.th_ch_m = 1.0;  // below the shift: displaced surfaces are changes
  Open();
  if (GetParam() == "memory") ImportPrior();  // a new in-memory storage is empty
  const Localization shifted{2.0, 1.5}, overconfident{2.0, 0.05};
  const auto confirmed_count = [](MapService& service) {
    return service.ListClusters(std::nullopt, std::string("confirmed"), 1, 1000)["total"]
        .get<int64_t>();
  };
  {  // the control: the same shifted drives claiming to be well localized
    ServerConfig control = config_;
    MapService blind(control, OpenMemoryStorage());
    const fs::path prior = dir_ / "control.pcd";
    WriteCloud(prior.string(), PriorScene().Sample(0.5));
    blind.ImportPriorFile(prior.string(), "prior");
    DriveOn(blind, "car-1", PriorScene(), 25.0, overconfident);
    DriveOn(blind, "car-2", PriorScene(), 24.0, overconfident);
    ASSERT_GT(confirmed_count(blind), 0) << "the shift makes no false change to guard against";
  }
  const int64_t s1 = Drive("car-1", PriorScene(), 25.0, shifted);
  Drive("car-2", PriorScene(), 24.0, shifted);
  ASSERT_GT(Clusters().size(), 0u) << "the shifted drives show no false change";
  EXPECT_EQ(confirmed_count(*service_), 0) << Clusters().dump(1);
  const std::optional<std::string> report =
      service_->storage().sessions().Get(s1)->localization_json;
  ASSERT_TRUE(report);
  EXPECT_DOUBLE_EQ(Json::parse(*report)["weight"].get<double>(), kMinSessionWeight);
  EXPECT_DOUBLE_EQ(Json::parse(*report)["position_sigma_m"].get<double>(), 1.5);
  EXPECT_EQ(service_->GetSession(s1)["localization"], Json::parse(*report));

  // Well-localized vehicles: every false cluster one of them contradicts is rejected, its support
  // being only the shifted sessions' 2 x 0.25. (Voxel consensus leaves out the shifted sessions'
  // points where the good sessions' surfaces are, so most false clusters shrink or vanish
  // instead: no longer detected, they are rejected too.)
  std::vector<int64_t> false_clusters;
  for (const Json& c : Clusters()) false_clusters.push_back(c["cluster_id"]);
  const int64_t s3 = Drive("car-3", PriorScene(), 25.0, Localization{0, 0.05});
  Drive("car-4", PriorScene(), 24.0);
  int contradicted = 0;
  for (const Json& c : Clusters()) {
    const Json& against = c["evidence"]["contradicting"]["sessions"];
    if (std::find(against.begin(), against.end(), s3) == against.end()) continue;
    ++contradicted;
    EXPECT_EQ(c["state"], "rejected") << c.dump(1);
    EXPECT_DOUBLE_EQ(c["evidence"]["supporting"]["weight"].get<double>(), 2 * kMinSessionWeight)
        << c.dump(1);
    EXPECT_EQ(c["evidence"]["contradicting"]["vehicles"][0], "car-3");
  }
  EXPECT_GT(contradicted, 0) << Clusters().dump(1);
  for (int64_t id : false_clusters) EXPECT_NE(StateOf(id), "confirmed") << id;
}

INSTANTIATE_TEST_SUITE_P(Backends, Lifecycle, ::testing::Values("memory", "sqlite", "postgres"),
                         [](const auto& info) { return info.param; });

// Independence by days: one vehicle on two UTC days confirms; on one day it does not.
TEST(ClusterEvidence, SessionsOfOneVehicleOnDifferentDaysAreIndependent) {
  LifecycleConfig config;  // k = 2 sessions, m = 2 vehicles or days
  ExtractedCluster cluster;
  cluster.by_session[1] = {4, 4};
  cluster.by_session[2] = {4, 3};
  cluster.by_session[3] = {4, 1};  // observes it, supports a quarter: contradicts
  constexpr int64_t kDay = 86'400'000;
  const std::vector<SessionFacts> same_day = {{1, "car", 10 * kDay + 5, {}, 1.0},
                                              {2, "car", 10 * kDay + 9, {}, 1.0},
                                              {3, "van", 10 * kDay, {}, 1.0}};
  const ClusterEvidence one_day = EvidenceOf(cluster, same_day);
  EXPECT_EQ(one_day.supporting.sessions, (std::vector<int64_t>{1, 2}));
  EXPECT_EQ(one_day.contradicting.sessions, (std::vector<int64_t>{3}));
  EXPECT_FALSE(EvidenceTransition(ClusterState::kCandidate, one_day, config));

  std::vector<SessionFacts> two_days = same_day;
  two_days[1].created_ms = 11 * kDay + 9;
  const ClusterEvidence independent = EvidenceOf(cluster, two_days);
  EXPECT_EQ(independent.supporting.days, (std::set<std::string>{"1970-01-11", "1970-01-12"}));
  const auto change = EvidenceTransition(ClusterState::kCandidate, independent, config);
  ASSERT_TRUE(change);
  EXPECT_EQ(change->to, ClusterState::kConfirmed);
  EXPECT_FALSE(EvidenceTransition(ClusterState::kConfirmed, independent, config))
      << "one contradicting session expired a confirmed cluster";
  config.confirm_sessions = 3;
  EXPECT_FALSE(EvidenceTransition(ClusterState::kCandidate, independent, config));
}

// Localization weights: the rule of localization_quality.hpp, and what they do to evidence.
TEST(ClusterEvidence, PoorlyLocalizedSessionsWeighLessAndCannotMakeEvidenceIndependent) {
  PipelineConfig p;  // gicp_max_fitness_m 1.0
  EXPECT_DOUBLE_EQ(AssessLocalization({{"status", "skipped"}}, {}, p).weight, 1.0);
  EXPECT_DOUBLE_EQ(AssessLocalization({{"status", "rejected"}}, {}, p).weight, kMinSessionWeight);
  EXPECT_DOUBLE_EQ(AssessLocalization({{"status", "accepted"}, {"fitness_m", 0.3}}, {}, p).weight,
                   1.0);
  EXPECT_NEAR(AssessLocalization({{"status", "accepted"}, {"fitness_m", 0.75}}, {}, p).weight, 0.75,
              1e-12);
  EXPECT_DOUBLE_EQ(AssessLocalization({{"status", "skipped"}}, {0.1, 0.2, 5.0}, p).weight, 1.0)
      << "the median, not one bad keyframe";
  EXPECT_NEAR(AssessLocalization({{"status", "skipped"}}, {0.65}, p).weight, 0.625, 1e-12);
  EXPECT_DOUBLE_EQ(AssessLocalization({{"status", "skipped"}}, {1.5, 2.0}, p).weight,
                   kMinSessionWeight);
  EXPECT_DOUBLE_EQ(
      AssessLocalization({{"status", "accepted"}, {"fitness_m", 0.75}}, {1.5}, p).weight,
      kMinSessionWeight)
      << "the smaller of the two";
  Json cov = Json::array();
  for (int i = 0; i < 36; ++i) cov.push_back(i == 21 ? 0.04 : i == 35 ? 0.25 : 0.0);
  EXPECT_DOUBLE_EQ(*PositionSigma(cov.dump()), 0.5);
  EXPECT_FALSE(PositionSigma("null"));

  LifecycleConfig config;
  ExtractedCluster cluster;
  cluster.by_session[1] = {2, 2};
  cluster.by_session[2] = {2, 2};
  const std::vector<SessionFacts> poor = {{1, "car-1", 0, {}, 0.25}, {2, "car-2", 0, {}, 0.25}};
  const ClusterEvidence e = EvidenceOf(cluster, poor);
  EXPECT_DOUBLE_EQ(e.supporting.weight, 0.5);
  EXPECT_TRUE(e.supporting.vehicles.empty());
  EXPECT_FALSE(EvidenceTransition(ClusterState::kCandidate, e, config));
  const std::vector<SessionFacts> good = {{1, "car-1", 0, {}, 1.0}, {2, "car-2", 0, {}, 0.6}};
  EXPECT_FALSE(EvidenceTransition(ClusterState::kCandidate, EvidenceOf(cluster, good), config))
      << "a weight of 1.6 confirmed with k = 2";
  config.confirm_sessions = 1;
  EXPECT_TRUE(EvidenceTransition(ClusterState::kCandidate, EvidenceOf(cluster, good), config));
}

}  // namespace
}  // namespace mapdelta::server
