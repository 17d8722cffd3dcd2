// mapdelta-client upload: upload a keyframe folder (offline mode), or resume an interrupted
// upload. The durable queue lives beside the folder (DIR.upload_queue), so running the same
// command again after a crash or outage continues without loss or duplicates.
#include <atomic>
#include <chrono>
#include <cstdio>
#include <thread>

#include "args.hpp"
#include "commands.hpp"
#include "mapdelta/client/config.hpp"
#include "mapdelta/client/http_transport.hpp"
#include "mapdelta/client/uploader.hpp"
#include "mapdelta/common/keyframes.hpp"
#include "mapdelta/common/log.hpp"

namespace mapdelta::client::app {

int RunUpload(int argc, char** argv) {
  const char* usage =
      "usage: mapdelta-client upload DIR --server URL --token T [--config FILE] [--vehicle-id ID]\n"
      "  DIR: a keyframe folder (camera.yaml, poses.txt, depth/), e.g. OUT/keyframes of 'run'.\n"
      "  Progress is kept in DIR.upload_queue/: run the same command again to resume.\n";
  Args args;
  try {
    args = ParseArgs(argc, argv, {"server", "token", "config", "vehicle-id"});
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n%s", e.what(), usage);
    return 2;
  }
  if (args.help) {
    std::fprintf(stderr, "%s", usage);
    return 0;
  }
  if (args.positional.size() != 1 || !args.Has("server") || !args.Has("token")) {
    std::fprintf(stderr, "expected DIR, --server and --token\n%s", usage);
    return 2;
  }
  ClientConfig config = args.Has("config") ? LoadClientConfig(args.Get("config")) : ClientConfig{};
  if (args.Has("vehicle-id")) config.upload.vehicle_id = args.Get("vehicle-id");
  std::string dir = args.positional[0];
  while (dir.size() > 1 && dir.back() == '/') dir.pop_back();
  const KeyframeFolder folder = ReadKeyframeFolder(dir);
  config.upload.depth_scale = folder.depth_scale;

  UploadQueue queue(dir + ".upload_queue");
  auto transport = MakeHttpTransport(args.Get("server"), args.Get("token"), config.upload.timeout_s);
  Uploader uploader(config.upload, folder.camera, &queue, transport.get());
  // Keyframes the queue has not seen yet (all of them on the first run; the tail after an
  // interrupted 'run'), in folder order, which is the keyframes' seq order.
  if (!queue.State().sealed) {
    for (size_t i = static_cast<size_t>(queue.State().next_seq); i < folder.keyframes.size(); ++i) {
      uploader.Enqueue(folder.keyframes[i]);
    }
    queue.Seal();
  }
  std::fprintf(stderr, "upload: %zu keyframes in %s, %zu pending\n", folder.keyframes.size(), dir.c_str(),
               queue.PendingCount());
  std::atomic<bool> stop{false}, finished{false};
  UploadReport report;
  std::thread runner([&] {
    report = uploader.Run(stop);  // returns on commit or a permanent error
    finished = true;
  });
  while (!finished) {
    std::fprintf(stderr, "\rupload: %zu pending ", queue.PendingCount());
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
  }
  runner.join();
  std::fprintf(stderr, "\n");
  if (!report.committed) {
    std::fprintf(stderr, "upload failed: %s\n", report.fatal.c_str());
    return 1;
  }
  std::fprintf(stderr, "upload: session %s committed, %zu keyframes sent, %zu retries, %zu conflicts\n",
               report.session_id.c_str(), report.uploaded, report.retries, report.conflicts);
  return 0;
}

}  // namespace mapdelta::client::app
