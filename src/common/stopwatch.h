// Wall-clock milliseconds, for the reports of the commands and of the device work.
#pragma once
#include <chrono>

namespace shprobe {

using Clock = std::chrono::steady_clock;

inline double millisecondsSince(Clock::time_point start) {
    return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

} // namespace shprobe
