// Work spread over threads by the core's batch functions (CompensateAll, PredictPositionErrorBounds): items handed
// out in chunks from a shared counter, each result into its own slot, so that neither the results nor their order
// depend on the thread count.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <thread>
#include <vector>

namespace robocal::internal {

/// Calls work(i) for every i in [0, count) on `threads` threads (0: as many as the hardware runs at once), in
/// chunks of `chunk`. An exception thrown by work(i) is kept, and the one of the smallest i is rethrown after every
/// item has run.
template <typename Work>
void ParallelFor(std::size_t count, int threads, std::size_t chunk, Work&& work) {
  std::vector<std::exception_ptr> errors(count);
  const std::size_t hardware = std::max(1u, std::thread::hardware_concurrency());
  const std::size_t wanted = threads > 0 ? static_cast<std::size_t>(threads) : hardware;
  const std::size_t workers = std::min(wanted, (count + chunk - 1) / chunk);
  std::atomic<std::size_t> next{0};
  auto run = [&] {
    for (std::size_t begin = next.fetch_add(chunk); begin < count; begin = next.fetch_add(chunk)) {
      for (std::size_t i = begin; i < std::min(begin + chunk, count); ++i) {
        try {
          work(i);
        } catch (...) {
          errors[i] = std::current_exception();
        }
      }
    }
  };
  std::vector<std::thread> pool;
  for (std::size_t w = 1; w < workers; ++w) pool.emplace_back(run);
  run();
  for (std::thread& t : pool) t.join();
  for (const std::exception_ptr& e : errors) {
    if (e) std::rethrow_exception(e);
  }
}

}  // namespace robocal::internal
