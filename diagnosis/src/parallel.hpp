// Internal: runs body(i, workspace) for i in [0, count) on up to `threads` threads (the caller's included), one
// model Workspace per thread; the first exception is re-thrown after all threads joined.
#pragma once

#include <algorithm>
#include <atomic>
#include <exception>
#include <functional>
#include <thread>
#include <vector>

#include "ctr/model/kinematics.hpp"

namespace ctr::diagnosis::detail {

inline void parallelFor(int count, int threads, Workspace& caller_ws,
                        const std::function<void(int, Workspace&)>& body) {
  const int nt = std::max(1, std::min(threads, count));
  if (nt == 1) {
    for (int i = 0; i < count; ++i) body(i, caller_ws);
    return;
  }
  std::atomic<int> next{0};
  std::vector<std::exception_ptr> errors(static_cast<std::size_t>(nt));
  auto worker = [&](int t, Workspace& w) {
    try {
      for (int i; (i = next++) < count;) body(i, w);
    } catch (...) {
      errors[static_cast<std::size_t>(t)] = std::current_exception();
      next = count;
    }
  };
  std::vector<Workspace> spaces(static_cast<std::size_t>(nt - 1));
  std::vector<std::thread> pool;
  for (int t = 1; t < nt; ++t) pool.emplace_back(worker, t, std::ref(spaces[static_cast<std::size_t>(t - 1)]));
  worker(0, caller_ws);
  for (auto& th : pool) th.join();
  for (const auto& e : errors)
    if (e) std::rethrow_exception(e);
}

}  // namespace ctr::diagnosis::detail
