// Text from an input (a URI, a name, a string field, an option's value) as an error message quotes
// it: one short line whatever the input holds, since a file may put megabytes where a name belongs.
#pragma once
#include <cstddef>
#include <string>
#include <string_view>

namespace shprobe {

// The most bytes of an input a message quotes.
constexpr size_t kMaxQuotedBytes = 200;

// `text` cut to at most `limit` bytes (not inside a UTF-8 sequence), control bytes as '?'; a cut
// text ends in "..." and says its whole length: `abc... (64000000 bytes)`. For a library's
// message that holds input of its own.
inline std::string clipped(std::string_view text, size_t limit = kMaxQuotedBytes) {
    size_t keep = text.size();
    if (keep > limit) {
        keep = limit;
        while (keep > 0 && (static_cast<unsigned char>(text[keep]) & 0xC0) == 0x80)
            --keep; // a UTF-8 continuation byte: cut before its sequence
    }
    std::string shown(text.substr(0, keep));
    for (char& c : shown)
        if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
    if (keep < text.size()) shown += "... (" + std::to_string(text.size()) + " bytes)";
    return shown;
}

// `text` in double quotes, as clipped cuts it: "abc" or "abc..." (64000000 bytes).
inline std::string quotedInput(std::string_view text, size_t limit = kMaxQuotedBytes) {
    if (text.size() <= limit) return "\"" + clipped(text, limit) + "\"";
    const std::string shown = clipped(text, limit);
    const size_t dots = shown.rfind("... (");
    return "\"" + shown.substr(0, dots + 3) + "\"" + shown.substr(dots + 3);
}

} // namespace shprobe
