#pragma once
// Row bands in parallel: forEachBand(bands, body) calls body(k) once for every
// band k in [0, bands), in any order and on any thread; it returns when all
// are done. Every band function of the hot stages goes through it.
//
// Normally TBB runs them (tbb::parallel_for over a blocked_range of bands).
// With SG_BANDS_STD_THREAD (set by SG_TSAN, docs/reliability.md) plain
// std::threads run them instead: ThreadSanitizer sees thread start and join,
// but not the synchronisation inside Debian's uninstrumented libtbb, and would
// report every hand-over of a band's output to the caller as a race. The
// threads take bands round-robin (thread t runs bands t, t + T, ...), so
// neighbouring bands always run on different threads and an access across a
// band border is always one TSan can see. T is TBB's current parallelism
// limit, so tbb::global_control in tests sets it in both modes.
#include <algorithm>
#include <cstddef>

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#ifdef SG_BANDS_STD_THREAD
#include <exception>
#include <mutex>
#include <thread>
#include <vector>
#endif

namespace sg {

template <class Body>
void forEachBand(int bands, Body&& body) {
  if (bands <= 0) return;
#ifndef SG_BANDS_STD_THREAD
  tbb::parallel_for(tbb::blocked_range<int>(0, bands), [&](const tbb::blocked_range<int>& range) {
    for (int k = range.begin(); k != range.end(); ++k) body(k);
  });
#else
  const int limit = static_cast<int>(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
  const int threads = std::max(1, std::min(bands, limit));
  std::exception_ptr error;
  std::mutex error_mutex;
  auto run = [&](int first) {
    try {
      for (int k = first; k < bands; k += threads) body(k);
    } catch (...) {
      const std::lock_guard<std::mutex> lock(error_mutex);
      if (!error) error = std::current_exception();
    }
  };
  std::vector<std::thread> workers;
  workers.reserve(static_cast<std::size_t>(threads - 1));
  for (int t = 1; t < threads; ++t) workers.emplace_back(run, t);
  run(0);
  for (std::thread& w : workers) w.join();
  if (error) std::rethrow_exception(error);
#endif
}

}  // namespace sg
