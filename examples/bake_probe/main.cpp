// bake_probe: bakes an SH light probe with shprobe's installed SPIR-V modules and plain Vulkan.
//
// Everything here comes from share/shprobe/spirv/INTERFACE.md: the bindings, the push-constant
// layouts (declared below and pinned by static_asserts), the specialization constants and the
// dispatch rules of project.comp, reduce.comp and convolve.comp. No shprobe C++ is linked or
// included; the only thing the package provides is the folder of the .spv files.
//
//   bake_probe [--environment white|sky] [--face-size N] [--order N] [--write-faces DIR]
//              [--spirv-dir DIR] [--validation]
//
// The environment is generated: `white` is radiance 1 everywhere (the white furnace: L_00 =
// sqrt(4 pi), every other coefficient 0), `sky` a smooth gradient with a soft sun. --write-faces
// writes the same texels as DIR/px.pfm ... DIR/nz.pfm, which `shprobe bake 'DIR/{face}.pfm'` reads.
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
#include <stdexcept>
#include <string>
#include <vector>

#define VK_CHECK(call)                                                                                         \
    do {                                                                                                       \
        VkResult result_ = (call);                                                                             \
        if (result_ != VK_SUCCESS) fail(std::string(#call) + " failed with VkResult " + std::to_string(result_)); \
    } while (0)

namespace {

[[noreturn]] void fail(const std::string& message) {
    std::fprintf(stderr, "bake_probe: error: %s\n", message.c_str());
    std::exit(1);
}

// --- the interface, from INTERFACE.md ------------------------------------------------------------

constexpr uint32_t kSpecWorkgroupWidth = 0; // specialization constant ids
constexpr uint32_t kSpecOrder = 1;
constexpr uint32_t kWidth = 64;             // workgroup width of all three modules here
constexpr uint32_t kTexelsPerPosition = 6;  // project.comp: one position = the same texel of six faces

struct ProjectParams { // project.comp, 16 bytes
    uint32_t faceSize;
    uint32_t firstRow;
    uint32_t rowCount;
    uint32_t partialOffset;
};
static_assert(sizeof(ProjectParams) == 16 && offsetof(ProjectParams, faceSize) == 0 &&
              offsetof(ProjectParams, firstRow) == 4 && offsetof(ProjectParams, rowCount) == 8 &&
              offsetof(ProjectParams, partialOffset) == 12);

struct ReduceParams { // reduce.comp, 4 bytes
    uint32_t partialCount;
};
static_assert(sizeof(ReduceParams) == 4);

struct ConvolveParams { // convolve.comp, 32 bytes: vec4 bandScale[2], band l at float l
    float bandScale[8];
};
static_assert(sizeof(ConvolveParams) == 32);

struct Coefficient { // every coefficient buffer: vec4, rgb + unused w
    float r, g, b, unused;
};
static_assert(sizeof(Coefficient) == 16);

// The lavapipe loop cap of project.comp: positions per invocation at order n.
uint32_t maxPositionsPerInvocation(uint32_t n) {
    return 32768u / (1u + 6u * (1u + n * n + n * n / 2u));
}

// A_l, the clamped-cosine convolution factor of band l.
double irradianceFactor(int l) {
    const double pi = 3.14159265358979323846;
    if (l == 0) return pi;
    if (l == 1) return 2.0 * pi / 3.0;
    if (l % 2 == 1) return 0.0;
    double binomial = 1.0; // C(l, l/2) / 2^l
    for (int k = 1; k <= l / 2; ++k) binomial *= (2.0 * k - 1.0) / (2.0 * k);
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

// RGBA32F, face after face, rows top to bottom: project.comp's layout with one band.
std::vector<Coefficient> makeCubemap(const Options& options) {
    uint32_t n = options.faceSize;
    std::vector<Coefficient> texels;
    texels.reserve(size_t(6) * n * n);
    for (int face = 0; face < 6; ++face)
        for (uint32_t j = 0; j < n; ++j)
            for (uint32_t i = 0; i < n; ++i) texels.push_back(radianceAt(options.environment, texelDirection(face, i, j, n)));
    return texels;
}

// PFM (little-endian RGB float), whose rows go bottom to top.
void writeFaces(const std::vector<Coefficient>& texels, uint32_t n, const std::string& folder) {
    const char* names[6] = {"px", "nx", "py", "ny", "pz", "nz"};
    for (int face = 0; face < 6; ++face) {
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

// --- Vulkan: instance, device, buffers -----------------------------------------------------------

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

VKAPI_ATTR VkBool32 VKAPI_CALL onValidation(VkDebugUtilsMessageSeverityFlagBitsEXT, VkDebugUtilsMessageTypeFlagsEXT,
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

// project.comp needs Vulkan 1.1 and subgroup basic + arithmetic operations in compute shaders.
bool suitable(VkPhysicalDevice physical, uint32_t& queueFamily) {
    VkPhysicalDeviceSubgroupProperties subgroup{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES};
    VkPhysicalDeviceProperties2 properties{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
    properties.pNext = &subgroup;
    vkGetPhysicalDeviceProperties2(physical, &properties);
    VkSubgroupFeatureFlags needed = VK_SUBGROUP_FEATURE_BASIC_BIT | VK_SUBGROUP_FEATURE_ARITHMETIC_BIT;
    if (properties.properties.apiVersion < VK_API_VERSION_1_1 || !(subgroup.supportedStages & VK_SHADER_STAGE_COMPUTE_BIT) ||
        (subgroup.supportedOperations & needed) != needed)
        return false;
    uint32_t count = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(physical, &count, nullptr);
    std::vector<VkQueueFamilyProperties> families(count);
    vkGetPhysicalDeviceQueueFamilyProperties(physical, &count, families.data());
    for (uint32_t i = 0; i < count; ++i)
        if (families[i].queueFlags & VK_QUEUE_COMPUTE_BIT) {
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
    if (!gpu.physical) fail("no Vulkan 1.1 device with subgroup arithmetic in compute shaders");
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

// Host-visible, coherent storage buffers: simple, and fine for a probe's few kilobytes.
struct Buffer {
    VkBuffer buffer = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkDeviceSize size = 0;
    void* mapped = nullptr;
};

uint32_t hostVisibleMemoryType(const Gpu& gpu, uint32_t allowed) {
    VkPhysicalDeviceMemoryProperties memory;
    vkGetPhysicalDeviceMemoryProperties(gpu.physical, &memory);
    VkMemoryPropertyFlags wanted = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
    for (uint32_t i = 0; i < memory.memoryTypeCount; ++i)
        if ((allowed & (1u << i)) && (memory.memoryTypes[i].propertyFlags & wanted) == wanted) return i;
    fail("no host-visible coherent memory for storage buffers");
}

Buffer createBuffer(const Gpu& gpu, VkDeviceSize size) {
    Buffer buffer;
    buffer.size = size;
    VkBufferCreateInfo info{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
    info.size = size;
    info.usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
    VK_CHECK(vkCreateBuffer(gpu.device, &info, nullptr, &buffer.buffer));
    VkMemoryRequirements requirements;
    vkGetBufferMemoryRequirements(gpu.device, buffer.buffer, &requirements);
    VkMemoryAllocateInfo allocate{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
    allocate.allocationSize = requirements.size;
    allocate.memoryTypeIndex = hostVisibleMemoryType(gpu, requirements.memoryTypeBits);
    VK_CHECK(vkAllocateMemory(gpu.device, &allocate, nullptr, &buffer.memory));
    VK_CHECK(vkBindBufferMemory(gpu.device, buffer.buffer, buffer.memory, 0));
    VK_CHECK(vkMapMemory(gpu.device, buffer.memory, 0, VK_WHOLE_SIZE, 0, &buffer.mapped));
    std::memset(buffer.mapped, 0, size);
    return buffer;
}

void destroyBuffer(const Gpu& gpu, Buffer& buffer) {
    vkDestroyBuffer(gpu.device, buffer.buffer, nullptr);
    vkFreeMemory(gpu.device, buffer.memory, nullptr);
}

// --- programs: one per module, as INTERFACE.md lays them out -------------------------------------

struct Program {
    VkShaderModule module = VK_NULL_HANDLE;
    VkDescriptorSetLayout setLayout = VK_NULL_HANDLE;
    VkPipelineLayout layout = VK_NULL_HANDLE;
    VkPipeline pipeline = VK_NULL_HANDLE;
    uint32_t pushConstantSize = 0;
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

// Set 0 holds storage buffers at bindings 0..bufferCount-1; push constants from offset 0;
// specialization constants 0 (workgroup width) and 1 (SH order); entry point "main".
Program createProgram(const Gpu& gpu, const std::string& path, uint32_t bufferCount, uint32_t pushConstantSize,
                      uint32_t order) {
    Program program;
    program.pushConstantSize = pushConstantSize;
    std::vector<uint32_t> code = readSpirv(path);
    VkShaderModuleCreateInfo moduleInfo{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
    moduleInfo.codeSize = code.size() * 4;
    moduleInfo.pCode = code.data();
    VK_CHECK(vkCreateShaderModule(gpu.device, &moduleInfo, nullptr, &program.module));

    std::vector<VkDescriptorSetLayoutBinding> bindings;
    for (uint32_t b = 0; b < bufferCount; ++b)
        bindings.push_back({b, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr});
    VkDescriptorSetLayoutCreateInfo setInfo{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
    setInfo.bindingCount = bufferCount;
    setInfo.pBindings = bindings.data();
    VK_CHECK(vkCreateDescriptorSetLayout(gpu.device, &setInfo, nullptr, &program.setLayout));

    VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, pushConstantSize};
    VkPipelineLayoutCreateInfo layoutInfo{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
    layoutInfo.setLayoutCount = 1;
    layoutInfo.pSetLayouts = &program.setLayout;
    layoutInfo.pushConstantRangeCount = 1;
    layoutInfo.pPushConstantRanges = &range;
    VK_CHECK(vkCreatePipelineLayout(gpu.device, &layoutInfo, nullptr, &program.layout));

    const uint32_t values[2] = {kWidth, order};
    const VkSpecializationMapEntry entries[2] = {{kSpecWorkgroupWidth, 0, 4}, {kSpecOrder, 4, 4}};
    VkSpecializationInfo specialization{2, entries, sizeof(values), values};
    VkComputePipelineCreateInfo info{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
    info.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
    info.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    info.stage.module = program.module;
    info.stage.pName = "main";
    info.stage.pSpecializationInfo = &specialization;
    info.layout = program.layout;
    VK_CHECK(vkCreateComputePipelines(gpu.device, VK_NULL_HANDLE, 1, &info, nullptr, &program.pipeline));
    return program;
}

void destroyProgram(const Gpu& gpu, Program& program) {
    vkDestroyPipeline(gpu.device, program.pipeline, nullptr);
    vkDestroyPipelineLayout(gpu.device, program.layout, nullptr);
    vkDestroyDescriptorSetLayout(gpu.device, program.setLayout, nullptr);
    vkDestroyShaderModule(gpu.device, program.module, nullptr);
}

VkDescriptorSet createSet(const Gpu& gpu, VkDescriptorPool pool, const Program& program,
                          std::initializer_list<const Buffer*> buffers) {
    VkDescriptorSetAllocateInfo allocate{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
    allocate.descriptorPool = pool;
    allocate.descriptorSetCount = 1;
    allocate.pSetLayouts = &program.setLayout;
    VkDescriptorSet set = VK_NULL_HANDLE;
    VK_CHECK(vkAllocateDescriptorSets(gpu.device, &allocate, &set));
    std::vector<VkDescriptorBufferInfo> infos;
    for (const Buffer* buffer : buffers) infos.push_back({buffer->buffer, 0, VK_WHOLE_SIZE});
    std::vector<VkWriteDescriptorSet> writes;
    for (uint32_t b = 0; b < infos.size(); ++b) {
        VkWriteDescriptorSet write{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
        write.dstSet = set;
        write.dstBinding = b;
        write.descriptorCount = 1;
        write.descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
        write.pBufferInfo = &infos[b];
        writes.push_back(write);
    }
    vkUpdateDescriptorSets(gpu.device, uint32_t(writes.size()), writes.data(), 0, nullptr);
    return set;
}

void dispatch(VkCommandBuffer commands, const Program& program, VkDescriptorSet set, const void* constants,
              uint32_t groups) {
    vkCmdBindPipeline(commands, VK_PIPELINE_BIND_POINT_COMPUTE, program.pipeline);
    vkCmdBindDescriptorSets(commands, VK_PIPELINE_BIND_POINT_COMPUTE, program.layout, 0, 1, &set, 0, nullptr);
    vkCmdPushConstants(commands, program.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, program.pushConstantSize, constants);
    vkCmdDispatch(commands, groups, 1, 1);
}

void barrier(VkCommandBuffer commands, VkPipelineStageFlags destinationStage, VkAccessFlags destinationAccess) {
    VkMemoryBarrier memory{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    memory.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT;
    memory.dstAccessMask = destinationAccess;
    vkCmdPipelineBarrier(commands, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, destinationStage, 0, 1, &memory, 0, nullptr,
                         0, nullptr);
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
    Program project, reduce, convolve;
};

Programs createPrograms(const Gpu& gpu, const Options& options) {
    std::string dir = options.spirvDir + "/";
    return {createProgram(gpu, dir + "project.comp.spv", 2, sizeof(ProjectParams), options.order),
            createProgram(gpu, dir + "reduce.comp.spv", 2, sizeof(ReduceParams), options.order),
            createProgram(gpu, dir + "convolve.comp.spv", 2, sizeof(ConvolveParams), options.order)};
}

// project.comp's workgroup count (INTERFACE.md): about 43 positions (256 texels) per invocation,
// capped for lavapipe's loop limit.
uint32_t projectGroups(const Gpu& gpu, uint32_t faceSize, uint32_t order) {
    const uint32_t positionsPerInvocation =
        std::min((256u + kTexelsPerPosition - 1) / kTexelsPerPosition, maxPositionsPerInvocation(order));
    const uint32_t perGroup = kWidth * positionsPerInvocation;
    return std::clamp((faceSize * faceSize + perGroup - 1) / perGroup, 1u, gpu.limits.maxComputeWorkGroupCount[0]);
}

// Everything one bake allocates.
struct BakeResources {
    Buffer input, partials, raw, radiance, irradiance;
    VkDescriptorPool pool = VK_NULL_HANDLE;
    VkCommandPool commandPool = VK_NULL_HANDLE;
};

BakeResources createBakeResources(const Gpu& gpu, const std::vector<Coefficient>& texels, uint32_t groups,
                                  uint32_t order) {
    const VkDeviceSize texelBytes = texels.size() * sizeof(Coefficient);
    if (texelBytes > gpu.limits.maxStorageBufferRange)
        fail("the cube map needs more than one band (maxStorageBufferRange); this example binds one");
    const VkDeviceSize setBytes = order * order * sizeof(Coefficient);
    BakeResources r;
    r.input = createBuffer(gpu, texelBytes);
    std::memcpy(r.input.mapped, texels.data(), texelBytes);
    r.partials = createBuffer(gpu, groups * setBytes);
    r.raw = createBuffer(gpu, setBytes);
    r.radiance = createBuffer(gpu, setBytes);
    r.irradiance = createBuffer(gpu, setBytes);

    VkDescriptorPoolSize poolSize{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 8};
    VkDescriptorPoolCreateInfo poolInfo{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
    poolInfo.maxSets = 4;
    poolInfo.poolSizeCount = 1;
    poolInfo.pPoolSizes = &poolSize;
    VK_CHECK(vkCreateDescriptorPool(gpu.device, &poolInfo, nullptr, &r.pool));
    VkCommandPoolCreateInfo commandPoolInfo{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
    commandPoolInfo.queueFamilyIndex = gpu.queueFamily;
    VK_CHECK(vkCreateCommandPool(gpu.device, &commandPoolInfo, nullptr, &r.commandPool));
    return r;
}

void destroyBakeResources(const Gpu& gpu, BakeResources& r) {
    vkDestroyCommandPool(gpu.device, r.commandPool, nullptr);
    vkDestroyDescriptorPool(gpu.device, r.pool, nullptr);
    for (Buffer* buffer : {&r.irradiance, &r.radiance, &r.raw, &r.partials, &r.input}) destroyBuffer(gpu, *buffer);
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

// Per-band scales of convolve.comp: 1 (radiance) or A_l (irradiance, E_lm = A_l L_lm).
ConvolveParams bandScales(uint32_t order, bool irradiance) {
    ConvolveParams params{};
    for (uint32_t l = 0; l < order; ++l) params.bandScale[l] = irradiance ? float(irradianceFactor(int(l))) : 1.0f;
    return params;
}

// project (one band: the whole cube map) -> reduce -> convolve twice, in one submission.
Bake bake(const Gpu& gpu, const Programs& programs, const std::vector<Coefficient>& texels, const Options& options) {
    const uint32_t n = options.faceSize, order = options.order;
    const uint32_t groups = projectGroups(gpu, n, order);
    BakeResources r = createBakeResources(gpu, texels, groups, order);
    VkDescriptorSet projectSet = createSet(gpu, r.pool, programs.project, {&r.input, &r.partials});
    VkDescriptorSet reduceSet = createSet(gpu, r.pool, programs.reduce, {&r.partials, &r.raw});
    VkDescriptorSet radianceSet = createSet(gpu, r.pool, programs.convolve, {&r.raw, &r.radiance});
    VkDescriptorSet irradianceSet = createSet(gpu, r.pool, programs.convolve, {&r.raw, &r.irradiance});
    const ProjectParams project{n, 0, n, 0};
    const ReduceParams reduce{groups};
    const ConvolveParams unit = bandScales(order, false), lambert = bandScales(order, true);

    VkCommandBuffer commands = beginCommands(gpu, r.commandPool);
    dispatch(commands, programs.project, projectSet, &project, groups);
    barrier(commands, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT);
    dispatch(commands, programs.reduce, reduceSet, &reduce, uint32_t(options.order * options.order)); // one per coefficient
    barrier(commands, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT);
    dispatch(commands, programs.convolve, radianceSet, &unit, 1);
    dispatch(commands, programs.convolve, irradianceSet, &lambert, 1);
    barrier(commands, VK_PIPELINE_STAGE_HOST_BIT, VK_ACCESS_HOST_READ_BIT);
    VK_CHECK(vkEndCommandBuffer(commands));
    submitAndWait(gpu, commands);
    std::printf("input: %s, 6 x %u x %u texels, order %u, %u workgroups of %u\n", options.environment.c_str(), n, n,
                order, groups, kWidth);

    auto* radiance = static_cast<const Coefficient*>(r.radiance.mapped);
    auto* irradiance = static_cast<const Coefficient*>(r.irradiance.mapped);
    Bake result{{radiance, radiance + order * order}, {irradiance, irradiance + order * order}};
    destroyBakeResources(gpu, r);
    return result;
}

void printCoefficients(const char* tag, const std::vector<Coefficient>& coefficients) {
    for (size_t i = 0; i < coefficients.size(); ++i)
        std::printf("%s %2zu %16.9g %16.9g %16.9g\n", tag, i, coefficients[i].r, coefficients[i].g, coefficients[i].b);
}

uint32_t parseNumber(const std::string& text, uint32_t low, uint32_t high, const char* what) {
    char* end = nullptr;
    unsigned long value = std::strtoul(text.c_str(), &end, 10);
    if (text.empty() || *end || value < low || value > high)
        fail(std::string(what) + " must be " + std::to_string(low) + ".." + std::to_string(high) + ", got " + text);
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
        if (arg == "--environment") options.environment = value();
        else if (arg == "--face-size") options.faceSize = parseNumber(value(), 1, 16384, "--face-size");
        else if (arg == "--order") options.order = parseNumber(value(), 1, 8, "--order");
        else if (arg == "--write-faces") options.writeFaces = value();
        else if (arg == "--spirv-dir") options.spirvDir = value();
        else if (arg == "--validation") options.validation = true;
        else fail("unknown option " + arg);
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

    for (Program* program : {&programs.convolve, &programs.reduce, &programs.project}) destroyProgram(gpu, *program);
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
