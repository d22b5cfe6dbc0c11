// The progress line of long jobs (scene bakes, batches, single bakes of large inputs, reference
// bakes): on stderr, only where stderr is a terminal and not with -q, what is done, the rate and
// the time left, "probes 1200/4096, 3.1 Mrays/s, 12 s left" (a batch draws it as a bar,
// "[#####-----] 12/40 probes, 5.2 probes/s, 3 s left"). Redrawn at most every quarter second (and
// once more for the last item), erased at the end, so that stdout and the error lines stay as
// they are without a terminal.
#pragma once
#include "app/stopwatch.h"
#include "common/work_counter.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <mutex>
#include <optional>
#include <stop_token>
#include <string>
#include <system_error>
#include <thread>
#include <unistd.h>

namespace shprobe {

class ProgressLine {
  public:
    struct Style {
        bool bar = false;              // "[#####-----] 12/40 probes" instead of "probes 12/40"
        double firstDrawSeconds = 0.0; // nothing is drawn before the job has run this long
    };

    // `noun`: what is counted, in the plural ("probes", "rows").
    ProgressLine(std::string noun, uint64_t total, bool quiet, Style style)
        : noun_(std::move(noun)), total_(total), style_(style),
          enabled_(!quiet && isatty(STDERR_FILENO) == 1) {}
    ProgressLine(std::string noun, uint64_t total, bool quiet)
        : ProgressLine(std::move(noun), total, quiet, {}) {}
    ~ProgressLine() { clear(); }
    ProgressLine(const ProgressLine&) = delete;
    ProgressLine& operator=(const ProgressLine&) = delete;

    // The rate and the time left count from `start` (a job that began before the line was made).
    void startedAt(Clock::time_point start) { start_ = start; }

    bool enabled() const { return enabled_; }
    // Stops drawing for good (the job's summary follows), erasing the line.
    void disable() {
        clear();
        enabled_ = false;
    }

    // `done` of the total; `work` counts what the rate is of when it is not the items themselves
    // (rays: "3.1 Mrays/s"), in `workUnit`. Drawn when due.
    void update(uint64_t done, double work = -1.0, const char* workUnit = nullptr) {
        done_ = done;
        work_ = work;
        workUnit_ = workUnit;
        if (!enabled_) return;
        const double sinceStart = millisecondsSince(start_) / 1000.0;
        if (sinceStart < style_.firstDrawSeconds) return;
        const bool last = done_ >= total_;
        if (drawn_ && !last && millisecondsSince(lastDraw_) < kRedrawMilliseconds) return;
        draw();
    }

    // Erases the line (before another line is printed); redraw() puts it back.
    void clear() {
        if (!drawn_) return;
        std::fputs("\r\033[K", stderr);
        std::fflush(stderr);
        drawn_ = false;
    }
    void redraw() {
        if (enabled_ && millisecondsSince(start_) / 1000.0 >= style_.firstDrawSeconds) draw();
    }

  private:
    static constexpr double kRedrawMilliseconds = 250.0;

    // "3.1 M" for 3.1e6: the rate with an SI prefix.
    static std::string scaled(double value) {
        const char* prefix = "";
        for (const char* next : {"k", "M", "G", "T"}) {
            if (value < 1000.0) break;
            value /= 1000.0;
            prefix = next;
        }
        char text[32];
        std::snprintf(text, sizeof text, "%.1f %s", value, prefix);
        return text;
    }

