// `shprobe view`: a GLFW window showing the environment, a lit sphere and a torus, with an orbit
// camera (drag with the left mouse button, scroll to zoom) and keys:
//   3, 5      SH order                 M   next shading mode (radiance, irradiance, l1-nonlinear)
//   B         next background          Left/Right  rotate the environment by 15 degrees (re-baked)
//   +, -      exposure by half a stop  R   reset the view        Esc, Q  quit
// or, instead, a glTF scene lit by its probe volume (the view of `shprobe render --scene`), with
// the same camera, exposure, reset and quit keys and
//   P         show or hide the probes (spheres shaded by their own SH)
// or a scene written by `shprobe transfer` relit by a sky or probe (the view of `shprobe render
// --scene --transfer`), the light turned on the device every frame, with
//   Left/Right, J/L  turn the light about +Y by 15 degrees     Up/Down, I/K  about +X
// The title shows the settings and the last bake time. The only file that includes GLFW is
// viewer.cpp; the library's core never links it.
#pragma once
#include "render/lit_scene.h"
#include "render/relit_scene.h"
#include "render/render_input.h"
#include "render/view_state.h"

#include <optional>
#include <string>
#include <vector>

namespace shprobe {

struct ViewerOptions {
    std::string input; // probe (.json), environment image, or empty: the built-in sky
    // The probe when the caller has read it already (standard input can be read only once);
    // otherwise input is loaded.
    std::optional<RenderInput> probe;
    RenderInputOptions inputOptions;
    std::optional<LitScene> scene; // shown instead of the probe's sphere and torus
    bool showProbes = false;       // the scene's probes, initially
    // Or a scene with per-vertex transfer and its light, turned initially by lightYaw, lightPitch.
    std::optional<TransferMesh> relitMesh;
    std::optional<RelitLight> relitLight;
    float lightYaw = 0.0f;
    float lightPitch = 0.0f;
    uint32_t width = 960; // window size (screen coordinates)
    uint32_t height = 600;
    ViewState view;         // the initial view (order, mode, exposure...)
    std::string screenshot; // save the last frame (--frames) to this PNG
    int frames = 0;         // > 0: exit after this many frames
    // Key presses to replay, one before each of the first frames (scripts and tests), as GLFW key
    // codes (scriptedKeys).
    std::vector<int> keys;
    std::string device;
    bool validation = false;
};

// The GLFW key codes of key names as in the key list above, lower case ("3", "5", "m", "b", "left",
// "right", "up", "down", "j", "l", "i", "k", "+", "-", "r", "q", "p"); throws Error(Input) for an unknown
// name.
std::vector<int> scriptedKeys(const std::vector<std::string>& names);

// What runViewer refuses before it opens a window: --screenshot without --frames, a screenshot that
// cannot be written. Error(Input) or Error(Output).
void checkViewerOptions(const ViewerOptions& options);

// Runs until the window is closed or `frames` frames were shown, once checkViewerOptions accepts
// the options. Without a display, throws Error(Device) saying so and pointing at `shprobe render`.
void runViewer(const ViewerOptions& options);

} // namespace shprobe
