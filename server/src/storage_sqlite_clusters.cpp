// SQLite change clusters: the ClusterRows of cluster_rows.hpp as statements on the shared
// connection (inside the caller's BEGIN IMMEDIATE, which already makes writers take turns),
// and the cluster store's reads.
#include "cluster_rows.hpp"
#include "storage_sqlite.hpp"

namespace mapdelta::server {
namespace {

ChangeClusterRecord ReadCluster(const sql::Stmt& s) {
  ChangeClusterRecord c;
  c.id = s.Int(0);
  c.tile = TileId(static_cast<int32_t>(s.Int(1)), static_cast<int32_t>(s.Int(2)));
  c.kind = ParseEnumOrThrow<ClusterKind>(s.Text(3), "change_clusters.kind");
  c.state = ParseEnumOrThrow<ClusterState>(s.Text(4), "change_clusters.state");
  c.point_count = s.Int(5);
  for (int i = 0; i < 3; ++i) {
    c.min[i] = s.Real(6 + i);
    c.max[i] = s.Real(9 + i);
    c.centroid[i] = s.Real(12 + i);
  }
  c.voxels = s.Blob(15);
  c.evidence_json = s.Text(16);
  c.prior_version = s.Int(17);
  if (!s.IsNull(18)) c.applied_version = s.Int(18);
  c.created_ms = s.Int(19);
  c.updated_ms = s.Int(20);
  c.seq = s.Int(21);
  return c;
}

void BindOpt(sql::Stmt& s, int index, const std::optional<int64_t>& v) {
  if (v)
    s.Bind(index, *v);
  else
    s.BindNull(index);
}

// Binds every column but id, from index 1 (as kClusterColumns without id, in that order).
void BindCluster(sql::Stmt& s, const ChangeClusterRecord& c) {
  s.Bind(1, int64_t{c.tile.ix()})
      .Bind(2, int64_t{c.tile.iy()})
      .Bind(3, ToString(c.kind))
      .Bind(4, ToString(c.state))
      .Bind(5, c.point_count);
  for (int i = 0; i < 3; ++i) {
    s.Bind(6 + i, c.min[i]).Bind(9 + i, c.max[i]).Bind(12 + i, c.centroid[i]);
  }
  s.Bind(15, c.voxels).Bind(16, c.evidence_json).Bind(17, c.prior_version);
  BindOpt(s, 18, c.applied_version);
  s.Bind(19, c.created_ms).Bind(20, c.updated_ms).Bind(21, c.seq).Bind(22, c.tile.ToString());
}

class SqliteClusterRows final : public ClusterRows {
 public:
  explicit SqliteClusterRows(sql::Db& db) : db_(db) {}
  void LockFeed() override {}  // BEGIN IMMEDIATE holds SQLite's one write lock
  int64_t NextSeq() override {
    sql::Stmt s(db_,
                "UPDATE change_feed SET last_seq = last_seq + 1 WHERE id = 1 RETURNING last_seq");
    s.Step();
    return s.Int(0);
  }
  std::vector<ChangeClusterRecord> ActiveInTile(const TileId& tile) override {
    sql::Stmt s(db_, std::string("SELECT ") + kClusterColumns +
                         " FROM change_clusters WHERE tile = ? AND state <> 'expired' ORDER BY id");
    s.Bind(1, tile.ToString());
    std::vector<ChangeClusterRecord> out;
    while (s.Step()) out.push_back(ReadCluster(s));
    return out;
  }
  std::vector<SessionFacts> TileSessions(const TileId& tile) override {
    sql::Stmt s(db_,
                "SELECT s.id, s.vehicle_id, s.created_ms, s.job_id, "
                "COALESCE(s.localization_weight, 1.0) FROM tile_sessions t "
                "JOIN sessions s ON s.id = t.session_id WHERE t.tile = ? ORDER BY s.id");
    s.Bind(1, tile.ToString());
    std::vector<SessionFacts> out;
    while (s.Step()) {
      SessionFacts f{s.Int(0), s.Text(1), s.Int(2), std::nullopt, s.Real(4)};
      if (!s.IsNull(3)) f.job_id = s.Int(3);
      out.push_back(std::move(f));
    }
    return out;
  }
  std::optional<ChangeClusterRecord> GetCluster(int64_t id) override {
    sql::Stmt s(db_,
                std::string("SELECT ") + kClusterColumns + " FROM change_clusters WHERE id = ?");
    s.Bind(1, id);
    if (!s.Step()) return std::nullopt;
    return ReadCluster(s);
  }
  int64_t InsertCluster(const ChangeClusterRecord& c) override {
    sql::Stmt s(db_,
                "INSERT INTO change_clusters (ix, iy, kind, state, point_count, min_x, min_y, "
                "min_z, max_x, max_y, max_z, centroid_x, centroid_y, centroid_z, voxels, "
                "evidence_json, prior_version, applied_version, created_ms, updated_ms, seq, "
                "tile) VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?)");
    BindCluster(s, c);
    s.Run();
    return db_.LastInsertId();
  }
  void UpdateCluster(const ChangeClusterRecord& c) override {
    sql::Stmt s(db_,
                "UPDATE change_clusters SET ix = ?, iy = ?, kind = ?, state = ?, point_count = ?, "
                "min_x = ?, min_y = ?, min_z = ?, max_x = ?, max_y = ?, max_z = ?, "
                "centroid_x = ?, centroid_y = ?, centroid_z = ?, voxels = ?, evidence_json = ?, "
                "prior_version = ?, applied_version = ?, created_ms = ?, updated_ms = ?, "
                "seq = ?, tile = ? WHERE id = ?");
    BindCluster(s, c);
    s.Bind(23, c.id).Run();
  }
  void InsertTransition(const ClusterTransitionRecord& t) override {
    sql::Stmt s(db_,
                "INSERT INTO cluster_transitions (seq, cluster_id, from_state, to_state, at_ms, "
                "cause, job_id, session_id, actor) VALUES (?,?,?,?,?,?,?,?,?)");
    s.Bind(1, t.seq).Bind(2, t.cluster_id);
    if (t.from)
      s.Bind(3, ToString(*t.from));
    else
      s.BindNull(3);
    s.Bind(4, ToString(t.to)).Bind(5, t.at_ms).Bind(6, t.cause);
    BindOpt(s, 7, t.job_id);
    BindOpt(s, 8, t.session_id);
    s.Bind(9, t.actor).Run();
  }

