// Work spread over all cores for loops whose items are independent: each item writes its own
// outputs, so the result is the same, bit for bit, for any number of threads.
#pragma once
#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <mutex>
#include <system_error>
#include <thread>
#include <vector>

namespace shprobe {

// All cores, but no more threads than the work is worth: a thread should get at least
// workPerThread units, so that starting it (tens of microseconds) stays a small part of its run.
// Small work does not even ask for the core count, which reads /sys.
inline unsigned threadCount(size_t work, size_t workPerThread) {
    const size_t worth = work / workPerThread;
    if (worth <= 1) return 1;
    return unsigned(std::max<size_t>(1, std::min<size_t>(std::thread::hardware_concurrency(), worth)));
}

// Calls task(item) for every item in [0, count) on `threads` threads, the caller's among them;
// each takes the next item not yet taken. Items must write disjoint outputs. The first exception a
// task throws (out of memory, say) stops the items not yet taken and reaches the caller once every
// thread has stopped, as the plain loop's would; an exception leaving a thread would end the process.
template <typename Task> void forEachItem(int count, unsigned threads, const Task& task) {
    if (threads <= 1) { // the plain loop: no shared counter
        for (int item = 0; item < count; ++item)
            task(item);
        return;
    }
    std::atomic<int> next{0};
    std::mutex failureLock;
    std::exception_ptr failure;
    const auto work = [&] {
        try {
            for (int item = next++; item < count; item = next++)
                task(item);
        } catch (...) {
            next = count;
            const std::lock_guard lock(failureLock);
            if (!failure) failure = std::current_exception();
        }
    };
    {
        std::vector<std::jthread> workers;
        for (unsigned t = 1; t < threads && int(t) < count; ++t) {
            try {
                workers.emplace_back(work);
            } catch (const std::system_error&) {
                break; // a process limit on threads: those running, and the caller's, take the rest
            }
        }
        work();
    } // the workers join here
    if (failure) std::rethrow_exception(failure);
}

} // namespace shprobe
