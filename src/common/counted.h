// A count with its noun in agreement, for messages: counted(1, "texel") is "1 texel",
// counted(2, "texel") "2 texels", counted(0, "texel") "0 texels"; nouns whose plural is not a
// trailing s give it (counted(n, "child", "children")).
#pragma once
#include <concepts>
#include <string>
#include <string_view>

namespace shprobe {

template <std::integral Count>
std::string counted(Count n, std::string_view singular, std::string_view plural = {}) {
    std::string text = std::to_string(n) + ' ';
    if (n == 1) return text.append(singular);
    return plural.empty() ? text.append(singular).append("s") : text.append(plural);
}

} // namespace shprobe
