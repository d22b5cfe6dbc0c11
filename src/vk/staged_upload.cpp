#include "vk/staged_upload.h"

#include "common/scope_exit.h"
#include "vk/check.h"
#include "vk/vulkan_commands.h"

#include <algorithm>

namespace shprobe {

namespace {

// The copy of `count` rows from `first` on (numbered through the layers) out of the buffer at
// `offset`: a partial layer, whole layers, a partial layer; at most three regions.
std::vector<VkBufferImageCopy> rowRegions(uint64_t first, uint64_t count, const GpuImage& image,
                                          VkDeviceSize rowBytes, VkDeviceSize offset) {
    const uint64_t height = image.extent.height;
    std::vector<VkBufferImageCopy> regions;
    while (count > 0) {
        const uint32_t layer = uint32_t(first / height);
        const uint32_t y = uint32_t(first % height);
        const bool wholeLayers = y == 0 && count >= height;
        const uint32_t layers = wholeLayers ? uint32_t(count / height) : 1;
        const uint32_t rows =
            wholeLayers ? uint32_t(height) : uint32_t(std::min<uint64_t>(count, height - y));
        VkBufferImageCopy region{};
        region.bufferOffset = offset;
        region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, layer, layers};
        region.imageOffset = {0, int32_t(y), 0};
        region.imageExtent = {image.extent.width, rows, 1};
        regions.push_back(region);
        const uint64_t copied = uint64_t(layers) * rows;
        first += copied;
        count -= copied;
        offset += copied * rowBytes;
    }
    return regions;
}

} // namespace

StagedRows stageImageRows(const Context& context, const GpuImage& image, VkDeviceSize rowBytes,
                          const FillRows& fill, const StagingOptions& options) {
    const uint64_t totalRows = uint64_t(image.extent.height) * image.layers;
    const uint64_t rowsPerSlot =
        std::min<uint64_t>(totalRows, std::max<VkDeviceSize>(1, options.slotBytes / rowBytes));
    const uint64_t chunks = (totalRows + rowsPerSlot - 1) / rowsPerSlot;
    const uint32_t slots = uint32_t(std::clamp<uint64_t>(options.slots, 1, chunks));

    StagedRows staged;
    OnFailure undo([&] { destroyStagedRows(context, staged); });
    staged.slotBytes = rowsPerSlot * rowBytes;
    staged.ring = createBuffer(context, staged.slotBytes * slots, VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                               MemoryUse::Upload, "staging for the texels");
    for (uint64_t chunk = 0; chunk < chunks; ++chunk) {
        const uint32_t index = uint32_t(chunk % slots);
        if (index < staged.submitted.size()) { // the slot's earlier copy must be done before it is refilled
            StagingSlot& slot = staged.submitted[index];
            VK_CHECK(vkWaitForFences(context.device, 1, &slot.fence, VK_TRUE, UINT64_MAX));
            slot.pending = false;
        }
        const uint64_t first = chunk * rowsPerSlot;
        const uint32_t rows = uint32_t(std::min(rowsPerSlot, totalRows - first));
        const VkDeviceSize offset = index * staged.slotBytes;
        fill(first, rows, static_cast<char*>(staged.ring.mapped) + offset);
        std::vector<VkBufferImageCopy> regions = rowRegions(first, rows, image, rowBytes, offset);
        if (chunk + 1 == chunks) {
            staged.tail = std::move(regions);
            break;
        }
        if (index == staged.submitted.size())
            staged.submitted.push_back({allocateCommandBuffer(context), createFence(context)});
        StagingSlot& slot = staged.submitted[index];
        VK_CHECK(vkResetFences(context.device, 1, &slot.fence));
        beginCommands(slot.commands);
        if (chunk == 0) beginImageCopies(slot.commands, image);
        vkCmdCopyBufferToImage(slot.commands, staged.ring.buffer, image.image,
                               VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, uint32_t(regions.size()),
                               regions.data());
        VK_CHECK(vkEndCommandBuffer(slot.commands));
        submitCommands(context, slot.commands, slot.fence);
        slot.pending = true;
        ++staged.submissions;
    }
    return staged;
}

void recordStagedRows(VkCommandBuffer commands, const StagedRows& staged, const GpuImage& image,
                      VkImageLayout layout, VkPipelineStageFlags readStage) {
    // Copies submitted earlier come first in submission order: the barriers below order them too.
    if (staged.submissions == 0) beginImageCopies(commands, image);
    vkCmdCopyBufferToImage(commands, staged.ring.buffer, image.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                           uint32_t(staged.tail.size()), staged.tail.data());
    endImageCopies(commands, image, layout, readStage);
}

void destroyStagedRows(const Context& context, StagedRows& staged) {
    for (const StagingSlot& slot : staged.submitted) {
        if (slot.pending) vkWaitForFences(context.device, 1, &slot.fence, VK_TRUE, UINT64_MAX);
        vkDestroyFence(context.device, slot.fence, nullptr);
        vkFreeCommandBuffers(context.device, context.commandPool, 1, &slot.commands);
    }
    destroyBuffer(context, staged.ring);
    staged = StagedRows{};
}

} // namespace shprobe
