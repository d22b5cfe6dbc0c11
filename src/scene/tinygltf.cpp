// tinygltf's implementation, compiled once, for the glTF reader (scene/gltf_scene.h). Every file of
// shprobe_scene is compiled with TINYGLTF_NO_STB_IMAGE, TINYGLTF_NO_STB_IMAGE_WRITE and
// TINYGLTF_NO_EXTERNAL_IMAGE (CMakeLists.txt), so that all of them see the same TinyGLTF class:
// without tinygltf's copy of stb_image (images are decoded by scene_images.cpp, and image files
// read by gltf_scene.cpp, when a material uses them). JSON is parsed by the system's nlohmann-json,
// which Debian's tiny_gltf.h includes as <nlohmann/json.hpp>.
#define TINYGLTF_IMPLEMENTATION
#include <tiny_gltf.h>
