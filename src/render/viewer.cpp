// The GLFW side of `shprobe view`: window, input and the frame loop. Rendering is the offscreen
// renderer's scene pass plus the tonemap pass into the swapchain (viewer_frames.cpp).
#include "render/viewer.h"

#include "common/counted.h"
#include "common/error.h"
#include "common/scope_exit.h"
#include "image/image_write.h"
#include "render/image_output.h"
#include "render/scene_renderer.h"
#include "render/viewer_frames.h"
#include "sh/rotation.h"
#include "vk/check.h"
#include "vk/vulkan_commands.h"

#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <vector>

namespace shprobe {

namespace {

constexpr float kDegreesPerPixel = 0.3f;
constexpr float kZoomPerStep = 0.9f;
constexpr float kRotationStep = 15.0f; // degrees per Left/Right
constexpr float kExposureStep = 0.5f;  // stops per +/-

// ---- Window and input ------------------------------------------------------------------------

std::string& lastGlfwError() {
    static std::string message = "unknown GLFW error";
    return message;
}

void onGlfwError(int, const char* description) {
    lastGlfwError() = description;
}

struct InputEvents {
    bool dragging = false;
    double lastX = 0.0, lastY = 0.0;
    float yawDelta = 0.0f, pitchDelta = 0.0f, zoomSteps = 0.0f;
    std::vector<int> keys;
};

InputEvents& eventsOf(GLFWwindow* window) {
    return *static_cast<InputEvents*>(glfwGetWindowUserPointer(window));
}

void onKey(GLFWwindow* window, int key, int, int action, int) {
    if (action == GLFW_PRESS || action == GLFW_REPEAT) eventsOf(window).keys.push_back(key);
}

void onMouseButton(GLFWwindow* window, int button, int action, int) {
    InputEvents& events = eventsOf(window);
    if (button != GLFW_MOUSE_BUTTON_LEFT) return;
    events.dragging = action == GLFW_PRESS;
    glfwGetCursorPos(window, &events.lastX, &events.lastY);
}

void onCursor(GLFWwindow* window, double x, double y) {
    InputEvents& events = eventsOf(window);
    if (!events.dragging) return;
    events.yawDelta -= float(x - events.lastX) * kDegreesPerPixel;
    events.pitchDelta += float(y - events.lastY) * kDegreesPerPixel;
    events.lastX = x;
    events.lastY = y;
}

void onScroll(GLFWwindow* window, double, double dy) {
    eventsOf(window).zoomSteps += float(dy);
}

GLFWwindow* openWindow(const ViewerOptions& options, InputEvents& events) {
    glfwSetErrorCallback(onGlfwError);
    if (!glfwInit())
        throw Error(ErrorKind::Device, "shprobe view needs a display, and there is none (" + lastGlfwError() +
                                           "): run it in a desktop session or under xvfb-run, or render "
                                           "images without a window with `shprobe render`");
    if (!glfwVulkanSupported()) {
        glfwTerminate();
        throw Error(ErrorKind::Device, "GLFW found no Vulkan loader; install libvulkan1 and a driver "
                                       "(`shprobe render` needs no window)");
    }
    glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
    GLFWwindow* window =
        glfwCreateWindow(int(options.width), int(options.height), "shprobe view", nullptr, nullptr);
    if (!window) {
        glfwTerminate();
        throw Error(ErrorKind::Device, "cannot open a window: " + lastGlfwError());
    }
    glfwSetWindowUserPointer(window, &events);
    glfwSetKeyCallback(window, onKey);
    glfwSetMouseButtonCallback(window, onMouseButton);
    glfwSetCursorPosCallback(window, onCursor);
    glfwSetScrollCallback(window, onScroll);
    return window;
}

void closeWindow(GLFWwindow* window) {
    glfwDestroyWindow(window);
    glfwTerminate();
}

VkExtent2D framebufferExtent(GLFWwindow* window) {
    int width = 0, height = 0;
    glfwGetFramebufferSize(window, &width, &height);
    return {uint32_t(std::max(width, 0)), uint32_t(std::max(height, 0))};
}

// Instance extensions for the window's surface, VK_KHR_swapchain, a graphics queue that presents.
ContextOptions viewerContextOptions(const ViewerOptions& options, GLFWwindow* window) {
    ContextOptions contextOptions;
    contextOptions.device = options.device;
    contextOptions.validation = options.validation;
    contextOptions.graphics = true;
    uint32_t count = 0;
    const char** names = glfwGetRequiredInstanceExtensions(&count);
    for (uint32_t i = 0; i < count; ++i)
        contextOptions.instanceExtensions.push_back(names[i]);
    contextOptions.deviceExtensions.push_back(VK_KHR_SWAPCHAIN_EXTENSION_NAME);
    contextOptions.createSurface = [window](VkInstance instance) {
        VkSurfaceKHR surface = VK_NULL_HANDLE;
        VkResult result = glfwCreateWindowSurface(instance, window, nullptr, &surface);
        if (result != VK_SUCCESS)
            throw Error(ErrorKind::Device, std::string("cannot create a Vulkan surface for the window: ") +
                                               vkResultName(result) + " (" + lastGlfwError() + ")");
        return surface;
    };
    return contextOptions;
}

// ---- The session: what is shown and how it changes -------------------------------------------

// A glTF scene lit by its volume, drawn by the capture's view pass into an HDR image of the
// swapchain's size.
struct ScenePicture {
    LitScene lit;
    SceneCapture capture;
    SceneViewTarget target;
    VkDescriptorSet tonemapInput = VK_NULL_HANDLE;
    bool showProbes = false;
};

// A scene with per-vertex transfer, relit by its light turned on the device each frame.
struct RelitPicture {
    TransferMesh mesh;
    RelitScene relit;
    RelitTarget target;
    VkDescriptorSet tonemapInput = VK_NULL_HANDLE;
    float yaw = 0.0f, pitch = 0.0f;
    float initialYaw = 0.0f, initialPitch = 0.0f;
};

struct Session {
    // The probe's sphere and torus (unless a scene is shown).
    RenderInput input;
    std::optional<ProbeBaker> baker; // re-bakes a rotated environment
    std::optional<SceneRenderer> renderer;
    SceneTargets targets;
    int foldOrder = 3;
    // Or the scene.
    std::optional<ScenePicture> scene;
    // Or the relit scene.
    std::optional<RelitPicture> relit;

