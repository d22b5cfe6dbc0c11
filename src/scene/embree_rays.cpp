// Embree's ray casting (scene/embree_rays.h) and the plugin's entry point.
#include "scene/embree_rays.h"

#include "common/error.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace shprobe {

namespace {

const char* embreeErrorName(RTCError code) {
    switch (code) {
    case RTC_ERROR_NONE:
        return "no error";
    case RTC_ERROR_UNKNOWN:
        return "unknown error";
    case RTC_ERROR_INVALID_ARGUMENT:
        return "invalid argument";
    case RTC_ERROR_INVALID_OPERATION:
        return "invalid operation";
    case RTC_ERROR_OUT_OF_MEMORY:
        return "out of memory";
    case RTC_ERROR_UNSUPPORTED_CPU:
        return "unsupported CPU";
    case RTC_ERROR_CANCELLED:
        return "cancelled";
    }
    return "unknown error";
}

// The first error Embree reports through its callback, which may run on its build threads and must
// not throw through Embree: it is kept here and thrown after the call that caused it.
struct EmbreeErrors {
    std::mutex mutex;
    RTCError code = RTC_ERROR_NONE;
    std::string message;
};

void recordEmbreeError(void* userPtr, RTCError code, const char* message) {
    auto& errors = *static_cast<EmbreeErrors*>(userPtr);
    const std::lock_guard lock(errors.mutex);
    if (errors.code != RTC_ERROR_NONE) return;
    errors.code = code;
    errors.message = std::string(embreeErrorName(code)) + (message ? std::string(": ") + message : "");
}

// A refused argument is the scene's fault; anything else (memory, processor) the machine's.
void throwIfFailed(EmbreeErrors& errors, const char* what) {
    const std::lock_guard lock(errors.mutex);
    if (errors.code == RTC_ERROR_NONE) return;
    const ErrorKind kind = errors.code == RTC_ERROR_INVALID_ARGUMENT ? ErrorKind::Input : ErrorKind::Device;
    throw Error(kind, std::string("Embree failed ") + what + ": " + errors.message);
}

RTCRay embreeRay(const Ray& ray) {
    RTCRay embree{};
    embree.org_x = ray.origin.x;
    embree.org_y = ray.origin.y;
    embree.org_z = ray.origin.z;
    embree.dir_x = ray.direction.x;
    embree.dir_y = ray.direction.y;
    embree.dir_z = ray.direction.z;
    embree.tnear = ray.tMin;
    embree.tfar = ray.tMax;
    embree.mask = ~0u;
    return embree;
}

struct ReleaseDevice {
    void operator()(RTCDevice device) const { rtcReleaseDevice(device); }
};
struct ReleaseScene {
    void operator()(RTCScene scene) const { rtcReleaseScene(scene); }
};

class EmbreeRayCaster final : public RayCaster {
  public:
    EmbreeRayCaster(const World& world, std::span<const uint32_t> triangles)
        : triangles_(triangles.begin(), triangles.end()) {
        for (uint32_t t : triangles_)
            if (t >= world.triangleCount())
                throw Error(ErrorKind::Input, "Embree: triangle " + std::to_string(t) + " past the World's " +
                                                  std::to_string(world.triangleCount()) + " triangles");
        device_.reset(rtcNewDevice(nullptr));
        if (!device_)
            throw Error(ErrorKind::Device, std::string("Embree could not start: ") +
                                               embreeErrorName(rtcGetDeviceError(nullptr)));
        rtcSetDeviceErrorFunction(device_.get(), recordEmbreeError, &errors_);
        // Validity and relocation count the back faces rays meet: an Embree built to cull them
        // would find every probe outside geometry.
        if (rtcGetDeviceProperty(device_.get(), RTC_DEVICE_PROPERTY_BACKFACE_CULLING_ENABLED) != 0)
            throw Error(ErrorKind::Device, "Embree was built with back-face culling, which hides the back "
                                           "faces shprobe counts; use a build without it");
        scene_.reset(rtcNewScene(device_.get()));
        throwIfFailed(errors_, "creating the scene");
        // Robust mode: watertight edges, so that no ray slips between two triangles sharing an edge.
        rtcSetSceneFlags(scene_.get(), RTC_SCENE_FLAG_ROBUST);
        if (!triangles_.empty()) attachTriangles(world);
        rtcCommitScene(scene_.get());
        throwIfFailed(errors_, "building the scene");
    }

    std::optional<RayHit> closestHit(const Ray& ray) const override {
        RTCRayHit query{};
        query.ray = embreeRay(ray);
        query.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        query.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
        RTCIntersectContext context;
        rtcInitIntersectContext(&context);
        rtcIntersect1(scene_.get(), &context, &query);
        if (query.hit.geomID == RTC_INVALID_GEOMETRY_ID) return std::nullopt;
        // Embree's Ng is the winding normal (p1 - p0) x (p2 - p0), unnormalized.
        const float facing = ray.direction.x * query.hit.Ng_x + ray.direction.y * query.hit.Ng_y +
                             ray.direction.z * query.hit.Ng_z;
        return RayHit{triangles_[query.hit.primID],
                      {query.ray.tfar, query.hit.u, query.hit.v, facing < 0.0f}};
    }

    bool anyHit(const Ray& ray) const override {
        RTCRay query = embreeRay(ray);
        RTCIntersectContext context;
        rtcInitIntersectContext(&context);
        rtcOccluded1(scene_.get(), &context, &query);
        return query.tfar < 0.0f; // Embree marks an occluded ray with tfar = -inf
    }

  private:
    // Embree's own buffers (padded as its vector loads need), filled with the triangles.
    void attachTriangles(const World& world) {
        RTCGeometry geometry = rtcNewGeometry(device_.get(), RTC_GEOMETRY_TYPE_TRIANGLE);
        throwIfFailed(errors_, "creating the triangle geometry");
        auto* vertices = static_cast<glm::vec3*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0,
                                                                         RTC_FORMAT_FLOAT3, sizeof(glm::vec3),
                                                                         world.positions.size()));
        auto* indices = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(
            geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(uint32_t), triangles_.size()));
        if (vertices && indices) {
            std::copy(world.positions.begin(), world.positions.end(), vertices);
            for (size_t k = 0; k < triangles_.size(); ++k)
                std::copy_n(&world.indices[3 * size_t(triangles_[k])], 3, &indices[3 * k]);
            rtcCommitGeometry(geometry);
            rtcAttachGeometry(scene_.get(), geometry);
        }
        rtcReleaseGeometry(geometry); // the scene holds it now
        throwIfFailed(errors_, "storing the triangles");
    }

    std::vector<uint32_t> triangles_; // Embree's primitive k is the World's triangle triangles_[k]
    EmbreeErrors errors_;             // outlives the device, whose callback writes it
    std::unique_ptr<RTCDeviceTy, ReleaseDevice> device_;
    std::unique_ptr<RTCSceneTy, ReleaseScene> scene_; // released before its device
};

} // namespace

std::unique_ptr<RayCaster> makeEmbreeRayCaster(const World& world, std::span<const uint32_t> triangles) {
    return std::make_unique<EmbreeRayCaster>(world, triangles);
}

} // namespace shprobe

extern "C" __attribute__((visibility("default"))) const shprobe::EmbreePlugin* shprobe_embree_plugin_v1() {
    static const shprobe::EmbreePlugin plugin{shprobe::makeEmbreeRayCaster};
    return &plugin;
}
