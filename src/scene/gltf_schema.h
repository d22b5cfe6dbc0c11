// The JSON of a glTF file checked before tinygltf reads it (part of the glTF reader,
// scene/gltf_scene.h). tinygltf skips a property of the wrong type without a word (a name that is
// a number, a list of primitives that is an object, a texture index of -1), and it takes the
// bytes of an image's buffer view without checking that the view lies within its buffer: both
// are refused here first.
#pragma once
#include <string>
#include <string_view>

namespace shprobe {

// Parses `json` (nested at most 64 levels) and checks every property glTF 2.0's schema defines,
// and those of the extensions read (KHR_lights_punctual, KHR_materials_emissive_strength), for its
// JSON type: strings, finite numbers, booleans, indices (integers from 0 to 2^31 - 1), arrays of
// the right length, objects; every extension must be an object. extensionsRequired may name only
// the extensions read (KHR_mesh_quantization too). Buffers and buffer views must
// hold at least one byte, and every buffer view must lie within the byteLength of its buffer.
// Throws Error(Input) "PATH: REASON" naming the property ("scenes[0].name must be a string, not a
// number").
void checkGltfJson(std::string_view json, const std::string& path);

} // namespace shprobe
