// Handing the memory that large requests freed back to the system, shortly after they end.
#pragma once

#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <thread>

namespace robocal::server {

/// malloc_trim(0) where the C library has it (glibc): gives the free pages of every malloc arena back to the
/// system. A no-op elsewhere.
void ReleaseFreedMemory();

/// The server's malloc settings (glibc; a no-op elsewhere), before any thread starts:
/// - two arenas instead of glibc's 8 per core. The service trims freed memory after large requests, but glibc never
///   trims the top of a thread arena below its dynamic threshold (up to 64 MB each): with 8 arenas, 8 concurrent
///   fits of 10,000 measurements left 355 MB resident, with 2 arenas 19 MB, at the same speed on 2 cores (per-thread
///   caches serve most small allocations without the arena lock).
/// - blocks up to 4 MB from the arenas, and their free tops kept up to 32 MB between trims. By default a block over
///   128 kB (a fit's Jacobian of 400 poses is 576 kB) is mapped anew and given back at every allocation, and a
///   fit allocates dozens: their page faults were an eighth of a 400-pose fit's time. The trimmer still gives the
///   memory back shortly after each large request.
void ConfigureMemoryAllocator();

/// Runs `trim` on its own thread `delay` after Schedule(), at most once per delay however often it is asked.
///
/// glibc keeps what a thread frees in that thread's arena for reuse, so after a burst of large requests the
/// server would hold their peak for good (8 concurrent fits of 10,000 measurements left 500 MB resident). A
/// request cannot trim at its own end: its request and reply documents are freed by the HTTP layer after the
/// service returns; the delay lets that happen first. Trimming after every free instead (a fixed
/// M_TRIM_THRESHOLD) made those fits twice as slow, re-faulting the same pages.
class MemoryTrimmer {
 public:
  explicit MemoryTrimmer(std::chrono::milliseconds delay = std::chrono::milliseconds(500),
                         std::function<void()> trim = ReleaseFreedMemory);
  /// Stops the thread at once; a trim that is still waiting for its delay is dropped.
  ~MemoryTrimmer();
  MemoryTrimmer(const MemoryTrimmer&) = delete;
  MemoryTrimmer& operator=(const MemoryTrimmer&) = delete;

  /// A trim `delay` from now, unless one is already waiting.
  void Schedule();
  /// Whether a trim is waiting for its delay (asked for, not yet begun). When none is, none runs until the next
  /// Schedule().
  bool Due();

 private:
  void Run();

  const std::chrono::milliseconds delay_;
  const std::function<void()> trim_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool due_ = false;
  bool stop_ = false;
  std::thread thread_;  // declared last: started once the members it uses exist
};

}  // namespace robocal::server
