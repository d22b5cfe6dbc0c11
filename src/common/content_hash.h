// A 64-bit hash of bytes that names content, not where it lies: a probe volume records the hash of
// the scene files it was baked from, so that the scene is recognized under any path. It identifies;
// it does not authenticate (anyone can make two inputs of one hash on purpose).
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

namespace shprobe {

// FNV-1a, 64 bits: Fowler, Noll and Vo, "The FNV Non-Cryptographic Hash Algorithm"
// (IETF draft-eastlake-fnv): for each byte, hash = (hash xor byte) * 1099511628211, from the offset
// basis 14695981039346656037, modulo 2^64.
class Fnv1a64 {
  public:
    void add(std::string_view bytes) {
        for (const char c : bytes) {
            hash_ ^= uint8_t(c);
            hash_ *= kPrime;
        }
    }
    // A length as 8 bytes, least significant first: placed before each part, it keeps "ab" + "c"
    // and "a" + "bc" apart.
    void addLength(uint64_t length) {
        char bytes[8];
        for (int i = 0; i < 8; ++i)
            bytes[i] = char(uint8_t(length >> (8 * i)));
        add({bytes, sizeof(bytes)});
    }
    uint64_t value() const { return hash_; }
    // "fnv1a64:" and 16 lowercase hex digits, most significant first.
    std::string text() const {
        static constexpr char kDigits[] = "0123456789abcdef";
        std::string out = "fnv1a64:";
        for (int shift = 60; shift >= 0; shift -= 4)
            out += kDigits[(hash_ >> shift) & 0xF];
        return out;
    }

  private:
    static constexpr uint64_t kPrime = 1099511628211ull;
    uint64_t hash_ = 14695981039346656037ull;
};

} // namespace shprobe
