// A number as messages give it: six significant digits, an exponent where that is shorter
// (shortNumber(1e-30) "1e-30", shortNumber(0.5) "0.5", shortNumber(1e300) "1e+300"), where
// std::to_string writes "0.000000" and three hundred digits.
#pragma once
#include <cstdio>
#include <string>

namespace shprobe {

inline std::string shortNumber(double value) {
    char text[32];
    std::snprintf(text, sizeof(text), "%g", value);
    return text;
}

} // namespace shprobe
