// How the programs set up glibc's heap before a command runs (heap.cpp says why).
#pragma once
#include <cstdint>

namespace shprobe {

// The part of the heap advised as transparent huge pages, [begin, end); empty where none was (other
// C libraries, a sanitizer's allocator, a break that could not move, a kernel without them).
struct HugePageHeap {
    uintptr_t begin = 0;
    uintptr_t end = 0;
};

// Freed memory kept for reuse, one arena for all threads, and the next 64 MiB of the heap advised
// as huge pages, the first large allocation after this call starting on one. Call once, before the
// command allocates its buffers.
HugePageHeap prepareHeap();

} // namespace shprobe
