// bench_load: many vehicles uploading at once to a running mapdelta-server on loopback, with
// readers of the change endpoints beside them (bench/load.sh starts a fresh server and runs
// this; bench/crash_soak.sh runs it with --retry while it kills and restarts the server).
// Each uploader drives sessions of --session-keyframes keyframes (160x90 analytic depth of
// the server tests' box scene), commits each one, and counts every keyframe the server
// acknowledged (201, or 200 for an identical retry). At the end it waits for every commit,
// checks that each session holds all its acknowledged keyframes, and prints keyframes/s,
// p50/p99 per endpoint, errors and the server's RSS over time. Exit status 1 if a keyframe
// was lost, a commit failed, or the server answered 5xx (or, without --retry, did not answer).
//   bench_load --port P --vehicle-token T --reader-token T [--uploaders 16] [--keyframes 500]
//              [--session-keyframes 100] [--readers 2] [--reader-interval-ms 50]
//              [--max-seconds 900] [--retry] [--server-pid-file F] [--dump-changes F]
//   bench_load --write-prior FILE.pcd
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <map>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "load/keyframe_lanes.hpp"
#include "load/load_client.hpp"
#include "load/rss_sampler.hpp"

namespace mb = mapdelta::bench;
using Json = nlohmann::json;
using Clock = std::chrono::steady_clock;

namespace {

struct Options {
  int port = 0;
  std::string vehicle_token, reader_token, pid_file, dump_changes, write_prior;
  int uploaders = 16, keyframes = 500, session_keyframes = 100, readers = 2,
      reader_interval_ms = 50;
  double max_seconds = 900;
  bool retry = false;
};

Options ParseOptions(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) throw std::runtime_error(a + " needs a value");
      return argv[++i];
    };
    if (a == "--port")
      o.port = std::stoi(next());
    else if (a == "--vehicle-token")
      o.vehicle_token = "Bearer " + next();
    else if (a == "--reader-token")
      o.reader_token = "Bearer " + next();
    else if (a == "--uploaders")
      o.uploaders = std::stoi(next());
    else if (a == "--keyframes")
      o.keyframes = std::stoi(next());
    else if (a == "--session-keyframes")
      o.session_keyframes = std::stoi(next());
    else if (a == "--readers")
      o.readers = std::stoi(next());
    else if (a == "--reader-interval-ms")
      o.reader_interval_ms = std::stoi(next());
    else if (a == "--max-seconds")
      o.max_seconds = std::stod(next());
    else if (a == "--retry")
      o.retry = true;
    else if (a == "--server-pid-file")
      o.pid_file = next();
    else if (a == "--dump-changes")
      o.dump_changes = next();
    else if (a == "--write-prior")
      o.write_prior = next();
    else
      throw std::runtime_error("unknown option " + a +
                               " (see the comment at the top of bench/bench_load.cpp)");
  }
  if (o.write_prior.empty() && (o.port <= 0 || o.vehicle_token.empty() || o.reader_token.empty())) {
    throw std::runtime_error("--port, --vehicle-token and --reader-token are required");
  }
  if (o.uploaders < 1 || o.keyframes < 1 || o.session_keyframes < 1)
    throw std::runtime_error("counts must be >= 1");
  return o;
}

struct SessionOutcome {
  int64_t id = 0;
  int acknowledged = 0;  // keyframes the server acknowledged
  bool commit_accepted = false;
};

// Shared state of one run.
struct Run {
  Options options;
  mb::LatencyBook book;
  Clock::time_point deadline;
  std::mutex mutex;
  std::vector<SessionOutcome> sessions;
  std::vector<std::string> problems;  // first unexpected answers, for the report
  std::atomic<int64_t> acknowledged{0};

  void Problem(const std::string& what, const mb::Answer& a) {
    std::lock_guard<std::mutex> lock(mutex);
    if (problems.size() < 20)
      problems.push_back(what + ": " + std::to_string(a.status) + " " + a.body.substr(0, 200));
  }
};

// Commits a session; with --retry a 409 after a lost answer means the first try got through.
bool Commit(Run& run, mb::LoadClient& c, int64_t session) {
  const std::string path = "/v1/sessions/" + std::to_string(session);
  const mb::Answer a = c.PostJson("POST commit", path + "/commit", run.options.vehicle_token, "");
  if (a.status == 202) return true;
  if (a.status == 409 && run.options.retry) {
    const mb::Answer s = c.Get("GET session", path, run.options.vehicle_token);
    if (s.status == 200 && Json::parse(s.body).value("state", "") != "open") return true;
  }
  run.Problem("commit of session " + std::to_string(session), a);
  return false;
}

