// loadGltfScene on arbitrary bytes (written to a file of a private folder, since a .gltf names its
// buffers and images by path): it must return a consistent World or throw shprobe::Error, never
// crash, hang or throw anything else. A World it returns must hold what the capture and the
// reference index blindly: whole triangles, indices within the vertices, one material per triangle
// that exists, textures that exist with their texels, finite positions inside the bounds, and no
// more triangles or texture pixels than the limits it was given.
#include "fuzz_support.h"
#include "scene/gltf_scene.h"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>

using namespace shprobe;

namespace {

bool validTexture(const World& world, int index) {
    return index == -1 || (index >= 0 && size_t(index) < world.textures.size());
}

void checkWorld(const World& world, const GltfLoadOptions& options) {
    const size_t vertices = world.positions.size();
    if (world.triangleCount() > options.maxTriangles) fuzz::finding("more triangles than the limit");
    int64_t pixels = 0;
    for (const SceneTexture& texture : world.textures) {
        const int64_t size = int64_t(texture.width) * texture.height;
        if (size > options.maxTexturePixels) fuzz::finding("a texture larger than the limit");
        pixels += size;
    }
    if (pixels > options.maxSceneTexturePixels) fuzz::finding("more texture pixels than the limit");
    if (world.indices.size() % 3 != 0) fuzz::finding("indices are not whole triangles");
    if (world.normals.size() != vertices || world.uvs.size() != vertices)
        fuzz::finding("normals or uvs do not match the positions");
    for (uint32_t index : world.indices)
        if (index >= vertices) fuzz::finding("an index past the vertices");
    if (world.triangleMaterials.size() != world.triangleCount()) fuzz::finding("one material per triangle");
    for (uint32_t material : world.triangleMaterials)
        if (material >= world.materials.size()) fuzz::finding("a triangle's material does not exist");
    for (const SceneMaterial& material : world.materials)
        if (!validTexture(world, material.albedoTexture) || !validTexture(world, material.emissionTexture))
            fuzz::finding("a material's texture does not exist");
    for (const SceneTexture& texture : world.textures)
        if (texture.width <= 0 || texture.height <= 0 ||
            texture.texels.size() != size_t(texture.width) * size_t(texture.height))
            fuzz::finding("a texture's texels do not match its size");
    for (const glm::vec3& p : world.positions)
        for (int a = 0; a < 3; ++a)
            if (!std::isfinite(p[a]) || p[a] < world.boundsMin[a] || p[a] > world.boundsMax[a])
                fuzz::finding("a position is not finite or outside the bounds");
}

// A private folder under $TMPDIR for the input file, removed when the fuzzer exits.
struct TemporaryFolder {
    std::string path;
    TemporaryFolder() : path((std::filesystem::temp_directory_path() / "fuzz_gltf_scene.XXXXXX").string()) {
        if (!mkdtemp(path.data())) fuzz::finding("cannot create a temporary folder in " + path);
    }
    ~TemporaryFolder() {
        std::error_code ignored;
        std::filesystem::remove_all(path, ignored);
    }
};

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    static const TemporaryFolder folder;
    const std::string path = folder.path + "/scene.gltf";
    {
        std::ofstream out(path, std::ios::binary | std::ios::trunc);
        out.write(reinterpret_cast<const char*>(data), std::streamsize(size));
    }
    // Limits small enough that no input costs more than a few MiB to accept; whatever counts a
    // file claims, the reader checks them against these or against its bytes before allocating.
    const GltfLoadOptions options{
        .maxTriangles = 100'000, .maxTexturePixels = 256 * 256, .maxSceneTexturePixels = 4 * 256 * 256};
    fuzz::expectOnlyShprobeErrors("loadGltfScene",
                                  [&] { checkWorld(loadGltfScene(path, options), options); });
    return 0;
}
