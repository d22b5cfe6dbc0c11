// SceneShading (surface_shading.h): the World's checks, and a surface point's normals and
// materials in double precision from the triangle's own vertices and the ray caster's barycentrics.
#include "scene/surface_shading.h"

#include "common/error.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <utility>

namespace shprobe {

namespace {

// --- World checks ------------------------------------------------------------------------------

Error sceneError(const std::string& message) {
    return Error(ErrorKind::Input, "scene: " + message);
}

template <glm::length_t L> bool isFinite(const glm::vec<L, float>& v) {
    for (glm::length_t i = 0; i < L; ++i) {
        if (!std::isfinite(v[i])) return false;
    }
    return true;
}

void requireVertices(const World& world) {
    const size_t count = world.positions.size();
    if (world.normals.size() != count || world.uvs.size() != count) {
        throw sceneError(std::to_string(count) + " positions but " + std::to_string(world.normals.size()) +
                         " normals and " + std::to_string(world.uvs.size()) + " texture coordinates");
    }
    for (size_t i = 0; i < count; ++i) {
        if (!isFinite(world.positions[i]) || !isFinite(world.normals[i]) || !isFinite(world.uvs[i]))
            throw sceneError("vertex " + std::to_string(i) + " is not finite");
    }
}

void requireTriangles(const World& world) {
    if (world.indices.size() % 3 != 0 || world.triangleMaterials.size() != world.triangleCount()) {
        throw sceneError(std::to_string(world.indices.size()) + " indices for " +
                         std::to_string(world.triangleMaterials.size()) + " triangle materials");
    }
    for (size_t i = 0; i < world.indices.size(); ++i) {
        if (world.indices[i] >= world.positions.size()) {
            throw sceneError("index " + std::to_string(i) + " is " + std::to_string(world.indices[i]) +
                             ", past the " + std::to_string(world.positions.size()) + " vertices");
        }
    }
    for (size_t t = 0; t < world.triangleMaterials.size(); ++t) {
        if (world.triangleMaterials[t] >= world.materials.size()) {
            throw sceneError("triangle " + std::to_string(t) + " has material " +
                             std::to_string(world.triangleMaterials[t]) + " of " +
                             std::to_string(world.materials.size()));
        }
    }
}

void requireMaterials(const World& world) {
    const int textures = int(world.textures.size());
    for (size_t m = 0; m < world.materials.size(); ++m) {
        for (int texture : {world.materials[m].albedoTexture, world.materials[m].emissionTexture}) {
            if (texture < -1 || texture >= textures) {
                throw sceneError("material " + std::to_string(m) + " names texture " +
                                 std::to_string(texture) + " of " + std::to_string(textures));
            }
        }
    }
    for (size_t t = 0; t < world.textures.size(); ++t) {
        const SceneTexture& texture = world.textures[t];
        if (texture.width < 1 || texture.height < 1 ||
            texture.texels.size() != size_t(texture.width) * size_t(texture.height)) {
            throw sceneError("texture " + std::to_string(t) + " is " + std::to_string(texture.width) + " x " +
                             std::to_string(texture.height) + " with " +
                             std::to_string(texture.texels.size()) + " texels");
        }
    }
}

// The suns with unit directions; a sun must have a direction and finite irradiance.
std::vector<SceneSun> normalizedSuns(std::vector<SceneSun> suns) {
    for (size_t s = 0; s < suns.size(); ++s) {
        const float length = glm::length(suns[s].direction);
        if (!std::isfinite(length) || length == 0.0f || !isFinite(suns[s].irradiance))
            throw sceneError("sun " + std::to_string(s) + " has no direction or a non-finite irradiance");
        suns[s].direction /= length;
    }
    return suns;
}

void requireSky(const Cubemap& sky) {
    if (sky.faceSize < 1 || sky.texels.size() != size_t(kFaceCount) * sky.faceSize * sky.faceSize) {
        throw sceneError("the sky cube map of face size " + std::to_string(sky.faceSize) + " holds " +
                         std::to_string(sky.texels.size()) + " texels");
    }
}

// Zero-area triangles cover no solid angle and have no normal: they are left out of Embree's scene.
std::vector<uint32_t> triangleList(const World& world) {
    std::vector<uint32_t> triangles;
    for (uint32_t t = 0; t < uint32_t(world.triangleCount()); ++t)
        if (hasArea(world, t)) triangles.push_back(t);
    return triangles;
}

double largestCoordinate(const glm::vec3& p) {
    return std::max({double(std::abs(p.x)), double(std::abs(p.y)), double(std::abs(p.z))});
}

double largestCoordinate(const World& world) {
    double largest = 0.0;
    for (const glm::vec3& p : world.positions)
        largest = std::max(largest, largestCoordinate(p));
    return largest;
}

// (1 - u - v) a0 + u a1 + v a2 in double: Embree's barycentrics weigh the vertices so (Embree's
// triangle parametrization).
template <typename Vector>
auto interpolate(const std::vector<Vector>& attribute, const uint32_t* vertex, const glm::dvec3& weights) {
    using Double = glm::vec<Vector::length(), double>;
    return weights.x * Double(attribute[vertex[0]]) + weights.y * Double(attribute[vertex[1]]) +
           weights.z * Double(attribute[vertex[2]]);
}

// The unit normal of the counter-clockwise winding (scene.h: triangles face the side they turn
// counter-clockwise on).
glm::dvec3 geometricNormal(const World& world, const uint32_t* vertex) {
    const glm::dvec3 p0(world.positions[vertex[0]]);
    const glm::dvec3 p1(world.positions[vertex[1]]);
    const glm::dvec3 p2(world.positions[vertex[2]]);
    return glm::normalize(glm::cross(p1 - p0, p2 - p0));
}

// The interpolated vertex normal, unit; where the vertex normals cancel, the geometric one.
glm::dvec3 shadingNormal(const glm::dvec3& interpolated, const glm::dvec3& geometric) {
    const double length = glm::length(interpolated);
    return length > 0.0 ? interpolated / length : geometric;
}

// x mod n in [0, n), for finite x.
double wrap(double x, int n) {
    const double r = std::fmod(x, double(n));
    return r < 0.0 ? r + n : r;
}

// glTF's default sampler: bilinear, repeat; texel (i, j) centred at ((i + 0.5) / w, (j + 0.5) / h),
// rows top to bottom from v = 0 at the top (glTF 2.0, "Images"). Alpha is not read: surfaces are opaque.
glm::dvec3 sampleBilinear(const SceneTexture& texture, const glm::dvec2& uv) {
    const double x = wrap(uv.x * texture.width - 0.5, texture.width);
    const double y = wrap(uv.y * texture.height - 0.5, texture.height);
    // wrap's r + n rounds to n for a tiny negative r: then i0 = n - 1 with fx = 1, all weight on texel 0.
    const int i0 = std::min(int(x), texture.width - 1);
    const int j0 = std::min(int(y), texture.height - 1);
    const int i1 = (i0 + 1) % texture.width;
    const int j1 = (j0 + 1) % texture.height;
    const double fx = x - i0;
    const double fy = y - j0;
    const auto texel = [&](int i, int j) {
        return glm::dvec3(glm::vec3(texture.texels[size_t(j) * texture.width + i]));
    };
    const glm::dvec3 top = (1.0 - fx) * texel(i0, j0) + fx * texel(i1, j0);
    const glm::dvec3 bottom = (1.0 - fx) * texel(i0, j1) + fx * texel(i1, j1);
    return (1.0 - fy) * top + fy * bottom;
}

glm::dvec3 materialColor(const World& world, const glm::vec3& factor, int texture, const glm::dvec2& uv) {
    if (texture < 0) return glm::dvec3(factor);
    return glm::dvec3(factor) * sampleBilinear(world.textures[size_t(texture)], uv);
}

// The sky texel a direction falls in: face-local (a, b) to texel i = floor((a + 1) / 2 N), as
// Vulkan's NEAREST filter picks it ("Cube Map Face Selection", then "Texel Selection").
glm::dvec3 nearestSkyTexel(const Cubemap& sky, const glm::dvec3& direction) {
    const FacePoint point = directionToFace(direction);
    const int n = sky.faceSize;
    const auto texel = [n](double coordinate) {
        return std::clamp(int(std::floor((coordinate + 1.0) * 0.5 * n)), 0, n - 1);
    };
    return glm::dvec3(glm::vec3(sky.at(point.face, texel(point.a), texel(point.b))));
}

// A number as the messages give it: 3 significant digits ("3.46e-11", "2e+06", "0.5").
std::string number(double value) {
    char text[32];
    std::snprintf(text, sizeof(text), "%.3g", value);
    return text;
}

} // namespace

void checkSceneScale(const World& world) {
    if (world.triangleCount() == 0) return; // the sky alone, at any scale
    const std::string name = world.description.empty() ? "scene" : world.description;
    auto scaleError = [&](const std::string& message) {
        return Error(ErrorKind::Input, name + ": " + message);
    };
    glm::dvec3 low(INFINITY), high(-INFINITY); // of the positions: a World built by hand may not set bounds
    for (const glm::vec3& p : world.positions) {
        low = glm::min(low, glm::dvec3(p));
        high = glm::max(high, glm::dvec3(p));
    }
    const double size = glm::length(high - low);
    const double largest = largestCoordinate(world);
    if (largest > kMaxSceneCoordinate)
        throw scaleError("its coordinates reach " + number(largest) + ", beyond the " +
                         number(kMaxSceneCoordinate) +
                         " the float ray test and capture hold (products of three coordinates); scale "
                         "the scene down");
    if (size == 0.0) throw scaleError("all its vertices lie at one point, so no triangle has any area");
    if (size < kMinSceneSize)
        throw scaleError("it is " + number(size) + " across (its box's diagonal), smaller than the " +
                         number(kMinSceneSize) +
                         " the float ray test and capture resolve (products of three coordinates); scale "
                         "the scene up");
    const double offset = kSurfaceOffsetScale * largest;
    if (offset > kMaxSurfaceOffsetShare * size)
        throw scaleError("its coordinates reach " + number(largest) + ", where float's spacing (" +
                         number(largest * std::numeric_limits<float>::epsilon()) +
                         ") is too coarse for a scene " + number(size) +
                         " across: rays leaving a surface start 256 such steps off it (" + number(offset) +
                         "), more than " + number(100.0 * kMaxSurfaceOffsetShare) +
                         "% of the scene; move the scene nearer the origin");
}

SceneShading::SceneShading(World world, const Cubemap& sky) {
    requireVertices(world);
    requireTriangles(world);
    checkSceneScale(world);
    requireMaterials(world);
    requireSky(sky);
    world.suns = normalizedSuns(std::move(world.suns));
    solidTriangles_ = triangleList(world);
    // Rays never meet a triangle of no area: such a scene would bake the sky alone without a word.
    if (world.triangleCount() > 0 && solidTriangles_.empty())
        throw Error(ErrorKind::Input, (world.description.empty() ? "scene" : world.description) +
                                          ": no triangle has any area (the corners of each lie on a line)");
    world_ = std::move(world);
    sky_ = sky;
}

double SceneShading::offset(uint32_t triangle) const {
    double largest = 0.0;
    for (int corner = 0; corner < 3; ++corner)
        largest = std::max(
            largest,
            largestCoordinate(world_.positions[world_.indices[3 * size_t(triangle) + size_t(corner)]]));
    return kSurfaceOffsetScale * largest;
}

SurfaceHit SceneShading::describe(uint32_t triangle, const glm::dvec2& barycentric,
                                  const glm::dvec3& direction) const {
    const uint32_t* vertex = &world_.indices[3 * size_t(triangle)];
    const glm::dvec3 weights(1.0 - barycentric.x - barycentric.y, barycentric.x, barycentric.y);
    const SceneMaterial& material = world_.materials[world_.triangleMaterials[triangle]];
    const glm::dvec3 normal = geometricNormal(world_, vertex);
    const bool front = glm::dot(normal, direction) < 0.0;
    const double side = front ? 1.0 : -1.0;
    SurfaceHit hit;
    hit.position = interpolate(world_.positions, vertex, weights);
    hit.normal = side * normal;
    hit.shadingNormal = side * shadingNormal(interpolate(world_.normals, vertex, weights), normal);
    hit.offset = offset(triangle);
    hit.rayOrigin = hit.position + hit.offset * hit.normal;
    const glm::dvec2 uv = interpolate(world_.uvs, vertex, weights);
    hit.albedo = materialColor(world_, material.albedo, material.albedoTexture, uv);
    hit.emission = materialColor(world_, material.emission, material.emissionTexture, uv);
    hit.triangle = triangle;
    hit.barycentric = barycentric;
    hit.frontSide = front;
    hit.backFace = !front && !material.doubleSided;
    return hit;
}

SurfaceHit SceneShading::surfacePoint(uint32_t triangle, const glm::dvec2& barycentric,
                                      bool frontSide) const {
    const glm::dvec3 normal = geometricNormal(world_, &world_.indices[3 * size_t(triangle)]);
    return describe(triangle, barycentric, frontSide ? -normal : normal);
}

glm::dvec3 SceneShading::skyRadiance(const glm::dvec3& direction) const {
    return nearestSkyTexel(sky_, direction);
}

} // namespace shprobe
