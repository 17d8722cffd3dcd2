// PostgreSQL change clusters: the ClusterRows of cluster_rows.hpp as statements on the caller's
// connection and transaction, and the cluster store's reads. Writers of clusters (publishes in
// any process, admin decisions) take the feed's counter row FOR UPDATE first and hold it until
// they commit: their reads of a tile's clusters see every earlier writer's commit, and their
// sequence numbers are handed out in commit order.
#include "cluster_rows.hpp"
#include "storage_postgres.hpp"

namespace mapdelta::server {
namespace {

ChangeClusterRecord ReadCluster(const pg::Result& r, int row) {
  ChangeClusterRecord c;
  c.id = r.Int(row, 0);
  c.tile = TileId(static_cast<int32_t>(r.Int(row, 1)), static_cast<int32_t>(r.Int(row, 2)));
  c.kind = ParseEnumOrThrow<ClusterKind>(r.Text(row, 3), "change_clusters.kind");
  c.state = ParseEnumOrThrow<ClusterState>(r.Text(row, 4), "change_clusters.state");
  c.point_count = r.Int(row, 5);
  for (int i = 0; i < 3; ++i) {
    c.min[i] = r.Real(row, 6 + i);
    c.max[i] = r.Real(row, 9 + i);
    c.centroid[i] = r.Real(row, 12 + i);
  }
  c.voxels = r.Bytes(row, 15);
  c.evidence_json = r.Text(row, 16);
  c.prior_version = r.Int(row, 17);
  c.applied_version = r.OptInt(row, 18);
  c.created_ms = r.Int(row, 19);
  c.updated_ms = r.Int(row, 20);
  c.seq = r.Int(row, 21);
  return c;
}

std::vector<ChangeClusterRecord> ReadClusters(const pg::Result& r) {
  std::vector<ChangeClusterRecord> out;
  for (int i = 0; i < r.rows(); ++i) out.push_back(ReadCluster(r, i));
  return out;
}

// Every column but id, as $1..$22 (kClusterColumns without id, then tile).
pg::Params ClusterParams(const ChangeClusterRecord& c) {
  pg::Params p;
  p.Add(int64_t{c.tile.ix()})
      .Add(int64_t{c.tile.iy()})
      .Add(ToString(c.kind))
      .Add(ToString(c.state))
      .Add(c.point_count);
  for (const auto* v : {&c.min, &c.max, &c.centroid}) {
    for (int i = 0; i < 3; ++i) p.Add((*v)[i]);
  }
  p.Add(c.voxels).Add(c.evidence_json).Add(c.prior_version).Add(c.applied_version);
  p.Add(c.created_ms).Add(c.updated_ms).Add(c.seq).Add(c.tile.ToString());
  return p;
}

class PostgresClusterRows final : public ClusterRows {
 public:
  explicit PostgresClusterRows(pg::Connection& c) : c_(c) {}
  void LockFeed() override { c_.Query("SELECT last_seq FROM change_feed WHERE id = 1 FOR UPDATE"); }
  int64_t NextSeq() override {
    return c_
        .Query("UPDATE change_feed SET last_seq = last_seq + 1 WHERE id = 1 RETURNING last_seq")
        .Int(0, 0);
  }
  std::vector<ChangeClusterRecord> ActiveInTile(const TileId& tile) override {
    return ReadClusters(c_.Query(std::string("SELECT ") + kClusterColumns +
                                     " FROM change_clusters WHERE tile = $1 AND state <> "
                                     "'expired' ORDER BY id",
                                 pg::Params().Add(tile.ToString())));
  }
  std::vector<SessionFacts> TileSessions(const TileId& tile) override {
    const pg::Result r = c_.Query(
        "SELECT s.id, s.vehicle_id, s.created_ms, s.job_id, "
        "COALESCE(s.localization_weight, 1.0)::float8 FROM tile_sessions t "
        "JOIN sessions s ON s.id = t.session_id WHERE t.tile = $1 ORDER BY s.id",
        pg::Params().Add(tile.ToString()));
    std::vector<SessionFacts> out;
    for (int i = 0; i < r.rows(); ++i) {
      out.push_back({r.Int(i, 0), r.Text(i, 1), r.Int(i, 2), r.OptInt(i, 3), r.Real(i, 4)});
    }
    return out;
  }
  std::optional<ChangeClusterRecord> GetCluster(int64_t id) override {
    const pg::Result r =
        c_.Query(std::string("SELECT ") + kClusterColumns + " FROM change_clusters WHERE id = $1",
                 pg::Params().Add(id));
    if (r.rows() == 0) return std::nullopt;
    return ReadCluster(r, 0);
  }
  int64_t InsertCluster(const ChangeClusterRecord& c) override {
    return c_
        .Query(
            "INSERT INTO change_clusters (ix, iy, kind, state, point_count, min_x, min_y, min_z, "
            "max_x, max_y, max_z, centroid_x, centroid_y, centroid_z, voxels, evidence_json, "
            "prior_version, applied_version, created_ms, updated_ms, seq, tile) VALUES "
            "($1,$2,$3,$4,$5,$6,$7,$8,$9,$10,$11,$12,$13,$14,$15,$16,$17,$18,$19,$20,$21,$22) "
            "RETURNING id",
            ClusterParams(c))
        .Int(0, 0);
  }
  void UpdateCluster(const ChangeClusterRecord& c) override {
    pg::Params p = ClusterParams(c);
    p.Add(c.id);
    c_.Query(
        "UPDATE change_clusters SET ix = $1, iy = $2, kind = $3, state = $4, point_count = $5, "
        "min_x = $6, min_y = $7, min_z = $8, max_x = $9, max_y = $10, max_z = $11, "
        "centroid_x = $12, centroid_y = $13, centroid_z = $14, voxels = $15, "
        "evidence_json = $16, prior_version = $17, applied_version = $18, created_ms = $19, "
        "updated_ms = $20, seq = $21, tile = $22 WHERE id = $23",
        p);
  }
  void InsertTransition(const ClusterTransitionRecord& t) override {
    pg::Params p;
    p.Add(t.seq).Add(t.cluster_id);
    if (t.from)
      p.Add(ToString(*t.from));
    else
      p.AddNull();
    p.Add(ToString(t.to)).Add(t.at_ms).Add(t.cause).Add(t.job_id).Add(t.session_id).Add(t.actor);
    c_.Query(
        "INSERT INTO cluster_transitions (seq, cluster_id, from_state, to_state, at_ms, cause, "
        "job_id, session_id, actor) VALUES ($1,$2,$3,$4,$5,$6,$7,$8,$9)",
        p);
  }

