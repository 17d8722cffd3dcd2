#include "mapdelta/client/upload_queue.hpp"

#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"

namespace mapdelta::client {
namespace fs = std::filesystem;
namespace {

// Write to a temporary name, flush, then rename: readers see the old or the new file, never
// a torn one.
void WriteAtomically(const std::string& path, const void* data, size_t size) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out.write(static_cast<const char*>(data), static_cast<std::streamsize>(size));
    out.flush();
    if (!out) throw Error(ErrorCode::kIo, tmp + ": cannot write upload queue file");
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) throw Error(ErrorCode::kIo, path + ": cannot rename into place: " + ec.message());
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(ErrorCode::kIo, path + ": cannot read");
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

bool ParseSeq(const fs::path& p, int64_t* seq) {
  try {
    size_t used = 0;
    const std::string stem = p.stem().string();
    *seq = std::stoll(stem, &used);
    return used == stem.size() && *seq >= 0;
  } catch (const std::exception&) {
    return false;
  }
}

}  // namespace

UploadQueue::UploadQueue(const std::string& dir) : dir_(dir) {
  std::error_code ec;
  fs::create_directories(fs::path(dir_) / "pending", ec);
  if (ec)
    throw Error(ErrorCode::kIo, dir_ + ": cannot create upload queue folder: " + ec.message());
  const std::string state_path = (fs::path(dir_) / "state.json").string();
  if (fs::exists(state_path)) {
    try {
      const auto j = nlohmann::json::parse(ReadFile(state_path));
      if (!j.at("session_id").is_null()) state_.session_id = j.at("session_id").dump();
      state_.sealed = j.at("sealed").get<bool>();
      state_.committed = j.at("committed").get<bool>();
      state_.next_seq = j.at("next_seq").get<int64_t>();
      state_.done_seq = j.at("done_seq").get<int64_t>();
    } catch (const nlohmann::json::exception& e) {
      throw Error(ErrorCode::kParse, state_path + ": " + e.what());
    }
  }
  // Items: a .png without its .json (killed mid-enqueue) and temporaries are incomplete.
  // An Enqueue that died before its state update still has a complete item: count it.
  for (const auto& entry : fs::directory_iterator(fs::path(dir_) / "pending")) {
    const auto& p = entry.path();
    int64_t seq = 0;
    if (p.extension() == ".tmp" || !ParseSeq(p, &seq)) {
      fs::remove(p, ec);
      continue;
    }
    if (p.extension() == ".png" && !fs::exists(ItemPath(seq, ".json"))) {
      MD_LOG(kWarn, "upload queue: dropping incomplete item " << p.string());
      fs::remove(p, ec);
    } else if (p.extension() == ".json") {
      state_.next_seq = std::max(state_.next_seq, seq + 1);
    }
  }
  std::lock_guard lock(mutex_);
  SaveStateLocked();
}

std::string UploadQueue::ItemPath(int64_t seq, const char* ext) const {
  std::ostringstream name;
  name << std::setw(10) << std::setfill('0') << seq << ext;
  return (fs::path(dir_) / "pending" / name.str()).string();
}

void UploadQueue::SaveStateLocked() const {
  nlohmann::json j;
  j["session_id"] =
      state_.session_id ? nlohmann::json::parse(*state_.session_id) : nlohmann::json();
  j["sealed"] = state_.sealed;
  j["committed"] = state_.committed;
  j["next_seq"] = state_.next_seq;
  j["done_seq"] = state_.done_seq;
  const std::string text = j.dump(2);
  WriteAtomically((fs::path(dir_) / "state.json").string(), text.data(), text.size());
}

int64_t UploadQueue::Enqueue(const std::string& meta_json, const std::vector<unsigned char>& png) {
  std::lock_guard lock(mutex_);
  if (state_.sealed) throw Error(ErrorCode::kConflict, dir_ + ": upload queue is sealed");
  const int64_t seq = state_.next_seq;
  WriteAtomically(ItemPath(seq, ".png"), png.data(), png.size());
  WriteAtomically(ItemPath(seq, ".json"), meta_json.data(), meta_json.size());
  state_.next_seq = seq + 1;
  SaveStateLocked();
  return seq;
}

std::optional<QueuedKeyframe> UploadQueue::Front() const {
  std::lock_guard lock(mutex_);
  for (int64_t seq = state_.done_seq; seq < state_.next_seq; ++seq) {
    const std::string meta = ItemPath(seq, ".json");
    if (!fs::exists(meta)) continue;
    const std::string png = ReadFile(ItemPath(seq, ".png"));
    return QueuedKeyframe{seq, ReadFile(meta), std::vector<unsigned char>(png.begin(), png.end())};
  }
  return std::nullopt;
}

void UploadQueue::MarkDone(int64_t seq) {
  std::lock_guard lock(mutex_);
  std::error_code ec;
  // Remove the meta first: from then on the item no longer exists for a restarted client.
  fs::remove(ItemPath(seq, ".json"), ec);
  fs::remove(ItemPath(seq, ".png"), ec);
  if (seq == state_.done_seq) {
    ++state_.done_seq;
    while (state_.done_seq < state_.next_seq && !fs::exists(ItemPath(state_.done_seq, ".json"))) {
      ++state_.done_seq;
    }
  }
  SaveStateLocked();
}

size_t UploadQueue::PendingCount() const {
  std::lock_guard lock(mutex_);
  size_t n = 0;
  for (int64_t seq = state_.done_seq; seq < state_.next_seq; ++seq)
    n += fs::exists(ItemPath(seq, ".json"));
  return n;
}

UploadState UploadQueue::State() const {
  std::lock_guard lock(mutex_);
  return state_;
}

void UploadQueue::SetSessionId(const std::string& session_id) {
  std::lock_guard lock(mutex_);
  state_.session_id = session_id;
  SaveStateLocked();
}

void UploadQueue::Seal() {
  std::lock_guard lock(mutex_);
  state_.sealed = true;
  SaveStateLocked();
}

void UploadQueue::MarkCommitted() {
  std::lock_guard lock(mutex_);
  state_.committed = true;
  SaveStateLocked();
}

}  // namespace mapdelta::client
