#pragma once
// Per-stage wall-time accumulation shared by the pipeline's threads.
#include <chrono>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "mapdelta/client/pipeline.hpp"

namespace mapdelta::client {

class StageTimer {
 public:
  class Scope {
   public:
    Scope(StageTimer* timer, std::string stage)
        : timer_(timer), stage_(std::move(stage)), start_(std::chrono::steady_clock::now()) {}
    ~Scope() {
      timer_->Add(stage_,
                  std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count());
    }

   private:
    StageTimer* timer_;
    std::string stage_;
    std::chrono::steady_clock::time_point start_;
  };
  void Add(const std::string& stage, double seconds) {
    std::lock_guard lock(mutex_);
    auto& t = stages_[stage];
    t.stage = stage;
    t.seconds += seconds;
    ++t.calls;
  }
  std::vector<StageTiming> Summary() const {
    std::lock_guard lock(mutex_);
    std::vector<StageTiming> out;
    for (const auto& [name, t] : stages_) out.push_back(t);
    return out;
  }

 private:
  mutable std::mutex mutex_;
  std::map<std::string, StageTiming> stages_;
};

}  // namespace mapdelta::client
