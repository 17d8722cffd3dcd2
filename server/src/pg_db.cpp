#include "pg_db.hpp"

#include <endian.h>

#include <bit>
#include <charconv>
#include <cstring>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"

namespace mapdelta::server::pg {
namespace {

// Built-in type OIDs (fixed by PostgreSQL; catalog/pg_type_d.h is in the server headers only).
constexpr Oid kBoolOid = 16, kByteaOid = 17, kNameOid = 19, kInt8Oid = 20, kInt2Oid = 21,
              kInt4Oid = 23, kTextOid = 25, kFloat4Oid = 700, kFloat8Oid = 701, kBpcharOid = 1042,
              kVarcharOid = 1043;
constexpr int kTextFormat = 0, kBinaryFormat = 1;

template <typename T>
T ReadBigEndian(const char* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  if constexpr (sizeof(T) == 2) return static_cast<T>(be16toh(static_cast<uint16_t>(v)));
  if constexpr (sizeof(T) == 4) return static_cast<T>(be32toh(static_cast<uint32_t>(v)));
  if constexpr (sizeof(T) == 8) return static_cast<T>(be64toh(static_cast<uint64_t>(v)));
}

std::string Shorten(std::string_view sql) { return OneLine(sql.substr(0, 160)); }

}  // namespace

std::string OneLine(std::string_view message) {
  std::string out;
  bool space = false;
  for (char c : message) {
    if (c == '\n' || c == '\r' || c == '\t' || c == ' ') {
      space = !out.empty();
      continue;
    }
    if (space) out += ' ';
    space = false;
    out += c;
  }
  return out;
}

std::string RedactConninfo(const std::string& conninfo) {
  char* error = nullptr;
  PQconninfoOption* options = PQconninfoParse(conninfo.c_str(), &error);
  if (!options) {
    const std::string why = error ? OneLine(error) : "out of memory";
    PQfreemem(error);
    return "(unparsable connection string: " + why + ")";
  }
  std::string out;
  for (PQconninfoOption* o = options; o->keyword; ++o) {
    if (!o->val || std::strcmp(o->keyword, "password") == 0) continue;
    if (!out.empty()) out += ' ';
    out += std::string(o->keyword) + "=" + o->val;
  }
  PQconninfoFree(options);
  return out;
}

// ---------------------------------------------------------------- Params

Params& Params::Add(int64_t value) {
  values_.emplace_back(std::to_string(value));
  lengths_.push_back(0);
  formats_.push_back(kTextFormat);
  return *this;
}

Params& Params::Add(double value) {
  char buf[64];
  // Shortest text that reads back to the same double, so nothing is lost on the way.
  const auto r = std::to_chars(buf, buf + sizeof(buf), value);
  values_.emplace_back(std::string(buf, r.ptr));
  lengths_.push_back(0);
  formats_.push_back(kTextFormat);
  return *this;
}

Params& Params::Add(std::string_view text) {
  values_.emplace_back(std::string(text));
  lengths_.push_back(0);
  formats_.push_back(kTextFormat);
  return *this;
}

Params& Params::Add(const std::vector<uint8_t>& bytes) {
  if (bytes.size() > kMaxByteaBytes) {
    throw Error(ErrorCode::kInvalidArgument, "postgres: a blob of " + std::to_string(bytes.size()) +
                                                 " bytes exceeds the bytea limit of " +
                                                 std::to_string(kMaxByteaBytes));
  }
  values_.emplace_back(std::string(bytes.begin(), bytes.end()));
  lengths_.push_back(static_cast<int>(bytes.size()));
  formats_.push_back(kBinaryFormat);
  return *this;
}

Params& Params::Add(const std::optional<std::string>& text) {
  return text ? Add(std::string_view(*text)) : AddNull();
}

Params& Params::Add(const std::optional<int64_t>& value) { return value ? Add(*value) : AddNull(); }

Params& Params::AddNull() {
  values_.emplace_back(std::nullopt);
  lengths_.push_back(0);
  formats_.push_back(kTextFormat);
  return *this;
}

const char* const* Params::values() const {
  pointers_.clear();
  for (const auto& v : values_) pointers_.push_back(v ? v->data() : nullptr);
  return pointers_.data();
}

// ---------------------------------------------------------------- Result

Result::Result(PGresult* result, std::string sql)
    : result_(result, PQclear), sql_(std::move(sql)) {}

int Result::rows() const { return PQntuples(result_.get()); }

int64_t Result::affected() const {
  const char* n = PQcmdTuples(result_.get());
  return (n && *n) ? std::strtoll(n, nullptr, 10) : 0;
}

void Result::WrongType(int col, const char* wanted) const {
  throw Error(ErrorCode::kInternal, "postgres: column " + std::to_string(col) + " has type oid " +
                                        std::to_string(PQftype(result_.get(), col)) + ", read as " +
                                        wanted + ", in: " + Shorten(sql_));
}

bool Result::IsNull(int row, int col) const { return PQgetisnull(result_.get(), row, col) != 0; }

int64_t Result::Int(int row, int col) const {
  const char* p = PQgetvalue(result_.get(), row, col);
  if (IsNull(row, col)) {
    throw Error(ErrorCode::kInternal, "postgres: NULL read as integer in: " + Shorten(sql_));
  }
  switch (PQftype(result_.get(), col)) {
    case kInt8Oid:
      return ReadBigEndian<int64_t>(p);
    case kInt4Oid:
      return ReadBigEndian<int32_t>(p);
    case kInt2Oid:
      return ReadBigEndian<int16_t>(p);
    default:
      WrongType(col, "integer");
  }
}

double Result::Real(int row, int col) const {
  const char* p = PQgetvalue(result_.get(), row, col);
  if (IsNull(row, col)) {
    throw Error(ErrorCode::kInternal, "postgres: NULL read as real in: " + Shorten(sql_));
  }
  switch (PQftype(result_.get(), col)) {
    case kFloat8Oid:
      return std::bit_cast<double>(ReadBigEndian<uint64_t>(p));
    case kFloat4Oid:
      return std::bit_cast<float>(ReadBigEndian<uint32_t>(p));
    default:
      WrongType(col, "real");
  }
}

bool Result::Bool(int row, int col) const {
  if (PQftype(result_.get(), col) != kBoolOid) WrongType(col, "bool");
  return !IsNull(row, col) && PQgetvalue(result_.get(), row, col)[0] != 0;
}

std::string Result::Text(int row, int col) const {
  const Oid type = PQftype(result_.get(), col);
  if (type != kTextOid && type != kVarcharOid && type != kNameOid && type != kBpcharOid) {
    WrongType(col, "text");
  }
  return std::string(PQgetvalue(result_.get(), row, col),
                     static_cast<size_t>(PQgetlength(result_.get(), row, col)));
}

std::optional<std::string> Result::OptText(int row, int col) const {
  if (IsNull(row, col)) return std::nullopt;
  return Text(row, col);
}

std::optional<int64_t> Result::OptInt(int row, int col) const {
  if (IsNull(row, col)) return std::nullopt;
  return Int(row, col);
}

std::vector<uint8_t> Result::Bytes(int row, int col) const {
  if (PQftype(result_.get(), col) != kByteaOid) WrongType(col, "bytea");
  const auto* p = reinterpret_cast<const uint8_t*>(PQgetvalue(result_.get(), row, col));
  return std::vector<uint8_t>(p, p + PQgetlength(result_.get(), row, col));
}

// ---------------------------------------------------------------- Connection

Connection::Connection(const std::string& conninfo)
    : conn_(PQconnectdb(conninfo.c_str()), PQfinish) {
  if (!conn_) throw Error(ErrorCode::kIo, "postgres: out of memory connecting");
  if (PQstatus(conn_.get()) != CONNECTION_OK) {
    throw Error(ErrorCode::kIo, "cannot connect to PostgreSQL (" + RedactConninfo(conninfo) +
                                    "): " + OneLine(PQerrorMessage(conn_.get())));
  }
  // Notices (e.g. "relation already exists, skipping") go to our log, not to stderr.
  PQsetNoticeProcessor(
      conn_.get(),
      [](void*, const char* message) { MD_LOG(kDebug, "postgres: " << OneLine(message)); },
      nullptr);
}

namespace {
[[noreturn]] void Fail(PGconn* conn, PGresult* result, std::string_view sql) {
  const char* state = result ? PQresultErrorField(result, PG_DIAG_SQLSTATE) : nullptr;
  const std::string sqlstate = state ? state : "";
  const std::string message = OneLine(result ? PQresultErrorMessage(result) : PQerrorMessage(conn));
  PQclear(result);
  // Class 23 = integrity constraint violation (unique, foreign key, check), as SQLITE_CONSTRAINT.
  const ErrorCode code = sqlstate.rfind("23", 0) == 0 ? ErrorCode::kConflict : ErrorCode::kIo;
  throw Error(code, "postgres error " + sqlstate + " (" + message + ") in: " + Shorten(sql));
}
}  // namespace

void Connection::Exec(std::string_view sql) {
  const std::string text(sql);
  PGresult* r = PQexec(conn_.get(), text.c_str());
  const ExecStatusType status = PQresultStatus(r);
  if (status != PGRES_COMMAND_OK && status != PGRES_TUPLES_OK) Fail(conn_.get(), r, sql);
  PQclear(r);
}

Result Connection::Query(std::string_view sql, const Params& params) {
  std::string text(sql);
  PGresult* r = PQexecParams(conn_.get(), text.c_str(), params.size(), nullptr, params.values(),
                             params.lengths(), params.formats(), kBinaryFormat);
  const ExecStatusType status = PQresultStatus(r);
  if (status != PGRES_COMMAND_OK && status != PGRES_TUPLES_OK) Fail(conn_.get(), r, sql);
  return Result(r, std::move(text));
}

// ---------------------------------------------------------------- Transaction

Transaction::Transaction(Connection& conn) : conn_(conn) { conn_.Exec("BEGIN"); }

Transaction::~Transaction() {
  if (done_) return;
  try {
    conn_.Exec("ROLLBACK");
  } catch (const std::exception& e) {
    MD_LOG(kError, "rollback failed: " << e.what());
  }
}

void Transaction::Commit() {
  conn_.Exec("COMMIT");
  done_ = true;
}

}  // namespace mapdelta::server::pg
