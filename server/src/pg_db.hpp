#pragma once
// Small RAII wrappers over libpq (PostgreSQL's C client), the counterpart of sqlite_db.hpp.
// Statements are parameterized ($1, $2, ...): numbers and text go as text, bytea as binary;
// results come back in binary format and are decoded by column type, so a column read as the
// wrong type is an error naming the statement, not a silent conversion. Every failure throws
// mapdelta::Error with the statement and PostgreSQL's message (unique violations as
// kConflict). Only storage code includes this.
#include <libpq-fe.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace mapdelta::server::pg {

// PostgreSQL's limit for one bytea value (1 GiB less the varlena header): a larger blob is
// refused before it is sent, with its size, instead of a protocol error from the server.
constexpr size_t kMaxByteaBytes = (size_t{1} << 30) - 4 - 1;

// Parameters of one statement, in $n order.
class Params {
 public:
  Params& Add(int64_t value);
  Params& Add(double value);
  Params& Add(std::string_view text);
  Params& Add(const std::string& text) { return Add(std::string_view(text)); }
  Params& Add(const char* text) { return Add(std::string_view(text)); }
  Params& Add(const std::vector<uint8_t>& bytes);  // bytea, sent binary
  Params& Add(const std::optional<std::string>& text);
  Params& Add(const std::optional<int64_t>& value);
  Params& AddNull();

  int size() const { return static_cast<int>(values_.size()); }
  const char* const* values() const;
  const int* lengths() const { return lengths_.data(); }
  const int* formats() const { return formats_.data(); }

 private:
  std::vector<std::optional<std::string>> values_;  // nullopt = SQL NULL
  std::vector<int> lengths_, formats_;
  mutable std::vector<const char*> pointers_;
};

class Result {
 public:
  Result(PGresult* result, std::string sql);
  int rows() const;
  int64_t affected() const;  // rows changed by INSERT/UPDATE/DELETE

  bool IsNull(int row, int col) const;
  int64_t Int(int row, int col) const;  // int2, int4, int8
  double Real(int row, int col) const;  // float4, float8
  bool Bool(int row, int col) const;
  std::string Text(int row, int col) const;  // text, varchar, name
  std::optional<std::string> OptText(int row, int col) const;
  std::optional<int64_t> OptInt(int row, int col) const;
  std::vector<uint8_t> Bytes(int row, int col) const;  // bytea; empty if NULL

 private:
  [[noreturn]] void WrongType(int col, const char* wanted) const;
  std::unique_ptr<PGresult, void (*)(PGresult*)> result_;
  std::string sql_;
};

class Connection {
 public:
  // Connects with a libpq connection string (URL or key=value). Throws Error(kIo) with
  // libpq's reason on one line and the target without its password.
  explicit Connection(const std::string& conninfo);
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;

  // One or more statements without parameters or rows (schema, BEGIN/COMMIT).
  void Exec(std::string_view sql);
  // One statement with parameters; rows or command status.
  Result Query(std::string_view sql, const Params& params = Params());
  // Connected and outside any transaction: safe to hand to the next caller.
  bool reusable() const {
    return PQstatus(conn_.get()) == CONNECTION_OK &&
           PQtransactionStatus(conn_.get()) == PQTRANS_IDLE;
  }

 private:
  std::unique_ptr<PGconn, void (*)(PGconn*)> conn_;
};

// BEGIN ... COMMIT; rolls back in the destructor unless Commit() was called.
class Transaction {
 public:
  explicit Transaction(Connection& conn);
  ~Transaction();
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;
  void Commit();

 private:
  Connection& conn_;
  bool done_ = false;
};

// The connection string without its password, for messages and logs ("host=... dbname=...").
std::string RedactConninfo(const std::string& conninfo);
// libpq's multi-line messages as one line.
std::string OneLine(std::string_view message);

}  // namespace mapdelta::server::pg
