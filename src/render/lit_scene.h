// A glTF scene lit by its baked probe volume, as `shprobe render --scene` and `shprobe view --scene`
// draw it: the view pass of its capture (render/scene_view.h) with the volume as its bounce source, an
// orbit camera around the scene's box, and an exposure from the volume. Both commands share these,
// so a viewer screenshot is the offscreen render of the same view, byte for byte.
#pragma once
#include "formats/probe_volume.h"
#include "render/scene_view.h"
#include "scene/scene.h"
#include "sh/cubemap.h"

namespace shprobe {

struct LitScene {
    World world;
    Cubemap sky;
    ProbeVolume volume; // a whole volume baked in `world` (not a brick), with irradiance
};

// The capture of the scene with the volume's irradiance as what its surfaces reflect.
SceneCapture createLitSceneCapture(const Context& context, const LitScene& scene);

// The orbit camera around the scene's box: yaw and pitch as `render --yaw --pitch` (degrees), at
// `zoom` times the distance that keeps the whole box in view.
SceneCamera orbitSceneCamera(const World& world, float yawDegrees, float pitchDegrees, float zoom = 1.0f);

// The exposure that puts the volume's mean radiance (its valid probes' L00 / sqrt(4 pi)) at mid grey.
float volumeExposure(const ProbeVolume& volume);

// Records the view (recordSceneView) and leaves target.color in SHADER_READ_ONLY_OPTIMAL for the
// tonemap pass.
void recordLitSceneView(VkCommandBuffer commands, const SceneCapture& capture, const SceneViewTarget& target,
                        const SceneCamera& camera, const SceneViewOptions& options);

} // namespace shprobe
