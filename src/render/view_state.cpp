#include "render/view_state.h"

#include <algorithm>
#include <cstdio>
#include <glm/ext/matrix_transform.hpp>

namespace shprobe {

glm::dmat3 environmentRotation(float degrees) {
    return glm::dmat3(glm::rotate(glm::dmat4(1.0), glm::radians(double(degrees)), glm::dvec3(0.0, 1.0, 0.0)));
}

Scene viewScene(const ViewState& view) {
    Camera camera = orbitCamera(view.yawDegrees, view.pitchDegrees, view.distance, view.verticalFovDegrees);
    Scene scene = viewerScene(camera, view.order, view.shading, view.background);
    scene.backgroundColor = glm::vec3(0.05f);
    return scene;
}

void clampView(ViewState& view) {
    view.pitchDegrees = std::clamp(view.pitchDegrees, -85.0f, 85.0f);
    view.distance = std::clamp(view.distance, 1.8f, 20.0f);
}

std::string viewSummary(const ViewState& view, const std::string& input, double bakeMilliseconds,
                        const std::string& device) {
    char text[512];
    std::snprintf(text, sizeof(text),
                  "shprobe view: %s | order %d | %s | background %s | env %+.0f deg | %+.1f EV",
                  input.c_str(), view.order, shadingModeName(view.shading), backgroundName(view.background),
                  double(view.environmentRotationDegrees), double(view.exposureStops));
    std::string summary = text;
    if (bakeMilliseconds > 0.0) {
        std::snprintf(text, sizeof(text), " | bake %.1f ms", bakeMilliseconds);
        summary += text;
    }
    return summary + " | " + device;
}

} // namespace shprobe
