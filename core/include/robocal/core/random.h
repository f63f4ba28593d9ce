// Seeded random numbers with results that are the same on every platform.
#pragma once

#include <cmath>
#include <cstdint>
#include <random>
#include <utility>
#include <vector>

namespace robocal {

/// A seeded generator for uniform and Gaussian draws.
///
/// Written by hand rather than using std::uniform_real_distribution / std::normal_distribution because the
/// standard leaves those algorithms to the library implementation: the same seed gives different numbers
/// with libstdc++ and libc++. std::mt19937_64 itself is fully specified, so everything built on it here is
/// reproducible from the seed alone, which every plan and simulation in robocal promises.
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : engine_(seed) {}

  /// Uniform in [0, 1), 53 random bits.
  double Uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }

  /// Uniform in [lo, hi).
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }

  /// Standard normal N(0, 1) by the Marsaglia polar method.
  double Normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double u = 0.0, v = 0.0, s = 0.0;
    do {
      u = 2.0 * Uniform() - 1.0;
      v = 2.0 * Uniform() - 1.0;
      s = u * u + v * v;
    } while (s >= 1.0 || s == 0.0);
    const double factor = std::sqrt(-2.0 * std::log(s) / s);
    spare_ = v * factor;
    has_spare_ = true;
    return u * factor;
  }

  /// Uniform integer in [0, n), n > 0 (rejection sampling, no modulo bias).
  std::uint64_t Index(std::uint64_t n) {
    const std::uint64_t limit = UINT64_MAX - UINT64_MAX % n;
    std::uint64_t x = 0;
    do {
      x = engine_();
    } while (x >= limit);
    return x % n;
  }

 private:
  std::mt19937_64 engine_;
  bool has_spare_ = false;
  double spare_ = 0.0;
};

/// `count` (at most from.size()) distinct elements of `from`, drawn by a partial Fisher-Yates shuffle: the k-th is
/// swapped with a uniform pick among the elements from k on. The exchange optimiser's random start and the rows a
/// file's calibration measurements are drawn from (`robocal upload --calibration-rows N --seed S`).
template <class T>
std::vector<T> DrawDistinct(std::vector<T> from, std::size_t count, Rng* rng) {
  for (std::size_t i = 0; i < count; ++i) std::swap(from[i], from[i + rng->Index(from.size() - i)]);
  from.resize(count);
  return from;
}

}  // namespace robocal
