#pragma once
// A bounded pool of libpq connections: a PGconn serves one thread at a time, and the server
// calls storage from its HTTP threads and its job threads at once. A connection found broken
// when handed back (server restart, network) is dropped and the next Acquire opens a new one.
#include <condition_variable>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "pg_db.hpp"

namespace mapdelta::server::pg {

class Pool {
 public:
  // Opens one connection at once (so a bad URL fails here, at start); more on demand, up to
  // max_connections.
  Pool(std::string conninfo, int max_connections);

  class Lease {
   public:
    Lease(Pool& pool, std::unique_ptr<Connection> conn) : pool_(pool), conn_(std::move(conn)) {}
    ~Lease() { pool_.Release(std::move(conn_)); }
    Lease(const Lease&) = delete;
    Lease& operator=(const Lease&) = delete;
    Connection& operator*() { return *conn_; }
    Connection* operator->() { return conn_.get(); }

   private:
    Pool& pool_;
    std::unique_ptr<Connection> conn_;
  };

  // Blocks while all max_connections are in use.
  Lease Acquire();

 private:
  void Release(std::unique_ptr<Connection> conn);

  const std::string conninfo_;
  const int max_connections_;
  std::mutex mutex_;
  std::condition_variable released_;
  std::vector<std::unique_ptr<Connection>> idle_;
  int open_ = 0;  // idle + leased
};

}  // namespace mapdelta::server::pg
