#pragma once
// The uploader's durable on-disk queue, so that a lost connection or a killed client resumes
// without losing or duplicating keyframes. Layout of DIR:
//   state.json             {"session_id": <server id or null>, "sealed": bool, "committed": bool,
//                           "next_seq": n, "done_seq": n}   (written atomically: tmp + rename)
//   pending/<seq>.png      the keyframe's 16-bit depth PNG (bytes exactly as uploaded)
//   pending/<seq>.json     its meta JSON; written last (tmp + rename), so an item exists only
//                          once both parts are complete
// An item leaves pending/ only after the server acknowledged it (MarkDone). A restart after the
// server stored an item but before MarkDone re-sends identical bytes, which the server's
// idempotent PUT answers with 200: no duplicate. Thread-safe.
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace mapdelta::client {

struct QueuedKeyframe {
  int64_t seq = 0;
  std::string meta_json;
  std::vector<unsigned char> depth_png;
};

struct UploadState {
  std::optional<std::string> session_id;  // the server's id, as JSON text (number or string)
  bool sealed = false;                    // no more keyframes will be enqueued
  bool committed = false;                 // the server accepted the commit
  int64_t next_seq = 0;                   // seq of the next Enqueue
  int64_t done_seq = 0;                   // all seq below this were acknowledged by the server
};

class UploadQueue {
 public:
  // Creates DIR if needed, removes half-written items, loads state. Throws Error(kIo/kParse).
  explicit UploadQueue(const std::string& dir);

  // Appends a keyframe; returns its seq. Throws Error(kConflict) once sealed.
  int64_t Enqueue(const std::string& meta_json, const std::vector<unsigned char>& depth_png);
  std::optional<QueuedKeyframe> Front() const;  // lowest pending seq
  void MarkDone(int64_t seq);                   // acknowledged: drop it from disk
  size_t PendingCount() const;

  UploadState State() const;
  void SetSessionId(const std::string& session_id);
  void Seal();
  void MarkCommitted();
  const std::string& dir() const { return dir_; }

 private:
  void SaveStateLocked() const;
  std::string ItemPath(int64_t seq, const char* ext) const;

  std::string dir_;
  mutable std::mutex mutex_;
  UploadState state_;
};

}  // namespace mapdelta::client
