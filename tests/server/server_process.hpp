#pragma once
// The real mapdelta-server binary as a child process, for process-level tests and benchmarks
// (MAPDELTA_SERVER_BIN names it). Throws std::runtime_error if it does not start.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

namespace mapdelta::testing {

// Runs the CLI to completion and returns its stdout (and stderr, if asked). `timeout` ends
// a command that should have exited but serves instead (exit code 124), so that such a test
// fails instead of hanging.
inline std::string RunCli(const std::string& args, int* exit_code, bool with_stderr = false) {
  const std::string cmd = "timeout 60 " + std::string(MAPDELTA_SERVER_BIN) + " " + args +
                          (with_stderr ? " 2>&1" : " 2>/dev/null");
  FILE* pipe = popen(cmd.c_str(), "r");
  std::string out;
  char buf[512];
  while (pipe && fgets(buf, sizeof(buf), pipe)) out += buf;
  const int status = pipe ? pclose(pipe) : -1;
  *exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return out;
}

// `mapdelta-server serve --config FILE --port 0 [extra...]`; waits for its first stdout line:
// "listening on HOST:PORT" (port() is then set) or, with --worker-only, "worker ready".
class ServerProcess {
 public:
  ServerProcess(const std::string& config, const std::string& log,
                const std::vector<std::string>& extra = {}) {
    std::vector<std::string> args = {
        MAPDELTA_SERVER_BIN, "serve", "--config", config, "--port", "0"};
    args.insert(args.end(), extra.begin(), extra.end());
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    int fds[2];
    if (pipe(fds) != 0) throw std::runtime_error("ServerProcess: pipe failed");
    pid_ = fork();
    if (pid_ == 0) {
      dup2(fds[1], 1);
      FILE* err = std::fopen(log.c_str(), "a");
      if (err) dup2(fileno(err), 2);
      close(fds[0]);
      execv(MAPDELTA_SERVER_BIN, argv.data());
      _exit(127);
    }
    close(fds[1]);
    FILE* out = fdopen(fds[0], "r");
    char line[256] = {0};
    if (out && fgets(line, sizeof(line), out)) first_line_ = line;
    if (out) fclose(out);
    if (first_line_.rfind("listening on ", 0) == 0) {
      port_ = std::stoi(first_line_.substr(first_line_.rfind(':') + 1));
    }
    if (first_line_.empty()) {
      Kill(SIGKILL);
      throw std::runtime_error("mapdelta-server did not start; see " + log);
    }
  }
  ~ServerProcess() {
    if (pid_ > 0) Kill(SIGKILL);
  }
  ServerProcess(const ServerProcess&) = delete;
  ServerProcess& operator=(const ServerProcess&) = delete;

  int port() const { return port_; }
  pid_t pid() const { return pid_; }
  // Sends the signal and waits; returns the exit status (or -signal).
  int Kill(int sig) {
    ::kill(pid_, sig);
    int status = 0;
    waitpid(pid_, &status, 0);
    pid_ = -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
  }

 private:
  pid_t pid_ = -1;
  int port_ = 0;
  std::string first_line_;
};

}  // namespace mapdelta::testing
