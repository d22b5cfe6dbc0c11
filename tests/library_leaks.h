// OpenImageIO 2.4's PNG reader leaks its error text (31 bytes) when libpng longjmps out of a
// truncated file (PNGInput::PngReadCallback): a LibraryLeaksIgnored in scope tells LeakSanitizer
// to overlook what is allocated during such a read. Nothing in other builds.
#pragma once

#if defined(__SANITIZE_ADDRESS__)
#define SHPROBE_TEST_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define SHPROBE_TEST_ASAN 1
#endif
#endif
#if defined(SHPROBE_TEST_ASAN)
#include <sanitizer/lsan_interface.h>
#endif

namespace shprobe::testing {

class LibraryLeaksIgnored {
  public:
#if defined(SHPROBE_TEST_ASAN)
    LibraryLeaksIgnored() {
        __lsan_disable();
    }
    ~LibraryLeaksIgnored() {
        __lsan_enable();
    }
#endif
};

} // namespace shprobe::testing
