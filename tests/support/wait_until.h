#pragma once
/// Waiting for something a test can observe (a state reached, a message arrived) instead of
/// sleeping for a fixed time and hoping.

#include <chrono>
#include <thread>

namespace softgrasp::testing {

/// Polls `done` every 10 ms until it holds or `timeout_s` passes; returns the seconds waited, or
/// a negative number on timeout (so: ASSERT_GE(WaitUntil(...), 0.0)).
template <class Pred>
double WaitUntil(Pred&& done, double timeout_s) {
  const auto start = std::chrono::steady_clock::now();
  for (;;) {
    const double waited =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (done()) return waited;
    if (waited > timeout_s) return -1.0;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

}  // namespace softgrasp::testing