void Upload(Run& run, int uploader, const mb::KeyframeLanes& lanes) {
  const Options& o = run.options;
  mb::LoadClient c("127.0.0.1", o.port, &run.book, o.retry, run.deadline);
  const std::string session_body = "{\"vehicle_id\":\"load-" + std::to_string(uploader) +
                                   "\",\"camera\":" + mb::KeyframeLanes::CameraJson() + "}";
  for (int done = 0; done < o.keyframes && Clock::now() < run.deadline;) {
    const mb::Answer created =
        c.PostJson("POST session", "/v1/sessions", o.vehicle_token, session_body);
    if (created.status != 201) {
      run.Problem("create session", created);
      return;
    }
    SessionOutcome s;
    s.id = Json::parse(created.body)["session_id"].get<int64_t>();
    const std::string prefix = "/v1/sessions/" + std::to_string(s.id) + "/keyframes/";
    const int count = std::min(o.session_keyframes, o.keyframes - done);
    for (int seq = 0; seq < count && Clock::now() < run.deadline; ++seq) {
      const mb::Answer a = c.PutKeyframe("PUT keyframe", prefix + std::to_string(seq),
                                         o.vehicle_token, lanes.Keyframe(uploader, seq));
      if (a.status != 201 && a.status != 200) {
        run.Problem("keyframe " + prefix + std::to_string(seq), a);
        break;  // the next seq would be out of order
      }
      ++s.acknowledged;
      ++run.acknowledged;
    }
    done += count;
    if (s.acknowledged > 0) s.commit_accepted = Commit(run, c, s.id);
    std::lock_guard<std::mutex> lock(run.mutex);
    run.sessions.push_back(s);
  }
}

