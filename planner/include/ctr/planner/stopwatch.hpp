/// @file stopwatch.hpp
/// @brief Elapsed time on the wall clock or on the process CPU clock (planning time limits, see Query).
#pragma once

#include <chrono>
#include <ctime>

namespace ctr::planner {

/// @brief Measures elapsed seconds since construction, on the wall clock or as CPU time of the whole process.
class Stopwatch {
 public:
  explicit Stopwatch(bool cpu = false) : cpu_(cpu), wall0_(std::chrono::steady_clock::now()), cpu0_(cpuNow()) {}
  /// @brief Seconds on the selected clock.
  double seconds() const { return cpu_ ? cpuNow() - cpu0_ : wallSeconds(); }
  /// @brief Wall-clock seconds.
  double wallSeconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0_).count();
  }
  bool cpu() const { return cpu_; }

 private:
  static double cpuNow() {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
  }
  bool cpu_;
  std::chrono::steady_clock::time_point wall0_;
  double cpu0_;
};

}  // namespace ctr::planner
