// Bakes in the background: one worker thread owns the library's BakeSession (bake_scene over the
// disk cache), takes the newest scene submitted, and cancels the bake under way when a newer one
// arrives (Interrupter::cancel: the cancelled bake stores nothing). The window polls for results
// and progress and never waits on a bake.
#pragma once
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "base/interrupt.h"
#include "library/bake.h"
#include "library/bake_cache.h"

namespace raywarp::editor {

class Baker {
 public:
  // `cache`: the on-disk bake cache, or null for none. `on_done` (may be empty) is called from the
  // worker thread when a result is ready, e.g. to wake the window's event loop.
  explicit Baker(std::unique_ptr<BakeCache> cache, std::function<void()> on_done = {});
  ~Baker();
  Baker(const Baker&) = delete;
  Baker& operator=(const Baker&) = delete;

  // Bakes `scene` for state number `generation`; a bake under way for an older one is cancelled.
  // `centre_on_lower_faces`: texel centres of D on the boxes' lower faces, so that a twist's
  // angle can then be shown smaller through a texture map M (library/texture_map.h).
  void submit(const Scene& scene, long generation, bool centre_on_lower_faces = false);

  struct Result {
    long generation = 0;
    bool centre_on_lower_faces = false;
    std::shared_ptr<const PreparedScene> prepared;  // null when the bake failed
    std::string error;                              // the bake's Error message
    double seconds = 0.0;
  };
  // The newest finished result not taken yet.
  std::optional<Result> take();

  struct Progress {
    bool busy = false;
    long generation = 0;
    std::string stage;
    double fraction = 0.0;
  };
  Progress progress() const;
  long cancelled() const;  // bakes cancelled by a newer submission

 private:
  void run();
  std::unique_ptr<BakeCache> cache_;
  std::function<void()> on_done_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  struct Job {
    Scene scene;
    long generation = 0;
    bool centre_on_lower_faces = false;
  };
  std::optional<Job> pending_;
  std::optional<Result> done_;
  Progress progress_;
  Interrupter* current_ = nullptr;
  long cancelled_ = 0;
  bool stop_ = false;
  std::thread worker_;
};

}  // namespace raywarp::editor
