// A scene written by `shprobe transfer` read back for drawing: its world (placed as the scene
// reader places it) and each world vertex's transfer attributes, as docs/transfer.md lays them out
// (_SH_TRANSFER_0 .. _SH_TRANSFER_{k-1}, VEC4 floats; asset.extras.shTransfer gives order and
// channels).
#pragma once
#include "scene/scene.h"

#include <string>
#include <vector>

namespace shprobe {

struct TransferMesh {
    World world;
    int order = 0;
    int channels = 0;   // 3 (RGB) or 1 (grey)
    int attributes = 0; // ceil(order^2 channels / 4)
    // World vertex v's attributes: floats [v * attributes * 4, (v + 1) * attributes * 4), packed as
    // the file packs them (coefficient i's channel c at i * channels + c, zeros after the last).
    std::vector<float> transfer;
};

// Throws Error(Input), one line naming the file, for what loadGltfScene refuses, a scene without
// asset.extras.shTransfer, a header whose format, version, convention, order, channels or
// attribute names are not those the writer writes, a primitive with other attributes than the
// header makes, attributes that are not VEC4 float accessors of POSITION's count, and a
// coefficient that is not finite or a padding float that is not zero.
TransferMesh loadTransferMesh(const std::string& path);

} // namespace shprobe
