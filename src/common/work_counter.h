// Work a long loop has done, counted by the threads doing it and read by another that draws a
// progress line (app/progress_line.h). Loops take a pointer that may be null: no counter, no count.
#pragma once
#include <atomic>
#include <chrono>
#include <cstdint>

namespace shprobe {

struct WorkCounter {
    std::atomic<uint64_t> total{0};
    std::atomic<uint64_t> done{0};
    std::atomic<uint64_t> texelsPerItem{0};                    // for the rate: "20.1 Mtexels/s"
    std::atomic<std::chrono::steady_clock::rep> startTicks{0}; // when the stage began
    // What is counted ("resampling, rows"), set last by startWork: a reader that sees it sees the
    // stage's total.
    std::atomic<const char*> what{nullptr};
};

// A loop's stage begins: `total` items of `texelsPerItem` texels each.
inline void startWork(WorkCounter* counter, const char* what, uint64_t total, uint64_t texelsPerItem) {
    if (!counter) return;
    counter->done.store(0, std::memory_order_relaxed);
    counter->total.store(total, std::memory_order_relaxed);
    counter->texelsPerItem.store(texelsPerItem, std::memory_order_relaxed);
    counter->startTicks.store(std::chrono::steady_clock::now().time_since_epoch().count(),
                              std::memory_order_relaxed);
    counter->what.store(what, std::memory_order_release);
}

inline void countWork(WorkCounter* counter, uint64_t items) {
    if (counter) counter->done.fetch_add(items, std::memory_order_relaxed);
}

} // namespace shprobe
