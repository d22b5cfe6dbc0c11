// prepareHeap (src/app/heap.h): the first large buffer after it lies where the heap is advised as
// transparent huge pages, and not one of its 4 KiB pages is in memory before it is touched. The
// kernel makes a huge page only of 2 MiB none of whose pages is mapped yet, so a buffer over a page
// touched earlier (the header glibc writes when the heap grows, say) faults 4 KiB at a time: 512
// faults in place of one. Whether the kernel then has a huge page to give depends on the
// machine, so that is not checked here; docs/benchmark.md ("Memory faults") counts the faults.
// Cube maps and images past the heap's advice (glibc maps them apart) are advised where they are
// made, when the program asks (sh/cubemap.h adviseTexelHugePages).
#include "app/heap.h"
#include "sh/cubemap.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <sys/mman.h>
#include <unistd.h>

namespace shprobe {
namespace {

// The VmFlags of the mapping of /proc/self/smaps that holds `address` ("" if none does).
std::string mappingFlags(uintptr_t address) {
    std::ifstream smaps("/proc/self/smaps");
    bool holds = false;
    for (std::string line; std::getline(smaps, line);) {
        uintptr_t from = 0, to = 0;
        char dash = 0;
        std::istringstream range(line);
        if (range >> std::hex >> from >> dash >> to && dash == '-') holds = from <= address && address < to;
        if (holds && line.rfind("VmFlags:", 0) == 0) return line;
    }
    return "";
}

// Whether the kernel's transparent huge pages are off ("[never]"), or not there at all.
bool hugePagesOff() {
    std::ifstream enabled("/sys/kernel/mm/transparent_hugepage/enabled");
    std::string mode;
    return !std::getline(enabled, mode) || mode.find("[never]") != std::string::npos;
}

TEST(Heap, LargeBuffersStartOnUntouchedHugePages) {
    const HugePageHeap heap = prepareHeap();
#if !defined(__GLIBC__)
    GTEST_SKIP() << "the heap is set up with glibc only";
#endif
    if (heap.begin == heap.end) {
        // prepareHeap gives up where a sanitizer's allocator owns the heap or the kernel takes no
        // huge-page advice; anywhere else an empty heap is the failure this test is for.
        if (testing::underSanitizer() || hugePagesOff())
            GTEST_SKIP() << "a sanitizer's allocator, or no transparent huge pages";
        FAIL() << "prepareHeap advised no heap, with glibc's allocator and transparent huge pages on";
    }
    if (std::getenv("MALLOC_PERTURB_")) GTEST_SKIP() << "MALLOC_PERTURB_ makes glibc fill what it hands out";
    EXPECT_EQ(heap.begin % (2 << 20), 0u);
    EXPECT_GE(heap.end - heap.begin, size_t(62) << 20);

    // An image's worth: where it lies, no page of it in memory yet but those holding glibc's
    // headers, its first and last.
    const size_t size = size_t(8) << 20, page = size_t(sysconf(_SC_PAGESIZE));
    char* buffer = static_cast<char*>(std::malloc(size));
    ASSERT_NE(buffer, nullptr);
    const uintptr_t first = reinterpret_cast<uintptr_t>(buffer);
    EXPECT_GE(first, heap.begin);
    EXPECT_LE(first + size, heap.end);
    EXPECT_NE(mappingFlags(first).find(" hg"), std::string::npos) << mappingFlags(first);
    const uintptr_t from = (first / page + 1) * page, to = (first + size) / page * page;
    std::vector<unsigned char> resident((to - from) / page);
    ASSERT_EQ(mincore(reinterpret_cast<void*>(from), to - from, resident.data()), 0);
    size_t touched = 0;
    for (unsigned char flags : resident)
        touched += flags & 1;
    EXPECT_EQ(touched, 0u) << "of " << resident.size() << " pages";
    std::free(buffer);
}

// A cube map of 6 x 1024^2 texels (96 MiB, past glibc's mmap threshold of at most 32 MiB, so a
// mapping of its own) is advised as huge pages when asked, and not otherwise; its fill is kept.
TEST(Heap, TexelsAreAdvisedWhenAsked) {
    if (testing::underSanitizer() || hugePagesOff())
        GTEST_SKIP() << "a sanitizer's allocator, or no transparent huge pages";
    auto interior = [](const Cubemap& cubemap) { // a 2 MiB boundary inside the texels
        constexpr uintptr_t kHugePage = uintptr_t(2) << 20;
        return (reinterpret_cast<uintptr_t>(cubemap.texels.data()) + kHugePage) & ~(kHugePage - 1);
    };
    adviseTexelHugePages(false);
    const Cubemap plain = makeCubemap(1024);
    EXPECT_EQ(mappingFlags(interior(plain)).find(" hg"), std::string::npos) << mappingFlags(interior(plain));
    adviseTexelHugePages(true);
    const Cubemap advised = makeCubemap(1024, glm::vec4(0.0f, 0.0f, 0.0f, 1.0f));
    adviseTexelHugePages(false);
    EXPECT_NE(mappingFlags(interior(advised)).find(" hg"), std::string::npos)
        << mappingFlags(interior(advised));
    EXPECT_EQ(advised.texels.size(), size_t(6) << 20);
    EXPECT_EQ(advised.texels.back(), glm::vec4(0.0f, 0.0f, 0.0f, 1.0f));
}

} // namespace
} // namespace shprobe
