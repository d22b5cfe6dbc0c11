// PNG files put together chunk by chunk (PNG specification, ISO/IEC 15948, 5.3), for the tests
// that need what no writer makes: files cut short, damaged CRCs, chunks in odd places.
#pragma once
#include <cstdint>
#include <string>

namespace shprobe::testing {

inline std::string bigEndian32(uint32_t value) {
    return {char(value >> 24), char(value >> 16), char(value >> 8), char(value)};
}

// PNG's CRC-32 (ISO 3309: polynomial 0xedb88320, reflected), bit by bit.
inline uint32_t pngCrc(const std::string& bytes) {
    uint32_t crc = 0xffffffffu;
    for (unsigned char byte : bytes) {
        crc ^= byte;
        for (int bit = 0; bit < 8; ++bit)
            crc = (crc >> 1) ^ (0xedb88320u & (0u - (crc & 1u)));
    }
    return ~crc;
}

// Length, type, data and CRC; crcFlip is XORed into the CRC to damage it.
inline std::string pngChunk(const std::string& type, const std::string& data, uint32_t crcFlip = 0) {
    return bigEndian32(uint32_t(data.size())) + type + data + bigEndian32(pngCrc(type + data) ^ crcFlip);
}

inline const std::string kPngSignature("\x89PNG\r\n\x1a\n", 8);

} // namespace shprobe::testing