// Lists changed tiles and fetches one tile's changes (and every 4th time its observed octree)
// in a loop until told to stop.
void Read(Run& run, const std::atomic<bool>& stop) {
  const Options& o = run.options;
  mb::LoadClient c("127.0.0.1", o.port, &run.book, o.retry, run.deadline);
  for (int64_t i = 0; !stop; ++i) {
    const mb::Answer list =
        c.Get("GET changes/tiles", "/v1/changes/tiles?bbox=-100,-100,100,100&page_size=100",
              o.reader_token);
    if (list.status != 200 && list.status != 0) run.Problem("list changed tiles", list);
    if (list.status == 200) {
      const Json tiles = Json::parse(list.body)["tiles"];
      if (!tiles.empty()) {
        const std::string tile = tiles[static_cast<size_t>(i) % tiles.size()]["tile"];
        const mb::Answer one =
            c.Get("GET changes/tiles/{t}", "/v1/changes/tiles/" + tile, o.reader_token);
        if (one.status != 200 && one.status != 0) run.Problem("tile changes " + tile, one);
        if (i % 4 == 0) {
          const mb::Answer bt =
              c.Get("GET observed/{t}.bt", "/v1/observed/tiles/" + tile + ".bt", o.reader_token);
          if (bt.status != 200 && bt.status != 404 && bt.status != 0)
            run.Problem("observed " + tile, bt);
        }
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(o.reader_interval_ms));
  }
}

struct Verdict {
  int64_t stored = 0, lost = 0, commits_failed = 0, commits_unfinished = 0;
};

// Waits until no session is committing, then compares stored keyframes with acknowledged ones.
Verdict WaitAndVerify(Run& run) {
  mb::LoadClient c("127.0.0.1", run.options.port, &run.book, run.options.retry,
                   run.deadline + std::chrono::minutes(10));
  Verdict v;
  for (const SessionOutcome& s : run.sessions) {
    const std::string path = "/v1/sessions/" + std::to_string(s.id);
    Json session;
    for (int tries = 0; tries < 6000; ++tries) {  // 10 min at most
      const mb::Answer a = c.Get("GET session", path, run.options.vehicle_token);
      if (a.status == 200) session = Json::parse(a.body);
      if (session.is_object() && session.value("state", "") != "committing") break;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    const int64_t count = session.is_object() ? session.value("keyframe_count", int64_t{0}) : 0;
    v.stored += count;
    v.lost += std::max<int64_t>(0, s.acknowledged - count);
    const std::string state = session.is_object() ? session.value("state", "?") : "?";
    if (s.commit_accepted && state == "committing")
      ++v.commits_unfinished;
    else if (s.commit_accepted && state != "committed")
      ++v.commits_failed;
  }
  return v;
}

}  // namespace

namespace {

void PrintRoutes(const mb::LatencyBook& book, int64_t* server_errors, int64_t* transport_errors) {
  std::printf("\n%-24s %8s %8s %6s %6s %9s %9s %9s %9s\n", "endpoint", "requests", "2xx", "4xx",
              "5xx", "no-answer", "p50_ms", "p99_ms", "max_ms");
  for (const auto& [route, s] : book.Snapshot()) {
    const int64_t n = s.ok + s.client_errors + s.server_errors + s.transport_errors;
    std::printf("%-24s %8lld %8lld %6lld %6lld %9lld %9.1f %9.1f %9.1f\n", route.c_str(),
                static_cast<long long>(n), static_cast<long long>(s.ok),
                static_cast<long long>(s.client_errors), static_cast<long long>(s.server_errors),
                static_cast<long long>(s.transport_errors), mb::Percentile(s.latencies_ms, 0.5),
                mb::Percentile(s.latencies_ms, 0.99), mb::Percentile(s.latencies_ms, 1.0));
    *server_errors += s.server_errors;
    *transport_errors += s.transport_errors;
  }
}

// About 20 evenly spaced samples and the peak.
void PrintRss(const std::vector<mb::RssSample>& samples) {
  if (samples.empty()) return;
  const size_t step = std::max<size_t>(1, samples.size() / 20);
  std::printf("\nserver RSS over time (MiB):");
  int64_t peak = 0;
  for (size_t i = 0; i < samples.size(); ++i) {
    peak = std::max(peak, samples[i].rss_kib);
    if (i % step == 0 || i + 1 == samples.size())
      std::printf(" %.0fs:%.0f", samples[i].t_s, samples[i].rss_kib / 1024.0);
  }
  std::printf("\nserver RSS peak: %.0f MiB, last: %.0f MiB\n", peak / 1024.0,
              samples.back().rss_kib / 1024.0);
}

// The changed tiles with their counts and confidence, sorted, one per line: what the soak
// compares between a killed and an uninterrupted run (times and ids left out).
bool DumpChanges(Run& run, const std::string& file) {
  mb::LoadClient c("127.0.0.1", run.options.port, &run.book, run.options.retry,
                   Clock::now() + std::chrono::minutes(2));
  const mb::Answer a =
      c.Get("GET changes/tiles", "/v1/changes/tiles?bbox=-1000,-1000,1000,1000&page_size=1000",
            run.options.reader_token);
  if (a.status != 200) return false;
  std::map<std::string, std::string> lines;
  const Json listing = Json::parse(a.body);  // named: a range-for over a temporary's member dangles
  for (const Json& t : listing["tiles"]) {
    char conf[32];
    std::snprintf(conf, sizeof(conf), "%.6f", t["max_confidence"].get<double>());
    lines[t["tile"]] =
        t["tile"].get<std::string>() + " new " + std::to_string(t["new_count"].get<int64_t>()) +
        " removed " + std::to_string(t["removed_count"].get<int64_t>()) + " max_confidence " + conf;
  }
  std::ofstream out(file);
  for (const auto& [tile, line] : lines) out << line << "\n";
  return static_cast<bool>(out);
}

int RunLoad(const Options& o) {
  std::printf("rendering keyframes ...\n");
  const mb::KeyframeLanes lanes(4, 60);
  Run run;
  run.options = o;
  const auto t0 = Clock::now();
  run.deadline = t0 + std::chrono::duration_cast<Clock::duration>(
                          std::chrono::duration<double>(o.max_seconds));
  mb::RssSampler rss(o.pid_file, 1.0);
  std::atomic<bool> stop_readers{false};
  std::vector<std::thread> readers, uploaders;
  for (int r = 0; r < o.readers; ++r) readers.emplace_back([&] { Read(run, stop_readers); });
  for (int u = 0; u < o.uploaders; ++u) uploaders.emplace_back([&, u] { Upload(run, u, lanes); });
  for (auto& t : uploaders) t.join();
  const double upload_s = std::chrono::duration<double>(Clock::now() - t0).count();
  const Verdict v = WaitAndVerify(run);
  const double total_s = std::chrono::duration<double>(Clock::now() - t0).count();
  stop_readers = true;
  for (auto& t : readers) t.join();
  rss.Stop();
  const bool dumped = o.dump_changes.empty() || DumpChanges(run, o.dump_changes);

  const int64_t planned = static_cast<int64_t>(o.uploaders) * o.keyframes;
  std::printf("\nuploaders %d x %d keyframes (sessions of %d), readers %d\n", o.uploaders,
              o.keyframes, o.session_keyframes, o.readers);
  std::printf("acknowledged keyframes: %lld of %lld in %.1f s = %.1f keyframes/s\n",
              static_cast<long long>(run.acknowledged.load()), static_cast<long long>(planned),
              upload_s, run.acknowledged.load() / upload_s);
  std::printf(
      "sessions %zu, all commits done after %.1f s; stored keyframes %lld, lost %lld, commits "
      "failed %lld, unfinished %lld\n",
      run.sessions.size(), total_s, static_cast<long long>(v.stored),
      static_cast<long long>(v.lost), static_cast<long long>(v.commits_failed),
      static_cast<long long>(v.commits_unfinished));
  int64_t server_errors = 0, transport_errors = 0;
  PrintRoutes(run.book, &server_errors, &transport_errors);
  PrintRss(rss.samples());
  for (const std::string& p : run.problems) std::printf("problem: %s\n", p.c_str());
  const bool complete = run.acknowledged.load() == planned;
  if (!complete) std::printf("NOT COMPLETE: stopped by --max-seconds or errors\n");
  const bool ok = complete && v.lost == 0 && v.commits_failed == 0 && v.commits_unfinished == 0 &&
                  server_errors == 0 && (o.retry || transport_errors == 0) && dumped;
  std::printf("%s\n", ok ? "RESULT ok" : "RESULT FAILED");
  return ok ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const Options o = ParseOptions(argc, argv);
    if (!o.write_prior.empty()) {
      mb::KeyframeLanes::WritePrior(o.write_prior);
      return 0;
    }
    return RunLoad(o);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_load: %s\n", e.what());
    return 2;
  }
}
