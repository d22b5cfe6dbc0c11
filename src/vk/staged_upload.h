// The rows of a layered image uploaded from the host through a small ring of staging slots: the
// host fills one slot while the device copies the one before, so a large image needs neither
// staging memory of its own size (pinned memory on a discrete GPU, slow to allocate and to fault
// in) nor a wait between filling and copying. The last slot's copy is left to the caller's command
// buffer (recordStagedRows), so an image that fits one slot costs no submission of its own.
// Plain handles; stageImageRows / destroyStagedRows.
#pragma once
#include "vk/image.h"
#include "vk/resources.h"

#include <cstdint>
#include <functional>
#include <vector>

namespace shprobe {

struct StagingOptions {
    VkDeviceSize slotBytes = VkDeviceSize(32) << 20; // whole rows are copied; at least one row a slot
    uint32_t slots = 3;
};

// A slot whose copy was submitted: its commands, and the fence signalled when the copy is done.
struct StagingSlot {
    VkCommandBuffer commands = VK_NULL_HANDLE;
    VkFence fence = VK_NULL_HANDLE;
    bool pending = false; // submitted and not yet waited for: only then may the fence be waited on
};

// Rows are numbered through the layers: row r is row r % height of layer r / height.
struct StagedRows {
    Buffer ring;
    VkDeviceSize slotBytes = 0;
    std::vector<StagingSlot> submitted;  // the slots copied ahead (none when the image fits one slot)
    uint64_t submissions = 0;            // copies submitted ahead, one per slot filled but the last
    std::vector<VkBufferImageCopy> tail; // the last slot's copy, for recordStagedRows
};

// Writes `rows` rows, from `firstRow` on, tightly packed (rowBytes each) to `destination`.
using FillRows = std::function<void(uint64_t firstRow, uint32_t rows, void* destination)>;

// Streams every row of `image` (all layers; rowBytes = width x texel bytes) through the ring,
// submitting each full slot but the last on the context's queue. The image must be in
// VK_IMAGE_LAYOUT_UNDEFINED and have VK_IMAGE_USAGE_TRANSFER_DST_BIT. `fill` may throw: the slots
// in flight are waited for and everything made is destroyed.
StagedRows stageImageRows(const Context& context, const GpuImage& image, VkDeviceSize rowBytes,
                          const FillRows& fill, const StagingOptions& options = {});

// Records the last slot's copy and leaves the image in `layout`, its texels visible to shader reads
// at `readStage`. Submit it before destroyStagedRows.
void recordStagedRows(VkCommandBuffer commands, const StagedRows& staged, const GpuImage& image,
                      VkImageLayout layout, VkPipelineStageFlags readStage);

// Waits for the slots still being copied, then frees the ring.
void destroyStagedRows(const Context& context, StagedRows& staged);

} // namespace shprobe
