// MemoryTrimmer: a delayed malloc_trim on its own thread.
#include "robocal/server/memory_trimmer.h"

#ifdef __GLIBC__
#include <malloc.h>
#endif

namespace robocal::server {

void ReleaseFreedMemory() {
#ifdef __GLIBC__
  malloc_trim(0);
#endif
}

void ConfigureMemoryAllocator() {
#ifdef __GLIBC__
  mallopt(M_ARENA_MAX, 2);
  mallopt(M_MMAP_THRESHOLD, 4 << 20);
  mallopt(M_TRIM_THRESHOLD, 32 << 20);
#endif
}

MemoryTrimmer::MemoryTrimmer(std::chrono::milliseconds delay, std::function<void()> trim)
    : delay_(delay), trim_(std::move(trim)), thread_([this] { Run(); }) {}

MemoryTrimmer::~MemoryTrimmer() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_one();
  thread_.join();
}

void MemoryTrimmer::Schedule() {
  {
    std::lock_guard lock(mutex_);
    if (due_) return;
    due_ = true;
  }
  wake_.notify_one();
}

bool MemoryTrimmer::Due() {
  std::lock_guard lock(mutex_);
  return due_;
}

void MemoryTrimmer::Run() {
  std::unique_lock lock(mutex_);
  for (;;) {
    wake_.wait(lock, [this] { return due_ || stop_; });
    if (wake_.wait_for(lock, delay_, [this] { return stop_; })) return;
    // A Schedule() from here on asks for the next trim: what it frees may come after this one.
    due_ = false;
    lock.unlock();
    trim_();
    lock.lock();
  }
}

}  // namespace robocal::server
