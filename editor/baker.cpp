#include "editor/baker.h"

#include <chrono>

#include "base/error.h"

namespace raywarp::editor {

Baker::Baker(std::unique_ptr<BakeCache> cache, std::function<void()> on_done)
    : cache_(std::move(cache)), on_done_(std::move(on_done)) {
  worker_ = std::thread([this] { run(); });
}

Baker::~Baker() {
  {
    const std::lock_guard lock(mutex_);
    stop_ = true;
    if (current_) current_->cancel();
  }
  wake_.notify_all();
  worker_.join();
}

void Baker::submit(const Scene& scene, long generation, bool centre_on_lower_faces) {
  {
    const std::lock_guard lock(mutex_);
    pending_ = Job{scene, generation, centre_on_lower_faces};
    if (current_ && !current_->cancelled()) {
      current_->cancel();
      ++cancelled_;
    }
  }
  wake_.notify_all();
}

std::optional<Baker::Result> Baker::take() {
  const std::lock_guard lock(mutex_);
  std::optional<Result> out = std::move(done_);
  done_.reset();
  return out;
}

Baker::Progress Baker::progress() const {
  const std::lock_guard lock(mutex_);
  return progress_;
}

long Baker::cancelled() const {
  const std::lock_guard lock(mutex_);
  return cancelled_;
}

void Baker::run() {
  BakeSession session(cache_.get());
  for (;;) {
    Job job;
    {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [this] { return stop_ || pending_.has_value(); });
      if (stop_) return;
      job = std::move(*pending_);
      pending_.reset();
      progress_ = Progress{true, job.generation, "", 0.0};
    }
    Interrupter interrupter([this](const std::string& stage, double fraction) {
      const std::lock_guard lock(mutex_);
      progress_.stage = stage;
      progress_.fraction = fraction;
    });
    {
      const std::lock_guard lock(mutex_);
      current_ = &interrupter;
      if (pending_ || stop_) interrupter.cancel();  // a newer one came while this one started
    }
    Result result;
    result.generation = job.generation;
    result.centre_on_lower_faces = job.centre_on_lower_faces;
    const auto start = std::chrono::steady_clock::now();
    bool finished = true;
    try {
      result.prepared = std::make_shared<const PreparedScene>(
          bake_scene(job.scene, session, job.centre_on_lower_faces, &interrupter));
    } catch (const Cancelled&) {
      finished = false;
    } catch (const Error& e) {
      result.error = e.what();
    } catch (const std::exception& e) {
      result.error = std::string("bake failed: ") + e.what();
    }
    result.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    {
      const std::lock_guard lock(mutex_);
      current_ = nullptr;
      progress_.busy = pending_.has_value();
      if (finished) done_ = std::move(result);
    }
    if (finished && on_done_) on_done_();
  }
}

}  // namespace raywarp::editor
