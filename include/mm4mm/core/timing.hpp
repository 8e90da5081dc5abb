#pragma once
// Wall-clock seconds of a stage, for the timings a result reports. Steady clock: a stage's time
// must not jump when the system clock is set.

#include <chrono>

namespace mm4mm {

using SteadyClock = std::chrono::steady_clock;

/// Seconds from `start` to now.
inline double secondsSince(SteadyClock::time_point start) {
  return std::chrono::duration<double>(SteadyClock::now() - start).count();
}

}  // namespace mm4mm
