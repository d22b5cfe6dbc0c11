// File names told apart by their extension, case aside: "SKY.EXR" names the same kind of file as
// "sky.exr", as it does to the tools that made it.
#pragma once
#include <algorithm>
#include <cctype>
#include <cstddef>
#include <string_view>

namespace shprobe {

// Whether `name` ends in `extension` (with its dot, possibly of several parts: ".unity.json"),
// ASCII letters in either case: hasExtension("T.GLB", ".glb").
inline bool hasExtension(std::string_view name, std::string_view extension) {
    if (name.size() < extension.size()) return false;
    const auto lower = [](char c) { return std::tolower(static_cast<unsigned char>(c)); };
    return std::equal(extension.begin(), extension.end(), name.end() - std::ptrdiff_t(extension.size()),
                      [&](char e, char n) { return lower(e) == lower(n); });
}

} // namespace shprobe
