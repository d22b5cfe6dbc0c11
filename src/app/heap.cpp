// A bake allocates its large buffers (the decoded image, OpenEXR's chunk buffers) once per input
// and touches every page of them, and each first touch of a fresh 4 KiB page is a fault (a third
// of a bake's time, docs/benchmark.md "Memory faults"). glibc's defaults also give such buffers back to the
// kernel when freed (mmap and munmap above a threshold that a same-size request then still exceeds), so a
// batch faults on every input again. Here the program keeps freed memory for reuse, all threads allocate from
// the main heap, and the next 64 MiB of that heap are advised as transparent huge pages (where the kernel
// offers them on request, as Debian's does), so that a first touch costs one fault per 2 MiB: what glibc's
// tunable glibc.malloc.hugetlb=1 does, which only the environment can set. Other C libraries keep their
// defaults.
#include "app/heap.h"

#include <cstddef>
#include <cstdlib>

#if defined(__GLIBC__)
#include <malloc.h>
#include <sys/mman.h>
#include <unistd.h>
#endif

namespace shprobe {

HugePageHeap prepareHeap() {
#if defined(__GLIBC__)
    constexpr size_t kMiB = size_t(1) << 20;
    constexpr uintptr_t kHugePage = 2 * kMiB;
    constexpr size_t kAdvised = 64 * kMiB;
    constexpr size_t kChunkHeader = 2 * sizeof(size_t); // glibc's, before each block
    mallopt(M_MMAP_THRESHOLD, int(32 * kMiB)); // the largest glibc accepts: larger images stay mmap'ed
    mallopt(M_TRIM_THRESHOLD, int(512 * kMiB));
    mallopt(M_ARENA_MAX, 1);
    // The heap grows by the request and the pad, and the new top's header is written at the end of
    // the request: every byte written so far lies below `begin`. The kernel makes a huge page only
    // of 2 MiB none of whose 4 KiB pages is mapped, so the advice starts above all of them; the
    // first 2 MiB boundary above the block would lie below that header.
    mallopt(M_TOP_PAD, int(kAdvised));
    void* block = std::malloc(kHugePage);
    mallopt(M_TOP_PAD, int(kMiB));
    const uintptr_t at = reinterpret_cast<uintptr_t>(block);
    const uintptr_t begin = (at + kHugePage + kChunkHeader + kHugePage - 1) & ~(kHugePage - 1);
    const uintptr_t end = reinterpret_cast<uintptr_t>(sbrk(0)) & ~(kHugePage - 1);
    // Only where the heap grew where the break says (not under a sanitizer's allocator, say).
    // And only where the kernel takes the advice (it may have no huge pages).
    if (!block || begin >= end || end - begin > kAdvised + 2 * kHugePage ||
        madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE) != 0) {
        std::free(block);
        return {};
    }
    // The block grows up to `begin` (in place: the heap's top follows it) and is kept for the
    // process, none of its pages touched but its first, so that the next large buffers start there,
    // on a huge page, and not below it.
    static void* kept = nullptr;
    kept = std::realloc(block, begin - at - kChunkHeader);
    if (!kept) kept = block;
    return {begin, end};
#else
    return {};
#endif
}

} // namespace shprobe
