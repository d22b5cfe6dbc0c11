// Shared by the fuzz targets: the one rule they all check is that library code given hostile input
// either succeeds or throws shprobe::Error. Any other exception, like a crash or a sanitizer report,
// is a finding: it aborts, so libFuzzer saves the input as crash-<hash>.
#pragma once
#include "common/error.h"

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <string>

namespace shprobe::fuzz {

template <class Body> void expectOnlyShprobeErrors(const char* what, Body&& body) {
    try {
        body();
    } catch (const shprobe::Error&) {
        // The documented failure: a message for the user, exit code 2 in the program.
    } catch (const std::exception& e) {
        std::fprintf(stderr, "%s threw a foreign exception: %s\n", what, e.what());
        std::abort();
    } catch (...) {
        std::fprintf(stderr, "%s threw a non-std exception\n", what);
        std::abort();
    }
}

[[noreturn]] inline void finding(const std::string& message) {
    std::fprintf(stderr, "invariant broken: %s\n", message.c_str());
    std::abort();
}

// Reads the input front to back; past the end it yields zeros, so every input decodes.
class ByteReader {
  public:
    ByteReader(const uint8_t* data, size_t size) : data_(data), size_(size) {}

    uint8_t u8() { return position_ < size_ ? data_[position_++] : 0; }
    uint16_t u16() { return uint16_t(u8() | (u8() << 8)); }
    uint32_t u32() { return uint32_t(u16()) | (uint32_t(u16()) << 16); }
    float f32() {
        uint32_t bits = u32();
        float value;
        std::memcpy(&value, &bits, sizeof value);
        return value;
    }
    size_t remaining() const { return size_ - position_; }
    std::string rest() {
        std::string text(reinterpret_cast<const char*>(data_ + position_), size_ - position_);
        position_ = size_;
        return text;
    }

  private:
    const uint8_t* data_;
    size_t size_;
    size_t position_ = 0;
};

} // namespace shprobe::fuzz