    void draw() {
        const double seconds = std::max(1e-9, millisecondsSince(start_) / 1000.0);
        std::string line;
        if (style_.bar) {
            constexpr uint64_t kWidth = 30;
            const uint64_t filled = total_ > 0 ? std::min(done_, total_) * kWidth / total_ : kWidth;
            line = "[" + std::string(filled, '#') + std::string(kWidth - filled, '-') + "] " +
                   std::to_string(done_) + "/" + std::to_string(total_) + " " + noun_;
        } else {
            line = noun_ + " " + std::to_string(done_) + "/" + std::to_string(total_);
        }
        line += ", " +
                (work_ >= 0.0 && workUnit_ ? scaled(work_ / seconds) + workUnit_
                                           : scaled(double(done_) / seconds) + noun_) +
                "/s";
        if (done_ > 0 && done_ < total_) {
            char left[32];
            std::snprintf(left, sizeof left, ", %.0f s left",
                          seconds * double(total_ - done_) / double(done_));
            line += left;
        } else if (done_ == 0) {
            line += ", time left unknown";
        }
        std::fprintf(stderr, "\r%s\033[K", line.c_str()); // erases what a longer line left
        std::fflush(stderr);
        drawn_ = true;
        lastDraw_ = Clock::now();
    }

    std::string noun_;
    uint64_t total_;
    Style style_;
    bool enabled_;
    bool drawn_ = false;
    uint64_t done_ = 0;
    double work_ = -1.0;
    const char* workUnit_ = nullptr;
    Clock::time_point start_ = Clock::now();
    Clock::time_point lastDraw_ = Clock::now();
};

// The progress line of a job whose loops run in library code and count into a WorkCounter
// (common/work_counter.h): a thread of its own redraws the line from the counter, a line per stage
// ("resampling, rows 1200/4096, 20.1 Mtexels/s, 3 s left", then "projecting, rows ..."), and
// nothing before the job has run a second. counter() is null where no line is drawn (not a
// terminal, -q), so that the loops count nothing. The line is erased when this is destroyed.
class CountedProgress {
  public:
    explicit CountedProgress(bool quiet) {
        if (quiet || isatty(STDERR_FILENO) != 1) return;
        try {
            watcher_ = std::jthread([this](std::stop_token stop) { watch(stop); });
        } catch (const std::system_error&) { // no thread: no line
        }
    }
    ~CountedProgress() { stop(); }
    CountedProgress(const CountedProgress&) = delete;
    CountedProgress& operator=(const CountedProgress&) = delete;

    WorkCounter* counter() { return watcher_.joinable() ? &counter_ : nullptr; }
    // Stops drawing for good and erases the line (before the job's summary).
    void stop() {
        if (!watcher_.joinable()) return;
        watcher_.request_stop();
        watcher_.join();
    }

  private:
    static constexpr auto kPoll = std::chrono::milliseconds(100);
    static constexpr double kFirstDrawSeconds = 1.0;

    void watch(std::stop_token stop) {
        const Clock::time_point start = Clock::now();
        const char* shown = nullptr;
        std::optional<ProgressLine> line;
        std::mutex mutex;
        std::condition_variable_any wake;
        std::unique_lock lock(mutex);
        while (!stop.stop_requested()) {
            wake.wait_for(lock, stop, kPoll, [] { return false; }); // a poll interrupted by stop()
            if (stop.stop_requested()) break;
            const char* what = counter_.what.load(std::memory_order_acquire);
            if (!what) continue;
            if (what != shown) {
                shown = what;
                const Clock::time_point stageStart(
                    Clock::duration(counter_.startTicks.load(std::memory_order_relaxed)));
                const double stageBegan = std::chrono::duration<double>(stageStart - start).count();
                line.emplace(
                    what, counter_.total.load(std::memory_order_relaxed), false,
                    ProgressLine::Style{.firstDrawSeconds = std::max(0.0, kFirstDrawSeconds - stageBegan)});
                line->startedAt(stageStart);
            }
            if (!line) continue; // the stage is over: its line is erased
            const uint64_t done = counter_.done.load(std::memory_order_relaxed);
            if (done >= counter_.total.load(std::memory_order_relaxed)) {
                line.reset();
                continue;
            }
            line->update(done, double(done) * double(counter_.texelsPerItem.load(std::memory_order_relaxed)),
                         "texels");
        }
    }

    WorkCounter counter_;
    std::jthread watcher_; // last: it reads counter_
};

} // namespace shprobe
