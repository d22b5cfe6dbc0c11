// Decoding the images of a glTF scene's textures (part of the glTF reader, scene/gltf_scene.h):
// PNG or JPEG bytes, wherever the file keeps them, into SceneTexture's linear RGBA.
#pragma once
#include "scene/scene.h"

#include <cstdint>
#include <span>
#include <string>

namespace shprobe {

// glTF's colour textures (base colour, emissive) are sRGB whatever the image file says: 8-bit and
// 16-bit values are decoded with the exact sRGB EOTF (IEC 61966-2-1); grey images become grey RGB
// and alpha is ignored (set to 1). An image of more than maxPixels pixels is refused from its
// header, before it is decoded. Throws Error(Input) "WHAT: REASON" ("scene.gltf: image 0: not a
// PNG or JPEG image").
// The pixels of a texture from its header alone (nothing is decoded), after the checks
// decodeColourTexture makes first: a PNG or JPEG of at most maxPixels pixels.
int64_t colourTexturePixels(std::span<const unsigned char> bytes, int64_t maxPixels, const std::string& what);

SceneTexture decodeColourTexture(std::span<const unsigned char> bytes, int64_t maxPixels,
                                 const std::string& what);

} // namespace shprobe
