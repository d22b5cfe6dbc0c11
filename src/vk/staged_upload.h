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

// Rows are numbered through the layers: row r is row r % height of layer r / height.
struct StagedRows {
    Buffer ring;
    VkDeviceSize slotBytes = 0;
    std::vector<VkCommandBuffer> commands; // one per slot that was submitted
    std::vector<VkFence> fences;           // signalled when that slot's copy is done
    std::vector<VkBufferImageCopy> tail;   // the last slot's copy, for recordStagedRows
    bool copiedAhead = false;              // slots before the last were submitted (the image is in
                                           // TRANSFER_DST_OPTIMAL already)
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