    ViewerFrames frames;
    ViewState initial;
    ViewState view;
    bool initialShowProbes = false;
    float autoExposure = 1.0f;
    std::string device;
};

bool backgroundAvailable(const Session& session, Background background) {
    if (background == Background::Environment) return session.input.environment.has_value();
    if (background == Background::Radiance) return session.renderer->probe.hasRadiance;
    return true;
}

bool shadingAvailable(const Session& session, ShadingMode mode) {
    return mode != ShadingMode::Radiance || session.renderer->probe.hasRadiance;
}

// A starting view the input can show.
ViewState usableView(const Session& session, ViewState view) {
    clampView(view);
    if (session.scene || session.relit) return view;
    if (!backgroundAvailable(session, view.background))
        view.background =
            backgroundAvailable(session, Background::Radiance) ? Background::Radiance : Background::Shading;
    if (!shadingAvailable(session, view.shading)) view.shading = ShadingMode::Irradiance;
    return view;
}

void nextShading(Session& session) {
    do
        session.view.shading = ShadingMode((int(session.view.shading) + 1) % 3);
    while (!shadingAvailable(session, session.view.shading));
}

void nextBackground(Session& session) {
    do
        session.view.background = Background((int(session.view.background) + 1) % 4);
    while (!backgroundAvailable(session, session.view.background));
}

// An environment is re-projected: the original is rotated, baked again, and both are shown. A
// probe file's coefficients are rotated instead (sh/rotation.h).
void rotateEnvironment(const Context& context, Session& session, float degrees) {
    waitForFrame(context, session.frames);
    session.view.environmentRotationDegrees =
        std::remainder(session.view.environmentRotationDegrees + degrees, 360.0f);
    glm::dmat3 rotation = environmentRotation(session.view.environmentRotationDegrees);
    if (!session.input.environment || !session.baker) {
        ShCoefficients rotated =
            rotate(makeShRotation(rotation, session.input.probe.order), session.input.probe);
        std::optional<SphericalLight> sun = session.input.sun;
        if (sun) sun->direction = rotation * sun->direction; // the light from d comes from R d
        setProbe(*session.renderer, foldProbe(rotated, session.foldOrder, session.input.name, sun));
        return;
    }
    Cubemap rotated = rotateCubemap(*session.input.environment, rotation);
    ShCoefficients probe = bakeRadiance(context, *session.baker, rotated, session.input.bakeMilliseconds);
    setEnvironment(context, *session.renderer, rotated);
    setProbe(*session.renderer, foldProbe(probe, session.foldOrder, session.input.name));
}

// Keys of every view: exposure, reset, quit. False for others.
bool applyViewKey(GLFWwindow* window, Session& session, int key) {
    switch (key) {
    case GLFW_KEY_EQUAL:
    case GLFW_KEY_KP_ADD:
        session.view.exposureStops += kExposureStep;
        return true;
    case GLFW_KEY_MINUS:
    case GLFW_KEY_KP_SUBTRACT:
        session.view.exposureStops -= kExposureStep;
        return true;
    case GLFW_KEY_R:
        session.view = usableView(session, session.initial);
        if (session.scene) session.scene->showProbes = session.initialShowProbes;
        if (session.relit) {
            session.relit->yaw = session.relit->initialYaw;
            session.relit->pitch = session.relit->initialPitch;
        }
        return true;
    case GLFW_KEY_ESCAPE:
    case GLFW_KEY_Q:
        glfwSetWindowShouldClose(window, GLFW_TRUE);
        return true;
    default:
        return false;
    }
}

void applyProbeKey(const Context& context, Session& session, int key) {
    switch (key) {
    case GLFW_KEY_3:
        session.view.order = 3;
        break;
    case GLFW_KEY_5:
        if (session.foldOrder >= 5) session.view.order = 5;
        break;
    case GLFW_KEY_M:
        nextShading(session);
        break;
    case GLFW_KEY_B:
        nextBackground(session);
        break;
    case GLFW_KEY_LEFT:
        rotateEnvironment(context, session, -kRotationStep);
        break;
    case GLFW_KEY_RIGHT:
        rotateEnvironment(context, session, kRotationStep);
        break;
    default:
        break;
    }
}

// Turns the light: the turn's matrices are written here (once the last frame is done with them) and
// rotate.comp turns the coefficients in every frame's commands.
void applyRelitKey(RelitPicture& relit, int key) {
    switch (key) {
    case GLFW_KEY_LEFT:
    case GLFW_KEY_J:
        relit.yaw = std::remainder(relit.yaw - kRotationStep, 360.0f);
        break;
    case GLFW_KEY_RIGHT:
    case GLFW_KEY_L:
        relit.yaw = std::remainder(relit.yaw + kRotationStep, 360.0f);
        break;
    case GLFW_KEY_UP:
    case GLFW_KEY_I:
        relit.pitch = std::remainder(relit.pitch - kRotationStep, 360.0f);
        break;
    case GLFW_KEY_DOWN:
    case GLFW_KEY_K:
        relit.pitch = std::remainder(relit.pitch + kRotationStep, 360.0f);
        break;
    default:
        break;
    }
}

void applyKey(const Context& context, GLFWwindow* window, Session& session, int key) {
    if (applyViewKey(window, session, key)) return;
    if (session.relit) return applyRelitKey(*session.relit, key);
    if (!session.scene) return applyProbeKey(context, session, key);
    if (key == GLFW_KEY_P) session.scene->showProbes = !session.scene->showProbes;
}

void applyInput(const Context& context, GLFWwindow* window, Session& session, InputEvents& events) {
    for (int key : events.keys)
        applyKey(context, window, session, key);
    events.keys.clear();
    session.view.yawDegrees += events.yawDelta;
    session.view.pitchDegrees += events.pitchDelta;
    session.view.distance *= std::pow(kZoomPerStep, events.zoomSteps);
    events.yawDelta = events.pitchDelta = events.zoomSteps = 0.0f;
    clampView(session.view);
}

std::string sceneSummary(const Session& session) {
    const ProbeVolume& volume = session.scene->lit.volume;
    char text[512];
    std::snprintf(text, sizeof(text),
                  "shprobe view: %s | %dx%dx%d probes, order %d, bounce %d%s | %+.1f EV | ",
                  session.scene->lit.world.description.c_str(), volume.grid.counts.x, volume.grid.counts.y,
                  volume.grid.counts.z, volume.order, volume.bounces,
                  session.scene->showProbes ? " | probes shown" : "", double(session.view.exposureStops));
    return text + session.device;
}

std::string relitSummary(const Session& session) {
    const RelitPicture& relit = *session.relit;
    char text[512];
    std::snprintf(text, sizeof(text),
                  "shprobe view: %s | transfer order %d %s | light yaw %.0f, pitch %.0f | %+.1f EV | ",
                  relit.mesh.world.description.c_str(), relit.mesh.order,
                  relit.mesh.channels == 3 ? "RGB" : "grey", double(relit.yaw), double(relit.pitch),
                  double(session.view.exposureStops));
    return text + session.device;
}

std::string sessionSummary(const Session& session) {
    if (session.relit) return relitSummary(session);
    if (session.scene) return sceneSummary(session);
    return viewSummary(session.view, session.input.name, session.input.bakeMilliseconds, session.device);
}

void updateTitle(GLFWwindow* window, const Session& session, std::string& shown) {
    std::string title = sessionSummary(session);
    if (title == shown) return;
    glfwSetWindowTitle(window, title.c_str());
    shown = title;
}

// The HDR image the picture is drawn into, at the swapchain's size.
void destroyPictureTargets(const Device& device, Session& session) {
    const Tonemapper& tonemapper = session.frames.tonemapper;
    if (session.relit) {
        if (session.relit->tonemapInput) freeTonemapInput(device, tonemapper, session.relit->tonemapInput);
        return destroyColorDepthTarget(device, session.relit->target);
    }
    if (!session.scene) return destroySceneTargets(device, tonemapper, session.targets);
    freeTonemapInput(device, tonemapper, session.scene->tonemapInput);
    destroySceneViewTarget(device, session.scene->target);
}

void sizePictureTargets(const Context& context, Session& session) {
    destroyPictureTargets(context, session);
    const VkExtent2D extent = session.frames.swapchain.extent;
    const Tonemapper& tonemapper = session.frames.tonemapper;
    if (session.relit) {
        RelitPicture& relit = *session.relit;
        relit.target = createRelitTarget(context, relit.relit, extent, VK_IMAGE_USAGE_SAMPLED_BIT);
        relit.tonemapInput = createTonemapInput(context, tonemapper, relit.target.color.view);
        return;
    }
    if (!session.scene) {
        session.targets = createSceneTargets(context, *session.renderer, tonemapper, extent);
        return;
    }
    ScenePicture& scene = *session.scene;
    scene.target = createSceneViewTarget(context, scene.capture, extent, VK_IMAGE_USAGE_SAMPLED_BIT);
    scene.tonemapInput = createTonemapInput(context, tonemapper, scene.target.color.view);
}

void startProbe(const Context& context, const ViewerOptions& options, Session& session) {
    session.input =
        options.probe ? *options.probe : loadRenderInput(context, options.input, options.inputOptions);
    session.foldOrder = std::min(session.input.probe.order, kMaxRenderOrder);
    ProbeShading probe = foldProbe(session.input.probe, std::max(options.view.order, session.foldOrder),
                                   session.input.name, session.input.sun);
    session.renderer = createSceneRenderer(context);
    setProbe(*session.renderer, probe);
    if (session.input.environment) {
        setEnvironment(context, *session.renderer, *session.input.environment);
        session.baker = createRenderBaker(context);
    }
    session.autoExposure = autoExposure(session.input.probe, session.input.sun);
}

void startScene(const Context& context, const ViewerOptions& options, Session& session) {
    session.scene.emplace();
    session.scene->lit = *options.scene;
    session.scene->capture = createLitSceneCapture(context, session.scene->lit);
    session.scene->showProbes = session.initialShowProbes = options.showProbes;
    session.autoExposure = volumeExposure(session.scene->lit.volume);
}

void startRelit(const Context& context, const ViewerOptions& options, Session& session) {
    RelitPicture& relit = session.relit.emplace();
    relit.mesh = *options.relitMesh;
    const ShCoefficients light = relitLightCoefficients(context, *options.relitLight, relit.mesh.order);
    relit.relit = createRelitScene(context, relit.mesh, light);
    relit.yaw = relit.initialYaw = options.lightYaw;
    relit.pitch = relit.initialPitch = options.lightPitch;
    session.autoExposure = autoExposure(light);
}

void startSession(const Context& context, const ViewerOptions& options, GLFWwindow* window,
                  Session& session) {
    if (options.relitMesh)
        startRelit(context, options, session);
    else if (options.scene)
        startScene(context, options, session);
    else
        startProbe(context, options, session);
    session.initial = usableView(session, options.view);
    session.view = session.initial;
    session.device = context.info.name;
    session.frames = createViewerFrames(context, framebufferExtent(window));
    sizePictureTargets(context, session);
}

void endSession(const Context& context, Session& session) {
    if (context.device) vkDeviceWaitIdle(context.device);
    destroyPictureTargets(context, session);
    destroyViewerFrames(context, session.frames);
    if (session.scene) destroySceneCapture(context, session.scene->capture);
    if (session.relit) destroyRelitScene(context, session.relit->relit);
    if (session.renderer) destroySceneRenderer(context, *session.renderer);
    if (session.baker) destroyProbeBaker(context, *session.baker);
}

// Records the current view into the picture's HDR image.
void recordRelitPicture(VkCommandBuffer commands, const Session& session) {
    const RelitPicture& relit = *session.relit;
    // The frame's fence has been waited for: the last rotation is done with the matrices.
    setLightRotation(relit.relit, lightRotation(relit.yaw, relit.pitch));
    const float zoom = session.view.distance / ViewState{}.distance;
    const SceneCamera camera =
        orbitSceneCamera(relit.mesh.world, session.view.yawDegrees, session.view.pitchDegrees, zoom);
    recordRelitView(commands, relit.relit, relit.target,
                    cameraProjection(camera, relit.target.extent, relit.relit.nearPlane));
}

void recordPicture(const Device& device, VkCommandBuffer commands, Session& session) {
    if (session.relit) return recordRelitPicture(commands, session);
    if (!session.scene) {
        Scene scene = viewScene(session.view);
        return recordScene(device, commands, *session.renderer, session.targets, scene);
    }
    const ScenePicture& scene = *session.scene;
    // The view's distance relative to its default: 1 keeps the whole scene in view.
    const float zoom = session.view.distance / ViewState{}.distance;
    const SceneCamera camera =
        orbitSceneCamera(scene.lit.world, session.view.yawDegrees, session.view.pitchDegrees, zoom);
    recordLitSceneView(commands, scene.capture, scene.target, camera, {.showProbes = scene.showProbes});
}

VkDescriptorSet tonemapInput(const Session& session) {
    if (session.relit) return session.relit->tonemapInput;
    return session.scene ? session.scene->tonemapInput : session.targets.tonemapInput;
}

void recreateFrames(const Context& context, Session& session, VkExtent2D extent) {
    recreateSwapchain(context, session.frames, extent);
    sizePictureTargets(context, session);
}

// Draws until the window closes or the requested frames are shown; returns the frames shown.
int runFrames(const Context& context, const ViewerOptions& options, GLFWwindow* window, Session& session,
              InputEvents& events) {
    const std::vector<int>& script = options.keys;
    int shown = 0;
    std::string title;
    while (!glfwWindowShouldClose(window) && (options.frames <= 0 || shown < options.frames)) {
        glfwPollEvents();
        if (size_t(shown) < script.size()) events.keys.push_back(script[size_t(shown)]);
        applyInput(context, window, session, events);
        updateTitle(window, session, title);
        VkExtent2D extent = framebufferExtent(window);
        if (extent.width == 0 || extent.height == 0) { // minimized
            glfwWaitEvents();
            continue;
        }
        if (extent.width != session.frames.swapchain.extent.width ||
            extent.height != session.frames.swapchain.extent.height)
            recreateFrames(context, session, extent);
        bool last = options.frames > 0 && shown + 1 == options.frames;
        FrameRequest request;
        request.recordPicture = [&](VkCommandBuffer commands) { recordPicture(context, commands, session); };
        request.tonemapInput = tonemapInput(session);
        request.exposure = session.autoExposure * std::exp2(session.view.exposureStops);
        request.capture = last && !options.screenshot.empty();
        FrameResult result = drawFrame(context, session.frames, request);
        if (result != FrameResult::NotDrawn) ++shown;
        if (result != FrameResult::Presented) recreateFrames(context, session, extent);
    }
    return shown;
}

void saveScreenshot(const Context& context, const ViewerOptions& options, const Session& session, int shown) {
    if (options.screenshot.empty() || shown < options.frames) return;
    VkExtent2D extent = session.frames.swapchain.extent;
    writeSrgbImage(options.screenshot, int(extent.width), int(extent.height),
                   readCapture(context, session.frames));
    std::printf("shprobe view: frame %d (%ux%u) saved to %s\n", shown, extent.width, extent.height,
                options.screenshot.c_str());
}

void runSession(const Context& context, const ViewerOptions& options, GLFWwindow* window,
                InputEvents& events) {
    Session session;
    ScopeExit end([&] { endSession(context, session); });
    startSession(context, options, window, session);
    std::printf("%s\n", sessionSummary(session).c_str());
    if (session.relit)
        std::printf("keys: Left/Right or J/L turn the light about +Y, Up/Down or I/K about +X, +/- exposure, "
                    "R reset, Esc quit; drag to orbit, scroll to zoom\n");
    else if (session.scene)
        std::printf("keys: P probes, +/- exposure, R reset, Esc quit; drag to orbit, scroll to zoom\n");
    else
        std::printf("keys: 3/5 order, M mode, B background, Left/Right rotate environment, +/- exposure, "
                    "R reset, Esc quit; drag to orbit, scroll to zoom\n");
    int shown = runFrames(context, options, window, session, events);
    saveScreenshot(context, options, session, shown);
}

} // namespace

std::vector<int> scriptedKeys(const std::vector<std::string>& names) {
    static const std::pair<const char*, int> kKeys[] = {
        {"3", GLFW_KEY_3},       {"5", GLFW_KEY_5},         {"m", GLFW_KEY_M},   {"b", GLFW_KEY_B},
        {"left", GLFW_KEY_LEFT}, {"right", GLFW_KEY_RIGHT}, {"up", GLFW_KEY_UP}, {"down", GLFW_KEY_DOWN},
        {"j", GLFW_KEY_J},       {"l", GLFW_KEY_L},         {"i", GLFW_KEY_I},   {"k", GLFW_KEY_K},
        {"+", GLFW_KEY_EQUAL},   {"-", GLFW_KEY_MINUS},     {"r", GLFW_KEY_R},   {"q", GLFW_KEY_Q},
        {"p", GLFW_KEY_P}};
    std::vector<int> keys;
    for (const std::string& name : names) {
        auto found = std::find_if(std::begin(kKeys), std::end(kKeys),
                                  [&](const auto& key) { return name == key.first; });
        if (found == std::end(kKeys))
            throw Error(ErrorKind::Input,
                        "unknown key '" + name +
                            "' (3, 5, m, b, left, right, up, down, j, l, i, k, +, -, r, q, p)");
        keys.push_back(found->second);
    }
    return keys;
}

void checkViewerOptions(const ViewerOptions& options) {
    if (options.frames <= 0 && !options.screenshot.empty())
        throw Error(ErrorKind::Input, "--screenshot needs --frames N (the frame to save)");
    if (!options.screenshot.empty()) checkRenderOutputPath(options.screenshot);
}

void runViewer(const ViewerOptions& options) {
    checkViewerOptions(options);
    InputEvents events;
    GLFWwindow* window = openWindow(options, events);
    ScopeExit close([&] { closeWindow(window); }); // after the context, whose surface is the window's
    Context context = createContext(viewerContextOptions(options, window));
    ScopeExit release([&] { destroyContext(context); });
    runSession(context, options, window, events);
    if (uint32_t messages = context.validationMessages(); messages > 0)
        throw Error(ErrorKind::Device, counted(messages, "Vulkan validation message") + " (above)");
}

} // namespace shprobe
