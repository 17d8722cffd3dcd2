#pragma once
// Small RAII wrappers over the sqlite3 C API. Every result is checked: a failure throws
// mapdelta::Error naming the statement and SQLite's message. Only storage code includes this.
#include <sqlite3.h>

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace mapdelta::server::sql {

class Db;

class Stmt {
 public:
  Stmt(Db& db, std::string_view sql);
  ~Stmt();
  Stmt(const Stmt&) = delete;
  Stmt& operator=(const Stmt&) = delete;

  // Binds are 1-based as in SQLite. Returns *this to chain.
  Stmt& Bind(int index, int64_t value);
  Stmt& Bind(int index, double value);
  Stmt& Bind(int index, std::string_view text);
  Stmt& Bind(int index, const std::string& text) { return Bind(index, std::string_view(text)); }
  Stmt& Bind(int index, const char* text) { return Bind(index, std::string_view(text)); }
  Stmt& Bind(int index, const std::vector<uint8_t>& blob);
  Stmt& BindNull(int index);
  Stmt& Bind(int index, const std::optional<std::string>& text);

  // Steps once: true if a row is available, false when done.
  bool Step();
  // Runs to completion (for statements without rows).
  void Run();
  void Reset();

  bool IsNull(int col) const;
  int64_t Int(int col) const;
  double Real(int col) const;
  std::string Text(int col) const;
  std::optional<std::string> OptText(int col) const;
  std::vector<uint8_t> Blob(int col) const;

 private:
  Db& db_;
  sqlite3_stmt* stmt_ = nullptr;
  std::string sql_;
};

class Db {
 public:
  // Opens (creating if needed) with WAL, foreign keys, synchronous=FULL for durability of
  // acknowledged writes, and a busy timeout so concurrent writers wait instead of failing.
  explicit Db(const std::string& path);
  ~Db();
  Db(const Db&) = delete;
  Db& operator=(const Db&) = delete;

  void Exec(std::string_view sql);  // one or more statements, no rows
  int64_t LastInsertId() const;
  int Changes() const;
  sqlite3* handle() { return db_; }
  [[noreturn]] void Fail(int rc, std::string_view what) const;

 private:
  sqlite3* db_ = nullptr;
  std::string path_;
};

// BEGIN IMMEDIATE ... COMMIT; rolls back in the destructor unless Commit() was called.
class Transaction {
 public:
  explicit Transaction(Db& db);
  ~Transaction();
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;
  void Commit();

 private:
  Db& db_;
  bool done_ = false;
};

}  // namespace mapdelta::server::sql
