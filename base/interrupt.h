// Progress and cancel of long work: raywarp's form of OpenVDB's interrupter.
//
// A bake takes an Interrupter* (null: no progress, no cancel) and polls it at least every 50 ms of
// work: every parallel loop polls once per chunk of iterations (base/parallel.h), and serial
// passes poll between their steps. cancel() may be called from any thread; the next poll then
// throws Cancelled, which unwinds the bake before it stores anything (no cache entry, no file).
#pragma once
#include <atomic>
#include <chrono>
#include <functional>
#include <mutex>
#include <stdexcept>
#include <string>

namespace raywarp {

// Thrown out of work whose Interrupter was cancelled. Not an Error: the input was fine.
struct Cancelled : std::runtime_error {
  Cancelled() : std::runtime_error("cancelled") {}
};

class Interrupter {
 public:
  // Receives (stage, fraction of the stage in [0, 1]); called from one thread at a time, at most
  // every `report_interval_s` seconds, and at every change of stage.
  using Report = std::function<void(const std::string& stage, double fraction)>;

  Interrupter() = default;
  explicit Interrupter(Report report, double report_interval_s = 0.05)
      : report_(std::move(report)), interval_(report_interval_s) {}
  Interrupter(const Interrupter&) = delete;
  Interrupter& operator=(const Interrupter&) = delete;

  // Any thread: asks the work to stop at its next poll.
  void cancel() noexcept { cancelled_.store(true, std::memory_order_relaxed); }
  bool cancelled() const noexcept { return cancelled_.load(std::memory_order_relaxed); }

  // Any thread: throws Cancelled when cancelled.
  void poll() {
    polls_.fetch_add(1, std::memory_order_relaxed);
    if (cancelled()) throw Cancelled();
  }
  // Any thread: records progress in `stage` (calling the report when due), then poll().
  void poll(const char* stage, double fraction) {
    if (report_) {
      const std::lock_guard lock(mutex_);
      const auto now = std::chrono::steady_clock::now();
      fraction = fraction < 0.0 ? 0.0 : fraction > 1.0 ? 1.0 : fraction;
      if (stage_ != stage) {
        stage_ = stage;
        fraction_ = fraction;
        last_ = now;
        report_(stage_, fraction_);
      } else {
        // Threads poll out of order: within a stage, the fraction reported never goes back.
        fraction_ = fraction > fraction_ ? fraction : fraction_;
        if (std::chrono::duration<double>(now - last_).count() >= interval_) {
          last_ = now;
          report_(stage_, fraction_);
        }
      }
    }
    poll();
  }
  // How many times the work polled (tests read it).
  long polls() const noexcept { return polls_.load(std::memory_order_relaxed); }

 private:
  Report report_;
  double interval_ = 0.05;
  std::atomic<bool> cancelled_{false};
  std::atomic<long> polls_{0};
  std::mutex mutex_;
  std::string stage_;
  double fraction_ = 0.0;
  std::chrono::steady_clock::time_point last_{};
};

// The same on a pointer that may be null.
inline void poll(Interrupter* interrupter) {
  if (interrupter) interrupter->poll();
}
inline void poll(Interrupter* interrupter, const char* stage, double fraction) {
  if (interrupter) interrupter->poll(stage, fraction);
}

}  // namespace raywarp
