// 32-bit words of the little-endian files shprobe reads and writes (.glb, .shpt) on a little-endian
// machine (transfer_gltf.cpp asserts it).
#pragma once
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>

namespace shprobe {

// The word at byte `at` (the caller checked that 4 bytes are there).
inline uint32_t littleEndian32(std::string_view bytes, size_t at) {
    uint32_t value;
    std::memcpy(&value, bytes.data() + at, 4);
    return value;
}

inline void appendLittleEndian32(std::string& bytes, uint32_t value) {
    bytes.append(reinterpret_cast<const char*>(&value), 4);
}

} // namespace shprobe
