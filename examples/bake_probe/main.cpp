// bake_probe: bakes an SH light probe with shprobe's installed SPIR-V modules and plain Vulkan.
//
// Everything here comes from the installed package: share/shprobe/spirv/INTERFACE.md gives the
// bindings, barriers, the dispatch rules of project.comp, reduce.comp and convolve.comp, and the
// output layout; the headers shared by shprobe's C++ and its shaders, from the GLSL folder
// (find_package(shprobe): shprobe_GLSL_DIR), give the push-constant structs, the specialization
// constant ids (gpu_interface.h) and the dispatch plan (dispatch_plan.h). No shprobe library is
// linked.
//
//   bake_probe [--environment white|sky] [--face-size N] [--order N] [--write-faces DIR]
//              [--spirv-dir DIR] [--validation]
//
// The environment is generated: `white` is radiance 1 everywhere (the white furnace: L_00 =
// sqrt(4 pi), every other coefficient 0), `sky` a smooth gradient with a soft sun. It is uploaded
// into a 2D-array image of six RGBA32F layers, which project.comp samples. --write-faces writes the
// same texels as DIR/px.pfm ... DIR/nz.pfm, which `shprobe bake 'DIR/{face}.pfm'` reads.
#include "dispatch_plan.h"
#include "gpu_interface.h"

#include <vulkan/vulkan.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <initializer_list>
#include <string>
#include <vector>

