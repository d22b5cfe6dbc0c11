// Images the tests write or project, made from a function of the pixel.
#pragma once
#include "sh/cubemap.h"

#include <functional>
#include <glm/vec3.hpp>

namespace shprobe::testing {

// A width x height image whose pixel (x, y) is value(x, y), alpha 1.
inline Image filledImage(int width, int height, const std::function<glm::vec3(int, int)>& value) {
    Image image = makeImage(width, height);
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x)
            image.at(x, y) = glm::vec4(value(x, y), 1.0f);
    return image;
}

inline Image constantImage(int width, int height, glm::vec3 value) {
    return filledImage(width, height, [&](int, int) { return value; });
}

} // namespace shprobe::testing
