// What the viewer shows, as plain data: the orbit camera, SH order, shading mode, background,
// environment rotation and exposure. Kept out of the viewer so the offscreen renderer can draw
// exactly the view a viewer screenshot shows (tests compare the two).
#pragma once
#include "render/scene.h"

#include <glm/mat3x3.hpp>
#include <string>

namespace shprobe {

struct ViewState {
    float yawDegrees = 35.0f; // orbit camera around the origin
    float pitchDegrees = 15.0f;
    float distance = 4.6f;
    float verticalFovDegrees = 40.0f;
    int order = 3;
    ShadingMode shading = ShadingMode::Irradiance;
    Background background = Background::Environment;
    float environmentRotationDegrees = 0.0f; // about +Y, applied by re-projecting the environment
    float exposureStops = 0.0f;              // relative to autoExposure
};

// The rotation of the environment by `degrees` about +Y (a light from d comes from R d).
glm::dmat3 environmentRotation(float degrees);

// The viewer's scene (a sphere and a torus) for a view.
Scene viewScene(const ViewState& view);

// Keeps the camera off the poles and at a sane distance.
void clampView(ViewState& view);

// One line for the window title: input, order, mode, background, rotation, bake time, device.
std::string viewSummary(const ViewState& view, const std::string& input, double bakeMilliseconds,
                        const std::string& device);

} // namespace shprobe
