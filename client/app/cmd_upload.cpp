// mapdelta-client upload: upload a keyframe folder (offline mode), or resume an interrupted
// upload. The durable queue lives beside the folder (DIR.upload_queue), so running the same
// command again after a crash or outage continues without loss or duplicates.
#include <atomic>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <thread>

#include "commands.hpp"
#include "mapdelta/client/config.hpp"
#include "mapdelta/client/http_transport.hpp"
#include "mapdelta/client/uploader.hpp"
#include "mapdelta/common/cli.hpp"
#include "mapdelta/common/keyframes.hpp"
#include "mapdelta/common/log.hpp"
#include "progress_line.hpp"

namespace mapdelta::client::app {

int RunUpload(int argc, char** argv) {
  std::string dir, server, token, config_path, vehicle_id;
  double give_up_after_s = UploadConfig().give_up_after_s;
  cli::Parser cli(
      "mapdelta-client upload",
      "Uploads a keyframe folder written in offline mode (camera.yaml, poses.txt, depth/), e.g.\n"
      "OUT/keyframes of 'run'. Progress is kept in DIR.upload_queue/: run the same command again\n"
      "to resume after a crash or an outage, without loss or duplicates.");
  cli.Positional("DIR", &dir, "keyframe folder")
      .Option("server", &server, "server base URL, e.g. http://localhost:8080", "URL")
      .Option("token", &token, "vehicle token", "T")
      .Option("config", &config_path, "client configuration (YAML)", "FILE")
      .Option("vehicle-id", &vehicle_id, "overrides upload.vehicle_id", "ID")
      .Option("give-up-after", &give_up_after_s,
              "stop with an error after this long without a successful answer from the server "
              "(overrides upload.give_up_after_s; 0: retry forever)",
              "S")
      .Require({"server", "token"})
      .Footer(cli::kExitCodesFooter);
  if (!cli.Parse(argc, argv, std::cout)) return cli::kExitOk;
  ClientConfig config = config_path.empty() ? ClientConfig{} : LoadClientConfig(config_path);
  if (cli.Given("vehicle-id")) config.upload.vehicle_id = vehicle_id;
  if (cli.Given("give-up-after")) {
    if (give_up_after_s < 0)
      cli::FailUsage(cli.program(), "--give-up-after: expected seconds >= 0");
    config.upload.give_up_after_s = give_up_after_s;
  }
  while (dir.size() > 1 && dir.back() == '/') dir.pop_back();
  const KeyframeFolder folder = ReadKeyframeFolder(dir);
  config.upload.depth_scale = folder.depth_scale;

  UploadQueue queue(dir + ".upload_queue");
  auto transport = MakeHttpTransport(server, token, config.upload.timeout_s);
  Uploader uploader(config.upload, folder.camera, &queue, transport.get());
  // Keyframes the queue has not seen yet (all of them on the first run; the tail after an
  // interrupted 'run'), in folder order, which is the keyframes' seq order.
  if (!queue.State().sealed) {
    for (size_t i = static_cast<size_t>(queue.State().next_seq); i < folder.keyframes.size(); ++i) {
      uploader.Enqueue(folder.keyframes[i]);
    }
    queue.Seal();
  }
  std::fprintf(stderr, "upload: %zu keyframes in %s, %zu pending\n", folder.keyframes.size(),
               dir.c_str(), queue.PendingCount());
  std::atomic<bool> stop{false}, finished{false};
  UploadReport report;
  std::thread runner([&] {
    report = uploader.Run(stop);  // returns on commit, a permanent error, or giving up
    finished = true;
  });
  const size_t total = folder.keyframes.size();
  ProgressLine progress;
  auto state = [&] {
    return "upload: " + std::to_string(total - queue.PendingCount()) + "/" + std::to_string(total) +
           " keyframes sent";
  };
  while (!finished) {
    progress.Update(state());
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
  }
  runner.join();
  progress.Finish(state());
  if (!report.committed) {
    std::fprintf(
        stderr,
        "mapdelta-client upload: error: %s\n"
        "%zu keyframes stay queued in %s.upload_queue: run the same command again to resume.\n",
        report.fatal.c_str(), queue.PendingCount(), dir.c_str());
    return cli::kExitFailure;
  }
  std::fprintf(stderr,
               "upload: session %s committed, %zu keyframes sent, %zu retries, %zu conflicts\n",
               report.session_id.c_str(), report.uploaded, report.retries, report.conflicts);
  return cli::kExitOk;
}

}  // namespace mapdelta::client::app