 private:
  sql::Db& db_;
};

}  // namespace

void ReconcileTileClustersSqlite(sql::Db& db, const ClusterLifecycle* lifecycle,
                                 const TilePublication& publication) {
  if (!lifecycle) return;
  SqliteClusterRows rows(db);
  ReconcileTileClusters(*lifecycle, rows, publication);
}

std::optional<ChangeClusterRecord> SqliteClusterStore::Get(int64_t id) {
  auto lock = Lock();
  return SqliteClusterRows(db()).GetCluster(id);
}

std::vector<ClusterTransitionRecord> SqliteClusterStore::History(int64_t id) {
  auto lock = Lock();
  sql::Stmt s(db(),
              "SELECT seq, cluster_id, from_state, to_state, at_ms, cause, job_id, session_id, "
              "actor FROM cluster_transitions WHERE cluster_id = ? ORDER BY seq");
  s.Bind(1, id);
  std::vector<ClusterTransitionRecord> out;
  while (s.Step()) {
    ClusterTransitionRecord t;
    t.seq = s.Int(0);
    t.cluster_id = s.Int(1);
    if (!s.IsNull(2)) t.from = ParseEnumOrThrow<ClusterState>(s.Text(2), "from_state");
    t.to = ParseEnumOrThrow<ClusterState>(s.Text(3), "to_state");
    t.at_ms = s.Int(4);
    t.cause = s.Text(5);
    if (!s.IsNull(6)) t.job_id = s.Int(6);
    if (!s.IsNull(7)) t.session_id = s.Int(7);
    t.actor = s.Text(8);
    out.push_back(std::move(t));
  }
  return out;
}

std::vector<ChangeClusterRecord> SqliteClusterStore::Feed(int64_t since, int64_t limit) {
  auto lock = Lock();
  sql::Stmt s(db(), std::string("SELECT ") + kClusterColumns +
                        " FROM change_clusters WHERE seq > ? ORDER BY seq LIMIT ?");
  s.Bind(1, since).Bind(2, limit);
  std::vector<ChangeClusterRecord> out;
  while (s.Step()) out.push_back(ReadCluster(s));
  return out;
}

int64_t SqliteClusterStore::LastSeq() {
  auto lock = Lock();
  sql::Stmt s(db(), "SELECT last_seq FROM change_feed WHERE id = 1");
  return s.Step() ? s.Int(0) : 0;
}

std::vector<ChangeClusterRecord> SqliteClusterStore::List(const std::optional<Rect>& rect,
                                                          std::optional<ClusterState> state,
                                                          int64_t limit, int64_t offset,
                                                          int64_t* total) {
  auto lock = Lock();
  // Absent filters compare a column with itself (always true), so one statement serves all.
  const std::string where =
      " FROM change_clusters WHERE (? = 0 OR (ix BETWEEN ? AND ? AND iy BETWEEN ? AND ?)) "
      "AND (? = '' OR state = ?)";
  const auto bind = [&](sql::Stmt& s) {
    s.Bind(1, int64_t{rect ? 1 : 0});
    BindTileRange(s, 2, rect.value_or(Rect{}));
    const std::string name(state ? ToString(*state) : "");
    s.Bind(6, name).Bind(7, name);
  };
  {
    sql::Stmt c(db(), "SELECT COUNT(*)" + where);
    bind(c);
    c.Step();
    *total = c.Int(0);
  }
  sql::Stmt s(db(),
              std::string("SELECT ") + kClusterColumns + where + " ORDER BY id LIMIT ? OFFSET ?");
  bind(s);
  s.Bind(8, limit).Bind(9, offset);
  std::vector<ChangeClusterRecord> out;
  while (s.Step()) out.push_back(ReadCluster(s));
  return out;
}

std::optional<ChangeClusterRecord> SqliteClusterStore::Transition(
    int64_t id, const std::vector<ClusterState>& from, ClusterTransitionRecord transition) {
  auto lock = Lock();
  sql::Transaction tx(db());
  SqliteClusterRows rows(db());
  std::optional<ChangeClusterRecord> out = TransitionCluster(rows, id, from, transition);
  tx.Commit();
  return out;
}

}  // namespace mapdelta::server