 private:
  pg::Connection& c_;
};

}  // namespace

void pg_rows::LockClusterFeed(pg::Connection& c, const ClusterLifecycle* lifecycle) {
  if (lifecycle) PostgresClusterRows(c).LockFeed();
}

void pg_rows::ReconcileTileClusters(pg::Connection& c, const ClusterLifecycle* lifecycle,
                                    const TilePublication& publication) {
  if (!lifecycle) return;
  PostgresClusterRows rows(c);
  mapdelta::server::ReconcileTileClusters(*lifecycle, rows, publication);
}

std::optional<ChangeClusterRecord> PostgresClusterStore::Get(int64_t id) {
  auto c = Connect();
  return PostgresClusterRows(*c).GetCluster(id);
}

std::vector<ClusterTransitionRecord> PostgresClusterStore::History(int64_t id) {
  auto c = Connect();
  const pg::Result r = c->Query(
      "SELECT seq, cluster_id, from_state, to_state, at_ms, cause, job_id, session_id, actor "
      "FROM cluster_transitions WHERE cluster_id = $1 ORDER BY seq",
      pg::Params().Add(id));
  std::vector<ClusterTransitionRecord> out;
  for (int i = 0; i < r.rows(); ++i) {
    ClusterTransitionRecord t;
    t.seq = r.Int(i, 0);
    t.cluster_id = r.Int(i, 1);
    if (!r.IsNull(i, 2)) t.from = ParseEnumOrThrow<ClusterState>(r.Text(i, 2), "from_state");
    t.to = ParseEnumOrThrow<ClusterState>(r.Text(i, 3), "to_state");
    t.at_ms = r.Int(i, 4);
    t.cause = r.Text(i, 5);
    t.job_id = r.OptInt(i, 6);
    t.session_id = r.OptInt(i, 7);
    t.actor = r.Text(i, 8);
    out.push_back(std::move(t));
  }
  return out;
}

std::vector<ChangeClusterRecord> PostgresClusterStore::Feed(int64_t since, int64_t limit) {
  auto c = Connect();
  return ReadClusters(c->Query(std::string("SELECT ") + kClusterColumns +
                                   " FROM change_clusters WHERE seq > $1 ORDER BY seq LIMIT $2",
                               pg::Params().Add(since).Add(limit)));
}

int64_t PostgresClusterStore::LastSeq() {
  auto c = Connect();
  const pg::Result r = c->Query("SELECT last_seq FROM change_feed WHERE id = 1");
  return r.rows() > 0 ? r.Int(0, 0) : 0;
}

std::vector<ChangeClusterRecord> PostgresClusterStore::List(const std::optional<Rect>& rect,
                                                            std::optional<ClusterState> state,
                                                            int64_t limit, int64_t offset,
                                                            int64_t* total) {
  auto c = Connect();
  pg::Transaction tx(*c);
  c->Exec("SET TRANSACTION ISOLATION LEVEL REPEATABLE READ READ ONLY");  // count = page's view
  const std::string where =
      " FROM change_clusters WHERE ($1 = 0 OR (ix BETWEEN $2 AND $3 AND iy BETWEEN $4 AND $5)) "
      "AND ($6 = '' OR state = $6)";
  pg::Params p;
  p.Add(int64_t{rect ? 1 : 0});
  pg_rows::AddTileRange(p, rect.value_or(Rect{})).Add(std::string(state ? ToString(*state) : ""));
  *total = c->Query("SELECT COUNT(*)" + where, p).Int(0, 0);
  p.Add(limit).Add(offset);
  std::vector<ChangeClusterRecord> out = ReadClusters(c->Query(
      std::string("SELECT ") + kClusterColumns + where + " ORDER BY id LIMIT $7 OFFSET $8", p));
  tx.Commit();
  return out;
}

std::optional<ChangeClusterRecord> PostgresClusterStore::Transition(
    int64_t id, const std::vector<ClusterState>& from, ClusterTransitionRecord transition) {
  auto c = Connect();
  pg::Transaction tx(*c);
  PostgresClusterRows rows(*c);
  std::optional<ChangeClusterRecord> out = TransitionCluster(rows, id, from, transition);
  tx.Commit();
  return out;
}

}  // namespace mapdelta::server
