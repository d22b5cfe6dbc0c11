// Offscreen rendering: no window, no surface extension. A scene is drawn into float targets and
// tonemapped into an 8-bit sRGB image on the device; all three are read back.
#pragma once
#include "render/scene_renderer.h"
#include "render/tonemap.h"
#include "sh/cubemap.h"

#include <cstdint>
#include <string>
#include <vector>

namespace shprobe {

constexpr VkFormat kDisplayFormat = VK_FORMAT_R8G8B8A8_SRGB;

struct OffscreenRenderer {
    SceneRenderer scene;
    Tonemapper tonemapper; // into kDisplayFormat, left ready for readback
};

// Throws Error(Input) naming `asked` (the option that sized them) where the device cannot create
// render targets of `extent`: RGBA32F, the largest texels of every render path, past the format's
// maxExtent or past its maxResourceSize (16 bytes a texel, as the validation layer counts them).
// Before any image is made: past those, vkCreateImage's result is undefined.
void requireRenderTargetExtent(const Device& device, VkExtent2D extent, const std::string& asked);

OffscreenRenderer createOffscreenRenderer(const Context& context);
void destroyOffscreenRenderer(const Device& device, OffscreenRenderer& renderer);

struct RenderedImage {
    Image linear;                 // RGBA32F linear radiance, unclamped (EXR output)
    Image directions;             // the direction target (render_interface.h): xyz and what w says
    std::vector<uint8_t> display; // RGBA8, tonemapped and sRGB-encoded (PNG output), rows top down
};

// Renders `scene` at `extent` pixels; `exposure` scales the linear colour before the display curve.
RenderedImage renderOffscreen(const Context& context, OffscreenRenderer& renderer, const Scene& scene,
                              VkExtent2D extent, float exposure);

} // namespace shprobe