#define VK_CHECK(call)                                                                                       \
    do {                                                                                                     \
        VkResult result_ = (call);                                                                           \
        if (result_ != VK_SUCCESS)                                                                           \
            fail(std::string(#call) + " failed with VkResult " + std::to_string(result_));                   \
    } while (0)

namespace {

[[noreturn]] void fail(const std::string& message) {
    std::fprintf(stderr, "bake_probe: error: %s\n", message.c_str());
    std::exit(1);
}

// --- the interface: INTERFACE.md and the shared headers ------------------------------------------

namespace glsl = shprobe::glsl; // the shared headers' C++ namespace

constexpr uint32_t kWidth = glsl::kDefaultWorkgroupWidth; // workgroup width of all three modules here
constexpr uint32_t kFaces = 6;  // layers per probe: probe p's face f is layer 6p + f
constexpr uint32_t kProbes = 1; // probes per bake; the modules take many, this example one
constexpr VkFormat kTexelFormat = VK_FORMAT_R32G32B32A32_SFLOAT;

struct Coefficient { // every coefficient buffer, and the texels: vec4, rgb + unused w
    float r, g, b, unused;
};
static_assert(sizeof(Coefficient) == 16);

// A_l, the clamped-cosine convolution factor of band l.
double irradianceFactor(int l) {
    const double pi = 3.14159265358979323846;
    if (l == 0) return pi;
    if (l == 1) return 2.0 * pi / 3.0;
    if (l % 2 == 1) return 0.0;
    double binomial = 1.0; // C(l, l/2) / 2^l
    for (int k = 1; k <= l / 2; ++k)
        binomial *= (2.0 * k - 1.0) / (2.0 * k);
    double sign = (l / 2) % 2 == 1 ? 1.0 : -1.0;
    return 2.0 * pi * sign / ((l + 2.0) * (l - 1.0)) * binomial;
}

// --- the environment -----------------------------------------------------------------------------

struct Options {
    std::string environment = "sky";
    uint32_t faceSize = 32;
    uint32_t order = 3;
    std::string writeFaces;
    std::string spirvDir = SHPROBE_SPIRV_DIR;
    bool validation = false;
};

struct Vec3 {
    float x, y, z;
};

// The direction through texel (i, j) of a face, Vulkan's cube-map convention (INTERFACE.md).
Vec3 texelDirection(int face, uint32_t i, uint32_t j, uint32_t n) {
    float a = 2.0f * (float(i) + 0.5f) / float(n) - 1.0f;
    float b = 2.0f * (float(j) + 0.5f) / float(n) - 1.0f;
    const Vec3 directions[6] = {{1, -b, -a}, {-1, -b, a}, {a, 1, b}, {a, -1, -b}, {a, -b, 1}, {-a, -b, -1}};
    Vec3 d = directions[face];
    float length = std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
    return {d.x / length, d.y / length, d.z / length};
}

Coefficient radianceAt(const std::string& environment, Vec3 d) {
    if (environment == "white") return {1.0f, 1.0f, 1.0f, 0.0f};
    float sun = std::max(0.0f, 0.48f * d.x + 0.6f * d.y + 0.64f * d.z);
    float glow = std::pow(sun, 16.0f);
    return {1.5f + 0.8f * d.y + 0.5f * d.x * d.z + 4.0f * glow, 1.0f + 0.6f * d.y + 0.3f * d.x + 3.0f * glow,
            1.2f + 0.9f * d.y - 0.2f * d.z * d.z + 2.0f * glow, 1.0f};
}

// RGBA32F, face after face, rows top to bottom: what vkCmdCopyBufferToImage puts into layers 0..5.
std::vector<Coefficient> makeCubemap(const Options& options) {
    uint32_t n = options.faceSize;
    std::vector<Coefficient> texels;
    texels.reserve(size_t(kFaces) * n * n);
    for (int face = 0; face < int(kFaces); ++face)
        for (uint32_t j = 0; j < n; ++j)
            for (uint32_t i = 0; i < n; ++i)
                texels.push_back(radianceAt(options.environment, texelDirection(face, i, j, n)));
    return texels;
}

// PFM (little-endian RGB float), whose rows go bottom to top.
void writeFaces(const std::vector<Coefficient>& texels, uint32_t n, const std::string& folder) {
    const char* names[6] = {"px", "nx", "py", "ny", "pz", "nz"};
    for (int face = 0; face < int(kFaces); ++face) {
        std::string path = folder + "/" + names[face] + ".pfm";
        std::ofstream file(path, std::ios::binary);
        file << "PF\n" << n << " " << n << "\n-1.0\n";
        for (uint32_t row = n; row-- > 0;)
            for (uint32_t i = 0; i < n; ++i) {
                const Coefficient& t = texels[(size_t(face) * n + row) * n + i];
                float rgb[3] = {t.r, t.g, t.b};
                file.write(reinterpret_cast<const char*>(rgb), sizeof(rgb));
            }
        if (!file) fail("cannot write " + path);
    }
}

// --- Vulkan: instance, device ---------------------------------------------------------------------

struct Gpu {
    VkInstance instance = VK_NULL_HANDLE;
    VkDebugUtilsMessengerEXT messenger = VK_NULL_HANDLE;
    VkPhysicalDevice physical = VK_NULL_HANDLE;
    VkDevice device = VK_NULL_HANDLE;
    VkQueue queue = VK_NULL_HANDLE;
    uint32_t queueFamily = 0;
    VkPhysicalDeviceLimits limits{};
};

int gValidationMessages = 0;

VKAPI_ATTR VkBool32 VKAPI_CALL onValidation(VkDebugUtilsMessageSeverityFlagBitsEXT,
                                            VkDebugUtilsMessageTypeFlagsEXT,
                                            const VkDebugUtilsMessengerCallbackDataEXT* data, void*) {
    std::fprintf(stderr, "validation: %s\n", data->pMessage);
    ++gValidationMessages;
    return VK_FALSE;
}

void createInstance(Gpu& gpu, bool validation) {
    VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
    app.pApplicationName = "bake_probe";
    app.apiVersion = VK_API_VERSION_1_1; // SPIR-V 1.3
    const char* layer = "VK_LAYER_KHRONOS_validation";
    const char* extension = VK_EXT_DEBUG_UTILS_EXTENSION_NAME;
    VkInstanceCreateInfo info{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
    info.pApplicationInfo = &app;
    if (validation) {
        info.enabledLayerCount = 1;
        info.ppEnabledLayerNames = &layer;
        info.enabledExtensionCount = 1;
        info.ppEnabledExtensionNames = &extension;
    }
    VK_CHECK(vkCreateInstance(&info, nullptr, &gpu.instance));
    if (!validation) return;
    VkDebugUtilsMessengerCreateInfoEXT messenger{VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT};
    messenger.messageSeverity =
        VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
    messenger.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT;
    messenger.pfnUserCallback = onValidation;
    auto create = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(gpu.instance, "vkCreateDebugUtilsMessengerEXT"));
    VK_CHECK(create(gpu.instance, &messenger, nullptr, &gpu.messenger));
}

// project.comp needs Vulkan 1.1, subgroup basic + arithmetic operations in compute shaders, and
// the texel format sampled from optimal-tiling images.
bool suitable(VkPhysicalDevice physical, uint32_t& queueFamily) {
    VkPhysicalDeviceSubgroupProperties subgroup{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES};
    VkPhysicalDeviceProperties2 properties{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
    properties.pNext = &subgroup;
    vkGetPhysicalDeviceProperties2(physical, &properties);
    VkSubgroupFeatureFlags needed = VK_SUBGROUP_FEATURE_BASIC_BIT | VK_SUBGROUP_FEATURE_ARITHMETIC_BIT;
    if (properties.properties.apiVersion < VK_API_VERSION_1_1 ||
        !(subgroup.supportedStages & VK_SHADER_STAGE_COMPUTE_BIT) ||
        (subgroup.supportedOperations & needed) != needed)
        return false;
    VkFormatProperties format;
    vkGetPhysicalDeviceFormatProperties(physical, kTexelFormat, &format);
    if (!(format.optimalTilingFeatures & VK_FORMAT_FEATURE_SAMPLED_IMAGE_BIT)) return false;
    uint32_t count = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(physical, &count, nullptr);
    std::vector<VkQueueFamilyProperties> families(count);
    vkGetPhysicalDeviceQueueFamilyProperties(physical, &count, families.data());
    for (uint32_t i = 0; i < count; ++i)
        if (families[i].queueFlags & VK_QUEUE_COMPUTE_BIT) { // compute queues also take transfers
            queueFamily = i;
            return true;
        }
    return false;
}

// The first suitable device (set VK_ICD_FILENAMES to choose a driver, e.g. lavapipe).
void createDevice(Gpu& gpu) {
    uint32_t count = 0;
    VK_CHECK(vkEnumeratePhysicalDevices(gpu.instance, &count, nullptr));
    std::vector<VkPhysicalDevice> devices(count);
    VK_CHECK(vkEnumeratePhysicalDevices(gpu.instance, &count, devices.data()));
    for (VkPhysicalDevice physical : devices)
        if (suitable(physical, gpu.queueFamily)) {
            gpu.physical = physical;
            break;
        }
    if (!gpu.physical)
        fail("no Vulkan 1.1 device with subgroup arithmetic in compute shaders and sampled RGBA32F");
    VkPhysicalDeviceProperties properties;
    vkGetPhysicalDeviceProperties(gpu.physical, &properties);
    gpu.limits = properties.limits;
    std::printf("device: %s\n", properties.deviceName);

    float priority = 1.0f;
    VkDeviceQueueCreateInfo queue{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
    queue.queueFamilyIndex = gpu.queueFamily;
    queue.queueCount = 1;
    queue.pQueuePriorities = &priority;
    VkDeviceCreateInfo info{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
    info.queueCreateInfoCount = 1;
    info.pQueueCreateInfos = &queue;
    VK_CHECK(vkCreateDevice(gpu.physical, &info, nullptr, &gpu.device));
    vkGetDeviceQueue(gpu.device, gpu.queueFamily, 0, &gpu.queue);
}

// --- memory: buffers and the cube-map image -------------------------------------------------------

// The first allowed memory type with all flags of the first preference any type meets.
uint32_t memoryType(const Gpu& gpu, uint32_t allowed,
                    std::initializer_list<VkMemoryPropertyFlags> preferences) {
    VkPhysicalDeviceMemoryProperties memory;
    vkGetPhysicalDeviceMemoryProperties(gpu.physical, &memory);
    for (VkMemoryPropertyFlags wanted : preferences)
        for (uint32_t i = 0; i < memory.memoryTypeCount; ++i)
            if ((allowed & (1u << i)) && (memory.memoryTypes[i].propertyFlags & wanted) == wanted) return i;
    fail("no suitable memory type");
}

// Host-visible, coherent buffers: simple, and fine for a probe's texels and few kilobytes of sums.
struct Buffer {
    VkBuffer buffer = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkDeviceSize size = 0;
    void* mapped = nullptr;
};

VkDeviceMemory allocate(const Gpu& gpu, const VkMemoryRequirements& requirements, uint32_t type) {
    const VkMemoryAllocateInfo info{.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO,
                                    .allocationSize = requirements.size,
                                    .memoryTypeIndex = type};
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VK_CHECK(vkAllocateMemory(gpu.device, &info, nullptr, &memory));
    return memory;
}

Buffer createBuffer(const Gpu& gpu, VkDeviceSize size, VkBufferUsageFlags usage) {
    Buffer buffer;
    buffer.size = size;
    VkBufferCreateInfo info{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
    info.size = size;
    info.usage = usage;
    VK_CHECK(vkCreateBuffer(gpu.device, &info, nullptr, &buffer.buffer));
    VkMemoryRequirements requirements;
    vkGetBufferMemoryRequirements(gpu.device, buffer.buffer, &requirements);
    const VkMemoryPropertyFlags hostVisible =
        VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
    buffer.memory = allocate(gpu, requirements, memoryType(gpu, requirements.memoryTypeBits, {hostVisible}));
    VK_CHECK(vkBindBufferMemory(gpu.device, buffer.buffer, buffer.memory, 0));
    VK_CHECK(vkMapMemory(gpu.device, buffer.memory, 0, VK_WHOLE_SIZE, 0, &buffer.mapped));
    std::memset(buffer.mapped, 0, size);
    return buffer;
}

void destroyBuffer(const Gpu& gpu, Buffer& buffer) {
    vkDestroyBuffer(gpu.device, buffer.buffer, nullptr);
    vkFreeMemory(gpu.device, buffer.memory, nullptr);
}

// The cube maps as project.comp reads them: N x N RGBA32F, `layers` layers, a 2D-array view.
struct Image {
    VkImage image = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkImageView view = VK_NULL_HANDLE;
    uint32_t size = 0, layers = 0;
};

Image createCubemapImage(const Gpu& gpu, uint32_t size, uint32_t layers) {
    Image image{.size = size, .layers = layers};
    VkImageCreateInfo info{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
    info.imageType = VK_IMAGE_TYPE_2D;
    info.format = kTexelFormat;
    info.extent = {size, size, 1};
    info.mipLevels = 1;
    info.arrayLayers = layers;
    info.samples = VK_SAMPLE_COUNT_1_BIT;
    info.tiling = VK_IMAGE_TILING_OPTIMAL;
    info.usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
    info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    VK_CHECK(vkCreateImage(gpu.device, &info, nullptr, &image.image));
    VkMemoryRequirements requirements;
    vkGetImageMemoryRequirements(gpu.device, image.image, &requirements);
    image.memory =
        allocate(gpu, requirements,
                 memoryType(gpu, requirements.memoryTypeBits, {VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, 0}));
    VK_CHECK(vkBindImageMemory(gpu.device, image.image, image.memory, 0));

    VkImageViewCreateInfo viewInfo{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
    viewInfo.image = image.image;
    viewInfo.viewType = VK_IMAGE_VIEW_TYPE_2D_ARRAY;
    viewInfo.format = kTexelFormat;
    viewInfo.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, layers};
    VK_CHECK(vkCreateImageView(gpu.device, &viewInfo, nullptr, &image.view));
    return image;
}

void destroyImage(const Gpu& gpu, Image& image) {
    vkDestroyImageView(gpu.device, image.view, nullptr);
    vkDestroyImage(gpu.device, image.image, nullptr);
    vkFreeMemory(gpu.device, image.memory, nullptr);
}

// project.comp reads with texelFetch, so filtering does not matter: nearest, clamped.
VkSampler createNearestSampler(const Gpu& gpu) {
    const VkSamplerCreateInfo info{.sType = VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO,
                                   .magFilter = VK_FILTER_NEAREST,
                                   .minFilter = VK_FILTER_NEAREST,
                                   .mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST,
                                   .addressModeU = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE,
                                   .addressModeV = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE,
                                   .addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE};
    VkSampler sampler = VK_NULL_HANDLE;
    VK_CHECK(vkCreateSampler(gpu.device, &info, nullptr, &sampler));
    return sampler;
}

// --- programs: one per module, as INTERFACE.md lays them out -------------------------------------

struct Program {
    VkShaderModule module = VK_NULL_HANDLE;
    VkDescriptorSetLayout setLayout = VK_NULL_HANDLE;
    VkPipelineLayout layout = VK_NULL_HANDLE;
    VkPipeline pipeline = VK_NULL_HANDLE;
    uint32_t pushConstantSize = 0;
};

// A module's file and set 0: bindings 0, 1, ... of these types. A combined image sampler gets
// `sampler` as its immutable sampler.
struct ProgramInfo {
    const char* file;
    std::vector<VkDescriptorType> bindings;
    uint32_t pushConstantSize;
    VkSampler sampler = VK_NULL_HANDLE;
};

std::vector<uint32_t> readSpirv(const std::string& path) {
    std::ifstream file(path, std::ios::binary | std::ios::ate);
    if (!file) fail("cannot read " + path);
    std::vector<uint32_t> words(size_t(file.tellg()) / 4);
    file.seekg(0);
    file.read(reinterpret_cast<char*>(words.data()), std::streamsize(words.size() * 4));
    if (!file || words.empty() || words[0] != 0x07230203u) fail(path + " is not a SPIR-V module");
    return words;
}

VkDescriptorSetLayout createSetLayout(const Gpu& gpu, const ProgramInfo& info) {
    std::vector<VkDescriptorSetLayoutBinding> bindings;
    for (VkDescriptorType type : info.bindings) {
        bool sampled = type == VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
        bindings.push_back({uint32_t(bindings.size()), type, 1, VK_SHADER_STAGE_COMPUTE_BIT,
                            sampled ? &info.sampler : nullptr});
    }
    const VkDescriptorSetLayoutCreateInfo setInfo{.sType =
                                                      VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO,
                                                  .bindingCount = uint32_t(bindings.size()),
                                                  .pBindings = bindings.data()};
    VkDescriptorSetLayout layout = VK_NULL_HANDLE;
    VK_CHECK(vkCreateDescriptorSetLayout(gpu.device, &setInfo, nullptr, &layout));
    return layout;
}

// Push constants from offset 0; specialization constants 0 (workgroup width) and 1 (SH order);
// entry point "main".
Program createProgram(const Gpu& gpu, const Options& options, const ProgramInfo& info) {
    Program program;
    program.pushConstantSize = info.pushConstantSize;
    std::vector<uint32_t> code = readSpirv(options.spirvDir + "/" + info.file);
    VkShaderModuleCreateInfo moduleInfo{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
    moduleInfo.codeSize = code.size() * 4;
    moduleInfo.pCode = code.data();
    VK_CHECK(vkCreateShaderModule(gpu.device, &moduleInfo, nullptr, &program.module));
    program.setLayout = createSetLayout(gpu, info);

    VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, info.pushConstantSize};
    VkPipelineLayoutCreateInfo layoutInfo{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
    layoutInfo.setLayoutCount = 1;
    layoutInfo.pSetLayouts = &program.setLayout;
    layoutInfo.pushConstantRangeCount = 1;
    layoutInfo.pPushConstantRanges = &range;
    VK_CHECK(vkCreatePipelineLayout(gpu.device, &layoutInfo, nullptr, &program.layout));

    const uint32_t values[2] = {kWidth, options.order};
    const VkSpecializationMapEntry entries[2] = {{SHPROBE_SPEC_LOCAL_SIZE, 0, 4}, {SHPROBE_SPEC_ORDER, 4, 4}};
    VkSpecializationInfo specialization{2, entries, sizeof(values), values};
    VkComputePipelineCreateInfo pipelineInfo{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
    pipelineInfo.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
    pipelineInfo.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    pipelineInfo.stage.module = program.module;
    pipelineInfo.stage.pName = "main";
    pipelineInfo.stage.pSpecializationInfo = &specialization;
    pipelineInfo.layout = program.layout;
    VK_CHECK(
        vkCreateComputePipelines(gpu.device, VK_NULL_HANDLE, 1, &pipelineInfo, nullptr, &program.pipeline));
    return program;
}

void destroyProgram(const Gpu& gpu, Program& program) {
    vkDestroyPipeline(gpu.device, program.pipeline, nullptr);
    vkDestroyPipelineLayout(gpu.device, program.layout, nullptr);
    vkDestroyDescriptorSetLayout(gpu.device, program.setLayout, nullptr);
    vkDestroyShaderModule(gpu.device, program.module, nullptr);
}

// What one binding of a set points at: a whole buffer, or an image view (its sampler is immutable).
struct Resource {
    const Buffer* buffer = nullptr;
    const Image* image = nullptr;
};

VkDescriptorSet createSet(const Gpu& gpu, VkDescriptorPool pool, const Program& program,
                          std::initializer_list<Resource> resources) {
    VkDescriptorSetAllocateInfo allocate{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
    allocate.descriptorPool = pool;
    allocate.descriptorSetCount = 1;
    allocate.pSetLayouts = &program.setLayout;
    VkDescriptorSet set = VK_NULL_HANDLE;
    VK_CHECK(vkAllocateDescriptorSets(gpu.device, &allocate, &set));
    std::vector<VkDescriptorBufferInfo> buffers(resources.size());
    std::vector<VkDescriptorImageInfo> images(resources.size());
    std::vector<VkWriteDescriptorSet> writes;
    for (const Resource& resource : resources) {
        uint32_t b = uint32_t(writes.size());
        VkWriteDescriptorSet write{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
        write.dstSet = set;
        write.dstBinding = b;
        write.descriptorCount = 1;
        if (resource.image) {
            images[b] = {VK_NULL_HANDLE, resource.image->view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
            write.descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
            write.pImageInfo = &images[b];
        } else {
            buffers[b] = {resource.buffer->buffer, 0, VK_WHOLE_SIZE};
            write.descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
            write.pBufferInfo = &buffers[b];
        }
        writes.push_back(write);
    }
    vkUpdateDescriptorSets(gpu.device, uint32_t(writes.size()), writes.data(), 0, nullptr);
    return set;
}

// --- commands --------------------------------------------------------------------------------------

void dispatch(VkCommandBuffer commands, const Program& program, VkDescriptorSet set, const void* constants,
              uint32_t groupsX, uint32_t groupsY) {
    vkCmdBindPipeline(commands, VK_PIPELINE_BIND_POINT_COMPUTE, program.pipeline);
    vkCmdBindDescriptorSets(commands, VK_PIPELINE_BIND_POINT_COMPUTE, program.layout, 0, 1, &set, 0, nullptr);
    vkCmdPushConstants(commands, program.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, program.pushConstantSize,
                       constants);
    vkCmdDispatch(commands, groupsX, groupsY, 1);
}

// Compute writes, made visible to `destinationAccess` at `destinationStage`.
void barrier(VkCommandBuffer commands, VkPipelineStageFlags destinationStage,
             VkAccessFlags destinationAccess) {
    VkMemoryBarrier memory{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    memory.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT;
    memory.dstAccessMask = destinationAccess;
    vkCmdPipelineBarrier(commands, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, destinationStage, 0, 1, &memory, 0,
                         nullptr, 0, nullptr);
}

struct LayoutChange {
    VkImageLayout from, to;
    VkPipelineStageFlags sourceStage;
    VkAccessFlags sourceAccess;
    VkPipelineStageFlags destinationStage;
    VkAccessFlags destinationAccess;
};

void changeLayout(VkCommandBuffer commands, const Image& image, const LayoutChange& change) {
    const VkImageMemoryBarrier barrier{
        .sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER,
        .srcAccessMask = change.sourceAccess,
        .dstAccessMask = change.destinationAccess,
        .oldLayout = change.from,
        .newLayout = change.to,
        .srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
        .dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
        .image = image.image,
        .subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, image.layers}};
    vkCmdPipelineBarrier(commands, change.sourceStage, change.destinationStage, 0, 0, nullptr, 0, nullptr, 1,
                         &barrier);
}

// The staging buffer's layers into the image, left in SHADER_READ_ONLY_OPTIMAL for compute reads.
void recordUpload(VkCommandBuffer commands, const Buffer& staging, const Image& image) {
    changeLayout(commands, image,
                 {VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                  VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, 0, VK_PIPELINE_STAGE_TRANSFER_BIT,
                  VK_ACCESS_TRANSFER_WRITE_BIT});
    const VkBufferImageCopy region{.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, image.layers},
                                   .imageExtent = {image.size, image.size, 1}};
    vkCmdCopyBufferToImage(commands, staging.buffer, image.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1,
                           &region);
    changeLayout(commands, image,
                 {VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL,
                  VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
                  VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT});
}

VkCommandBuffer beginCommands(const Gpu& gpu, VkCommandPool pool) {
    VkCommandBufferAllocateInfo allocate{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
    allocate.commandPool = pool;
    allocate.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    allocate.commandBufferCount = 1;
    VkCommandBuffer commands = VK_NULL_HANDLE;
    VK_CHECK(vkAllocateCommandBuffers(gpu.device, &allocate, &commands));
    VkCommandBufferBeginInfo begin{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    VK_CHECK(vkBeginCommandBuffer(commands, &begin));
    return commands;
}

void submitAndWait(const Gpu& gpu, VkCommandBuffer commands) {
    VkFenceCreateInfo fenceInfo{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    VkFence fence = VK_NULL_HANDLE;
    VK_CHECK(vkCreateFence(gpu.device, &fenceInfo, nullptr, &fence));
    VkSubmitInfo submit{VK_STRUCTURE_TYPE_SUBMIT_INFO};
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &commands;
    VK_CHECK(vkQueueSubmit(gpu.queue, 1, &submit, fence));
    VK_CHECK(vkWaitForFences(gpu.device, 1, &fence, VK_TRUE, UINT64_MAX));
    vkDestroyFence(gpu.device, fence, nullptr);
}

// --- the bake ------------------------------------------------------------------------------------

struct Bake {
    std::vector<Coefficient> radiance;
    std::vector<Coefficient> irradiance;
};

struct Programs {
    VkSampler sampler = VK_NULL_HANDLE; // project.comp's immutable sampler
    Program project, reduce, convolve;
};

Programs createPrograms(const Gpu& gpu, const Options& options) {
    const VkDescriptorType image = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    const VkDescriptorType buffer = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    Programs programs;
    programs.sampler = createNearestSampler(gpu);
    programs.project = createProgram(
        gpu, options, {"project.comp.spv", {image, buffer}, sizeof(glsl::ProjectParams), programs.sampler});
    programs.reduce =
        createProgram(gpu, options, {"reduce.comp.spv", {buffer, buffer}, sizeof(glsl::ReduceParams)});
    programs.convolve =
        createProgram(gpu, options, {"convolve.comp.spv", {buffer, buffer}, sizeof(glsl::ConvolveParams)});
    return programs;
}

void destroyPrograms(const Gpu& gpu, Programs& programs) {
    for (Program* program : {&programs.convolve, &programs.reduce, &programs.project})
        destroyProgram(gpu, *program);
    vkDestroySampler(gpu.device, programs.sampler, nullptr);
}

// What one bake dispatches: N, the SH order and project.comp's workgroups per probe, with the
// plan's inputs from the device and its intermediate values, printed for scripts/example.sh to
// hold against INTERFACE.md's table of plans.
struct BakePlan {
    uint32_t faceSize = 0, order = 0, groups = 0;
    uint32_t maxWorkGroupCountX = 0, maxStorageBufferRange = 0;
    uint32_t positions = 0, maxGroups = 0, maxPositions = 0, perInvocation = 0;
};

// shprobe's plan (dispatch_plan.h, INTERFACE.md): shprobe's default texels per invocation, at
// least as many positions per invocation as maxComputeWorkGroupCount[0] and one binding of partial
// slots (maxStorageBufferRange) allow, at most lavapipe's loop cap.
BakePlan planBake(const Gpu& gpu, const Options& options) {
    BakePlan plan{.faceSize = options.faceSize, .order = options.order};
    plan.maxWorkGroupCountX = gpu.limits.maxComputeWorkGroupCount[0];
    plan.maxStorageBufferRange = gpu.limits.maxStorageBufferRange;
    plan.positions = glsl::projectionPositions(options.faceSize);
    const uint32_t slotBytes = options.order * options.order * uint32_t(sizeof(Coefficient));
    plan.maxGroups =
        glsl::maxGroupsPerProbe(plan.maxWorkGroupCountX, plan.maxStorageBufferRange, slotBytes, kProbes);
    plan.maxPositions = glsl::maxPositionsPerInvocation(options.order);
    plan.perInvocation = glsl::planPositionsPerInvocation(plan.positions, glsl::kDefaultTexelsPerInvocation,
                                                          kWidth, plan.maxGroups, plan.maxPositions);
    if (plan.perInvocation == 0)
        fail("face size " + std::to_string(options.faceSize) + " at order " + std::to_string(options.order) +
             " needs more workgroups than one dispatch allows on this device");
    plan.groups = glsl::planGroups(plan.positions, plan.perInvocation, kWidth);
    return plan;
}

// Everything one bake allocates.
struct BakeResources {
    Buffer staging, partials, radiance, output;
    Image cubemaps;
    VkDescriptorPool pool = VK_NULL_HANDLE;
    VkDescriptorSet project = VK_NULL_HANDLE, reduce = VK_NULL_HANDLE, convolve = VK_NULL_HANDLE;
    VkCommandPool commandPool = VK_NULL_HANDLE;
};

VkDescriptorPool createDescriptorPool(const Gpu& gpu) {
    const VkDescriptorPoolSize sizes[2] = {{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 5},
                                           {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1}};
    VkDescriptorPoolCreateInfo info{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
    info.maxSets = 3;
    info.poolSizeCount = 2;
    info.pPoolSizes = sizes;
    VkDescriptorPool pool = VK_NULL_HANDLE;
    VK_CHECK(vkCreateDescriptorPool(gpu.device, &info, nullptr, &pool));
    return pool;
}

// The buffers of INTERFACE.md's table (partial slots, radiance, output), the image and its
// staging copy, and the three descriptor sets.
BakeResources createBakeResources(const Gpu& gpu, const Programs& programs,
                                  const std::vector<Coefficient>& texels, const BakePlan& plan) {
    if (plan.faceSize > gpu.limits.maxImageDimension2D)
        fail("face size " + std::to_string(plan.faceSize) + " exceeds maxImageDimension2D " +
             std::to_string(gpu.limits.maxImageDimension2D));
    const VkDeviceSize texelBytes = texels.size() * sizeof(Coefficient);
    const VkDeviceSize setBytes = plan.order * plan.order * sizeof(Coefficient);
    BakeResources r;
    r.staging = createBuffer(gpu, texelBytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT);
    std::memcpy(r.staging.mapped, texels.data(), texelBytes);
    r.cubemaps = createCubemapImage(gpu, plan.faceSize, kFaces * kProbes);
    r.partials = createBuffer(gpu, kProbes * plan.groups * setBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
    r.radiance = createBuffer(gpu, kProbes * setBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
    r.output = createBuffer(gpu, 2 * kProbes * setBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
    r.pool = createDescriptorPool(gpu);
    r.project = createSet(gpu, r.pool, programs.project, {{.image = &r.cubemaps}, {&r.partials}});
    r.reduce = createSet(gpu, r.pool, programs.reduce, {{&r.partials}, {&r.radiance}});
    r.convolve = createSet(gpu, r.pool, programs.convolve, {{&r.radiance}, {&r.output}});
    VkCommandPoolCreateInfo commandPoolInfo{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
    commandPoolInfo.queueFamilyIndex = gpu.queueFamily;
    VK_CHECK(vkCreateCommandPool(gpu.device, &commandPoolInfo, nullptr, &r.commandPool));
    return r;
}

void destroyBakeResources(const Gpu& gpu, BakeResources& r) {
    vkDestroyCommandPool(gpu.device, r.commandPool, nullptr);
    vkDestroyDescriptorPool(gpu.device, r.pool, nullptr);
    for (Buffer* buffer : {&r.output, &r.radiance, &r.partials})
        destroyBuffer(gpu, *buffer);
    destroyImage(gpu, r.cubemaps);
    destroyBuffer(gpu, r.staging);
}

// Per-band scales of convolve.comp: 1 (radiance) or A_l (irradiance, E_lm = A_l L_lm), written
// from vec4 outputOffset on.
glsl::ConvolveParams convolveParams(uint32_t order, bool irradiance, uint32_t outputOffset) {
    glsl::ConvolveParams params{};
    for (uint32_t l = 0; l < order; ++l)
        params.bandScale[l / 4][l % 4] = irradiance ? float(irradianceFactor(int(l))) : 1.0f;
    params.outputOffset = outputOffset;
    return params;
}

// upload -> project -> reduce -> convolve twice into one output: radiance at 0, irradiance after
// all probes' radiance (INTERFACE.md's output layout).
void recordBake(VkCommandBuffer commands, const Programs& programs, const BakeResources& r,
                const BakePlan& plan) {
    const uint32_t coefficients = plan.order * plan.order;
    const glsl::ProjectParams project{plan.faceSize};
    const glsl::ReduceParams reduce{plan.groups};
    const glsl::ConvolveParams radiance = convolveParams(plan.order, false, 0);
    const glsl::ConvolveParams irradiance = convolveParams(plan.order, true, kProbes * coefficients);
    recordUpload(commands, r.staging, r.cubemaps);
    dispatch(commands, programs.project, r.project, &project, plan.groups, kProbes);
    barrier(commands, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT);
    dispatch(commands, programs.reduce, r.reduce, &reduce, coefficients,
             kProbes); // one workgroup per coefficient
    barrier(commands, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT);
    dispatch(commands, programs.convolve, r.convolve, &radiance, 1, kProbes);
    // Not needed (disjoint parts of one binding); shprobe records it too, for hazard tracking that
    // sees the binding's whole range.
    barrier(commands, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT);
    dispatch(commands, programs.convolve, r.convolve, &irradiance, 1, kProbes);
    barrier(commands, VK_PIPELINE_STAGE_HOST_BIT, VK_ACCESS_HOST_READ_BIT);
}

Bake bake(const Gpu& gpu, const Programs& programs, const std::vector<Coefficient>& texels,
          const Options& options) {
    const BakePlan plan = planBake(gpu, options);
    BakeResources r = createBakeResources(gpu, programs, texels, plan);
    VkCommandBuffer commands = beginCommands(gpu, r.commandPool);
    recordBake(commands, programs, r, plan);
    VK_CHECK(vkEndCommandBuffer(commands));
    submitAndWait(gpu, commands);
    std::printf("input: %s, 6 x %u x %u texels, order %u, %u workgroups of %u\n", options.environment.c_str(),
                plan.faceSize, plan.faceSize, plan.order, plan.groups, kWidth);
    // The columns of INTERFACE.md's table of plans, in its order.
    std::printf("plan: %u %u %u %u %u %u %u %u %u %u %u %u\n", plan.faceSize, plan.order, kProbes,
                glsl::kDefaultTexelsPerInvocation, kWidth, plan.maxWorkGroupCountX,
                plan.maxStorageBufferRange, plan.positions, plan.maxGroups, plan.maxPositions,
                plan.perInvocation, plan.groups);

    // Probe 0: radiance at vec4 0, irradiance at kProbes * n^2.
    const uint32_t coefficients = plan.order * plan.order;
    const auto* radiance = static_cast<const Coefficient*>(r.output.mapped);
    const Coefficient* irradiance = radiance + kProbes * coefficients;
    Bake result{{radiance, radiance + coefficients}, {irradiance, irradiance + coefficients}};
    destroyBakeResources(gpu, r);
    return result;
}

void printCoefficients(const char* tag, const std::vector<Coefficient>& coefficients) {
    for (size_t i = 0; i < coefficients.size(); ++i)
        std::printf("%s %2zu %16.9g %16.9g %16.9g\n", tag, i, coefficients[i].r, coefficients[i].g,
                    coefficients[i].b);
}

uint32_t parseNumber(const std::string& text, uint32_t low, uint32_t high, const char* what) {
    char* end = nullptr;
    unsigned long value = std::strtoul(text.c_str(), &end, 10);
    if (text.empty() || *end || value < low || value > high)
        fail(std::string(what) + " must be " + std::to_string(low) + ".." + std::to_string(high) + ", got " +
             text);
    return uint32_t(value);
}

Options parseOptions(int argc, char** argv) {
    Options options;
    for (int i = 1; i < argc; ++i) {
        std::string arg = argv[i];
        auto value = [&]() -> std::string {
            if (i + 1 >= argc) fail(arg + " needs a value");
            return argv[++i];
        };
        if (arg == "--environment")
            options.environment = value();
        else if (arg == "--face-size")
            options.faceSize = parseNumber(value(), 1, 16384, "--face-size");
        else if (arg == "--order")
            options.order = parseNumber(value(), 1, SHPROBE_MAX_ORDER, "--order");
        else if (arg == "--write-faces")
            options.writeFaces = value();
        else if (arg == "--spirv-dir")
            options.spirvDir = value();
        else if (arg == "--validation")
            options.validation = true;
        else
            fail("unknown option " + arg);
    }
    if (options.environment != "white" && options.environment != "sky")
        fail("--environment must be white or sky, got " + options.environment);
    return options;
}

} // namespace

int main(int argc, char** argv) {
    Options options = parseOptions(argc, argv);
    std::vector<Coefficient> texels = makeCubemap(options);
    if (!options.writeFaces.empty()) writeFaces(texels, options.faceSize, options.writeFaces);

    Gpu gpu;
    createInstance(gpu, options.validation);
    createDevice(gpu);
    Programs programs = createPrograms(gpu, options);
    Bake result = bake(gpu, programs, texels, options);
    printCoefficients("L", result.radiance);
    printCoefficients("E", result.irradiance);

    destroyPrograms(gpu, programs);
    vkDestroyDevice(gpu.device, nullptr);
    if (gpu.messenger) {
        auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
            vkGetInstanceProcAddr(gpu.instance, "vkDestroyDebugUtilsMessengerEXT"));
        destroy(gpu.instance, gpu.messenger, nullptr);
    }
    vkDestroyInstance(gpu.instance, nullptr);
    if (gValidationMessages) fail(std::to_string(gValidationMessages) + " validation messages");
    return 0;
}
