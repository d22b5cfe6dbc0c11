// `shprobe render --scene OUT.glb --transfer` end to end, as child processes on lavapipe with the
// validation layer on (SHPROBE_VALIDATION=1 from ctest: any message fails the run):
//   - the pixels of an outward box, its unshadowed transfer written by `shprobe transfer`, equal
//     the CPU's L_out = sum_i T_i L_i at the face each pixel's ray meets, linear (EXR) and
//     tonemapped (PNG), at order 3 (relight.vert) and order 5 (relight_wide.vert);
//   - the light turned by 90 degrees on the device equals the light turned on the CPU (`shprobe
//     rotate`) and relit unturned, from a probe and from a sky;
//   - refusals: a scene without transfer, more attributes than the device has, an irradiance
//     probe, a light past float, a bad turn, light options without --transfer.
#include "render/lit_scene.h"
#include "render/probe_shading.h"
#include "run_program.h"
#include "scene/transfer_mesh.h"
#include "scene_fixtures.h"
#include "test_inputs.h"

#include <OpenImageIO/imageio.h>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <glm/geometric.hpp>
#include <gtest/gtest.h>

namespace shprobe::testing {
namespace {

namespace fs = std::filesystem;

#define EXPECT_CONTAINS(text, part) EXPECT_NE((text).find(part), std::string::npos) << "in: " << (text)

// Pixels as floats (EXR: linear; PNG: 0..255), rows top down.
struct Pixels {
    int width = 0, height = 0, channels = 0;
    std::vector<float> values;
    glm::vec3 at(int x, int y) const {
        const float* p = &values[(size_t(y) * width + x) * channels];
        return {p[0], p[1], p[2]};
    }
};

Pixels readPixels(const std::string& path) {
    std::unique_ptr<OIIO::ImageInput> input = OIIO::ImageInput::open(path);
    if (!input) return {};
    const OIIO::ImageSpec& spec = input->spec();
    Pixels pixels{spec.width, spec.height, spec.nchannels, {}};
    pixels.values.resize(size_t(spec.width) * spec.height * spec.nchannels);
    const bool bytes = spec.format == OIIO::TypeDesc::UINT8;
    if (bytes) {
        std::vector<uint8_t> raw(pixels.values.size());
        input->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::UINT8, raw.data());
        std::copy(raw.begin(), raw.end(), pixels.values.begin());
    } else {
        input->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, pixels.values.data());
    }
    return pixels;
}

// tonemap.frag on the CPU: exposure, ACES filmic fit, sRGB encoding, 8 bits.
glm::vec3 tonemapped(glm::vec3 linear, float exposure) {
    glm::vec3 out;
    for (int c = 0; c < 3; ++c) {
        const double x = std::max(double(linear[c]) * exposure, 0.0);
        const double mapped = std::clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
        const double srgb =
            mapped <= 0.0031308 ? 12.92 * mapped : 1.055 * std::pow(mapped, 1.0 / 2.4) - 0.055;
        out[c] = float(std::round(srgb * 255.0));
    }
    return out;
}

// The first face of the axis-aligned box [lo, hi] the ray from `eye` along `d` meets, with how far
// inside the face (0 at an edge, 0.5 at the centre, in units of the face's sides) the hit is.
struct BoxHit {
    glm::dvec3 normal{0.0};
    double inside = 0.0;
};
std::optional<BoxHit> hitBox(glm::dvec3 eye, glm::dvec3 d, glm::dvec3 lo, glm::dvec3 hi) {
    double nearest = INFINITY;
    std::optional<BoxHit> hit;
    for (int axis = 0; axis < 3; ++axis)
        for (int side = 0; side < 2; ++side) {
            const double plane = side ? hi[axis] : lo[axis];
            if (d[axis] == 0.0) continue;
            const double t = (plane - eye[axis]) / d[axis];
            if (t <= 0.0 || t >= nearest) continue;
            const glm::dvec3 p = eye + t * d;
            double inside = 0.5;
            bool within = true;
            for (int other = 0; other < 3; ++other) {
                if (other == axis) continue;
                const double u = (p[other] - lo[other]) / (hi[other] - lo[other]);
                within = within && u >= 0.0 && u <= 1.0;
                inside = std::min({inside, u, 1.0 - u});
            }
            if (!within) continue;
            nearest = t;
            BoxHit h;
            h.normal[axis] = side ? 1.0 : -1.0;
            h.inside = inside;
            hit = h;
        }
    return hit;
}

// L_out of the mesh's vertices whose transfer belongs to a face of normal n: the box's faces have
// their own vertices, all of one transfer (unshadowed, one normal, one albedo).
glm::dvec3 faceRadiance(const TransferMesh& mesh, glm::dvec3 n, const ShCoefficients& light) {
    const World& world = mesh.world;
    for (size_t v = 0; v < world.positions.size(); ++v) {
        if (glm::length(glm::dvec3(world.normals[v]) - n) > 1e-4) continue;
        const float* t = &mesh.transfer[v * size_t(mesh.attributes) * 4];
        glm::dvec3 sum(0.0);
        for (size_t i = 0; i < light.rgb.size(); ++i)
            for (int c = 0; c < 3; ++c)
                sum[c] += double(t[mesh.channels == 3 ? 3 * i + c : i]) * light.rgb[i][c];
        return sum;
    }
    ADD_FAILURE() << "no vertex of normal " << n.x << " " << n.y << " " << n.z;
    return glm::dvec3(0.0);
}

class RenderTransfer : public ::testing::Test {
  protected:
    TemporaryFolder folder{"shprobe_render_transfer"};
    RunResult run(const std::vector<std::string>& args) { return runProgram(args, folder.path() / "logs"); }
    std::string file(const std::string& name) const { return folder.path() / name; }

    // An outward box of a coloured albedo (RGB transfer), its transfer at `order` in `name`.
    std::string transferBox(const std::string& name, int order, const std::string& model = "unshadowed") {
        writeBoxGltf(file("source.glb"),
                     {.size = {1.0f, 0.8f, 1.2f}, .albedo = {0.8f, 0.6f, 0.4f}, .inwardFacing = false});
        RunResult made = run({"transfer", file("source.glb"), "--model", model, "--order",
                              std::to_string(order), "-o", file(name)});
        EXPECT_EQ(made.exitCode, 0) << describe(made);
        return file(name);
    }
    // Exit code 2, one line naming every part, no output.
    void expectRefused(const std::vector<std::string>& args, const std::vector<std::string>& parts,
                       const std::string& output) {
        RunResult result = run(args);
        EXPECT_EQ(result.exitCode, 2) << describe(result);
        EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1) << describe(result);
        for (const std::string& part : parts)
            EXPECT_CONTAINS(result.err, part);
        EXPECT_FALSE(fs::exists(output)) << output;
    }
};

// Every pixel whose ray meets a face at least 3% of its side inside its edges (so that no pixel
// is shared by two faces or by a face and the background) equals the CPU sum. Tolerance: the GPU
// sums n^2 float products of numbers of size ~1 (relative rounding ~n^2 * 6e-8) and interpolates
// equal values across the face: 1e-5 of the light's L00 covers it a hundred times over. PNG: the
// CPU tonemap of the CPU sum within one 8-bit level (the hardware sRGB encoding rounds its own way).
TEST_F(RenderTransfer, PixelsEqualTheCpuSumOfTransferTimesLight) {
    for (int order : {3, 5}) {
        SCOPED_TRACE("order " + std::to_string(order));
        const std::string scene = transferBox("box_" + std::to_string(order) + ".glb", order);
        const ShCoefficients light = testProbe(order);
        writeProbeFile(file("light.json"), light, {});
        const std::vector<std::string> view{"--yaw", "30", "--pitch", "35", "--size", "64x48"};
        for (const char* output : {"relit.exr", "relit.png"}) {
            std::vector<std::string> args{"render",  "--scene",          scene, "--transfer",
                                          "--probe", file("light.json"), "-o",  file(output)};
            args.insert(args.end(), view.begin(), view.end());
            RunResult result = run(args);
            ASSERT_EQ(result.exitCode, 0) << describe(result);
            EXPECT_CONTAINS(result.out, "transfer order " + std::to_string(order) + ", RGB");
        }
        const Pixels linear = readPixels(file("relit.exr"));
        const Pixels display = readPixels(file("relit.png"));
        ASSERT_EQ(linear.width, 64);
        ASSERT_EQ(display.height, 48);
        const TransferMesh mesh = loadTransferMesh(scene);
        const SceneCamera camera = orbitSceneCamera(mesh.world, 30.0f, 35.0f);
        const glm::dvec3 forward = glm::normalize(camera.target - camera.eye);
        const glm::dvec3 right = glm::normalize(glm::cross(forward, camera.up));
        const glm::dvec3 down = glm::cross(forward, right);
        const double f = 1.0 / std::tan(camera.verticalFovDegrees * M_PI / 360.0), aspect = 64.0 / 48.0;
        const float exposure = autoExposure(light);
        const double tolerance = 1e-5 * light.rgb[0].x;
        int faces = 0, background = 0;
        for (int y = 0; y < 48; ++y)
            for (int x = 0; x < 64; ++x) {
                const double u = 2.0 * (x + 0.5) / 64.0 - 1.0, v = 2.0 * (y + 0.5) / 48.0 - 1.0;
                const glm::dvec3 d = forward + right * (u * aspect / f) + down * (v / f);
                const auto hit = hitBox(camera.eye, d, mesh.world.boundsMin, mesh.world.boundsMax);
                glm::dvec3 expected(0.0);
                if (hit && hit->inside < 0.03) continue;
                if (hit) expected = faceRadiance(mesh, hit->normal, light);
                (hit ? faces : background)++;
                const glm::vec3 got = linear.at(x, y);
                for (int c = 0; c < 3; ++c)
                    ASSERT_NEAR(got[c], expected[c], tolerance)
                        << "pixel " << x << ", " << y << " channel " << c;
                const glm::vec3 want = tonemapped(glm::vec3(expected), exposure), shown = display.at(x, y);
                for (int c = 0; c < 3; ++c)
                    ASSERT_NEAR(shown[c], want[c], 1.0) << "pixel " << x << ", " << y << " channel " << c;
            }
        EXPECT_GT(faces, 600) << "the box fills much of the picture";
        EXPECT_GT(background, 300);
    }
}

// Turning the light by 90 degrees about +Y on the device (rotate.comp) equals turning its
// coefficients on the CPU (`shprobe rotate`, double precision) and relighting unturned. Tolerance:
// the GPU rotation is float (about 1e-6 of the coefficients' size); 1e-5 of L00 covers it. From a
// sky, the same after the sky is baked: --sky bakes it on the device at the transfer's order, and
// `shprobe bake` of the same image gives the coefficients turned on the CPU.
TEST_F(RenderTransfer, LightTurnedOnTheDeviceEqualsLightTurnedOnTheCpu) {
    const std::string scene = transferBox("box.glb", 3);
    const ShCoefficients light = testProbe(3);
    writeProbeFile(file("light.json"), light, {});
    writeTestEnvironment(file("sky.exr"));
    // The sky as --sky bakes it: on the device, at the equirect's own face size (width / 4).
    RunResult baked = run({"bake", file("sky.exr"), "--order", "3", "--backend", "gpu", "--face-size", "16",
                           "-o", file("sky.json")});
    ASSERT_EQ(baked.exitCode, 0) << describe(baked);
    for (const char* name : {"light", "sky"}) {
        RunResult turned = run({"rotate", file(std::string(name) + ".json"), "--matrix", "0,0,1,0,1,0,-1,0,0",
                                "-o", file(std::string(name) + "_turned.json")});
        ASSERT_EQ(turned.exitCode, 0) << describe(turned);
    }
    const std::vector<std::string> base{"render",  "--scene", scene,    "--transfer",
                                        "--pitch", "35",      "--size", "48"};
    auto render = [&](const std::string& output, std::vector<std::string> lightOptions) {
        std::vector<std::string> args = base;
        args.insert(args.end(), lightOptions.begin(), lightOptions.end());
        args.insert(args.end(), {"-o", file(output)});
        RunResult result = run(args);
        EXPECT_EQ(result.exitCode, 0) << describe(result);
        return readPixels(file(output));
    };
    const Pixels device = render("device.exr", {"--probe", file("light.json"), "--light-yaw", "90"});
    const Pixels cpu = render("cpu.exr", {"--probe", file("light_turned.json")});
    const Pixels unturned = render("unturned.exr", {"--probe", file("light.json")});
    const Pixels skyDevice = render("sky_device.exr", {"--sky", file("sky.exr"), "--light-yaw", "90"});
    const Pixels skyCpu = render("sky_cpu.exr", {"--probe", file("sky_turned.json")});
    ASSERT_EQ(device.values.size(), cpu.values.size());
    ASSERT_EQ(skyDevice.values.size(), skyCpu.values.size());
    double largest = 0.0, skyLargest = 0.0, skyMean = 0.0, turn = 0.0;
    for (size_t i = 0; i < device.values.size(); ++i) {
        turn = std::max(turn, double(std::abs(device.values[i] - unturned.values[i])));
        largest = std::max(largest, double(std::abs(device.values[i] - cpu.values[i])));
        skyLargest = std::max(skyLargest, double(std::abs(skyDevice.values[i] - skyCpu.values[i])));
        skyMean += std::abs(double(skyCpu.values[i])) / double(skyCpu.values.size());
    }
    EXPECT_GT(turn, 0.02 * light.rgb[0].x) << "the turn shows";
    EXPECT_LT(largest, 1e-5 * light.rgb[0].x);
    EXPECT_LT(skyLargest, 1e-4 * skyMean) << "sky mean " << skyMean;
    std::printf(
        "light turned on the device vs the CPU: largest difference %.3g (probe), %.3g of the mean (sky)\n",
        largest, skyLargest / skyMean);

    // A turn whose band matrices are not 0 and 1 only: R = Ry(90) Rx(30).
    RunResult turned =
        run({"rotate", file("light.json"), "--matrix",
             "0,0.5,0.8660254037844386,0,0.8660254037844386,-0.5,-1,0,0", "-o", file("both.json")});
    ASSERT_EQ(turned.exitCode, 0) << describe(turned);
    const Pixels both =
        render("both.exr", {"--probe", file("light.json"), "--light-yaw", "90", "--light-pitch", "30"});
    const Pixels bothCpu = render("both_cpu.exr", {"--probe", file("both.json")});
    double bothLargest = 0.0;
    for (size_t i = 0; i < both.values.size(); ++i)
        bothLargest = std::max(bothLargest, double(std::abs(both.values[i] - bothCpu.values[i])));
    EXPECT_LT(bothLargest, 1e-5 * light.rgb[0].x);
    std::printf("yaw 90, pitch 30: largest difference %.3g (L00 %.1f)\n", bothLargest, light.rgb[0].x);
}

TEST_F(RenderTransfer, RefusesScenesWithoutTransferTooManyAttributesAndBadTurns) {
    writeBoxGltf(file("plain.glb"), {.inwardFacing = false});
    expectRefused({"render", "--scene", file("plain.glb"), "--transfer", "-o", file("a.png")},
                  {"plain.glb", "no per-vertex transfer"}, file("a.png"));
    // Order 7 RGB: 147 floats, 37 attributes; lavapipe has 32 (31 beside the position).
    const std::string wide = transferBox("order7.glb", 7);
    expectRefused({"render", "--scene", wide, "--transfer", "-o", file("b.png")},
                  {"order 7 RGB transfer needs 37 vertex attributes", "maxVertexInputAttributes"},
                  file("b.png"));
    const std::string scene = transferBox("box.glb", 3);
    writeProbeFile(file("irradiance.json"), testProbe(3, Quantity::Irradiance), {});
    expectRefused(
        {"render", "--scene", scene, "--transfer", "--probe", file("irradiance.json"), "-o", file("f.png")},
        {"irradiance.json", "holds irradiance"}, file("f.png"));
    // A light the device's float relighting cannot hold would draw infinity.
    ShCoefficients blinding = testProbe(3);
    blinding.rgb[0] = glm::dvec3(1e38);
    writeProbeFile(file("blinding.json"), blinding, {});
    expectRefused(
        {"render", "--scene", scene, "--transfer", "--probe", file("blinding.json"), "-o", file("g.png")},
        {"blinding.json", "its light is past the float range the shaders take"}, file("g.png"));
    expectRefused({"render", "--scene", scene, "--transfer", "--light-yaw", "400", "-o", file("c.png")},
                  {"--light-yaw"}, file("c.png"));
    expectRefused({"render", "--scene", scene, "--light-yaw", "10", "-o", file("d.png")}, {"--transfer"},
                  file("d.png"));
    expectRefused({"render", "--scene", scene, "--transfer", "--volume", "v.shpv", "-o", file("e.png")},
                  {"--volume"}, file("e.png"));
}

// A transfer file damaged after `shprobe transfer` wrote it: a coefficient that is NaN or infinite
// (the device would draw it), a padding float that is not zero, and a header that does not describe
// the attributes (another format, version or convention, channels or names that make another count)
// are each refused in one line naming the file, before any device work.
TEST_F(RenderTransfer, RefusesDamagedTransferFiles) {
    const Glb written = readGlb(readText(transferBox("box.glb", 3))); // RGB: 27 floats, 7 attributes
    const nlohmann::json& attributes = written.json["meshes"][0]["primitives"][0]["attributes"];
    // The file `name`: the written one, `edit`ed.
    auto damaged = [&](const std::string& name, const std::function<void(Glb&)>& edit) {
        Glb glb = written;
        edit(glb);
        writeText(file(name), glbOf(glb));
        return file(name);
    };
    // Float `component` of `vertex` in attribute `name` set to `value`.
    auto setFloat = [&](const std::string& name, size_t vertex, size_t component, float value) {
        return [&, name, vertex, component, value](Glb& glb) {
            const nlohmann::json& accessor = glb.json["accessors"][attributes[name].get<size_t>()];
            const nlohmann::json& view = glb.json["bufferViews"][accessor["bufferView"].get<size_t>()];
            const size_t at = view.value("byteOffset", size_t(0)) + accessor.value("byteOffset", size_t(0)) +
                              (vertex * 4 + component) * sizeof(float);
            std::memcpy(&glb.bin[at], &value, sizeof(float));
        };
    };
    auto setHeader = [](const std::string& key, nlohmann::json value) {
        return [key, value](Glb& glb) { glb.json["asset"]["extras"]["shTransfer"][key] = value; };
    };
    const std::vector<std::pair<std::string, std::vector<std::string>>> cases{
        {damaged("nan.glb", setFloat("_SH_TRANSFER_0", 0, 0, NAN)),
         {"nan.glb", "mesh 0 primitive 0's _SH_TRANSFER_0 holds nan at vertex 0", "must be finite"}},
        {damaged("inf.glb", setFloat("_SH_TRANSFER_3", 2, 1, -INFINITY)),
         {"inf.glb", "_SH_TRANSFER_3 holds -inf at vertex 2"}},
        {damaged("padding.glb", setFloat("_SH_TRANSFER_6", 1, 3, 1.0f)),
         {"padding.glb", "_SH_TRANSFER_6 holds 1 at vertex 1 past the 27 floats"}},
        {damaged("format.glb", setHeader("format", "other.transfer")),
         {"format.glb", "\"format\" is not \"shprobe.transfer\""}},
        {damaged("version.glb", setHeader("version", 2)), {"version.glb", "version 2", "reads 1"}},
        {damaged("convention.glb", setHeader("convention", "real-orthonormal")),
         {"convention.glb", "\"convention\" is not"}},
        {damaged("names.glb", setHeader("channels", 1)),
         {"names.glb", "\"attributes\" is not _SH_TRANSFER_0..2"}},
        {damaged("count.glb",
                 [&](Glb& glb) {
                     setHeader("channels", 1)(glb);
                     setHeader("attributes", {"_SH_TRANSFER_0", "_SH_TRANSFER_1", "_SH_TRANSFER_2"})(glb);
                 }),
         {"count.glb", "has 7 _SH_TRANSFER_ attributes", "order 3 and channels 1 make 3"}},
    };
    for (const auto& [scene, parts] : cases) {
        SCOPED_TRACE(scene);
        expectRefused({"render", "--scene", scene, "--transfer", "-o", file("out.png")}, parts,
                      file("out.png"));
    }
}

// A transfer baked from a model that holds one already (order 3, RGB: 7 attributes) at order 1
// (one attribute) replaces it: the file holds its own count and renders.
TEST_F(RenderTransfer, ATransferOfATransferKeepsOnlyItsOwnAttributes) {
    const std::string first = transferBox("order3.glb", 3);
    RunResult again = run({"transfer", first, "--order", "1", "-o", file("order1.glb")});
    ASSERT_EQ(again.exitCode, 0) << describe(again);
    const Glb written = readGlb(readText(file("order1.glb")));
    for (const auto& primitive : written.json["meshes"][0]["primitives"]) {
        size_t transferAttributes = 0;
        for (const auto& [name, accessor] : primitive["attributes"].items())
            transferAttributes += name.starts_with("_SH_TRANSFER_") ? 1 : 0;
        EXPECT_EQ(transferAttributes, 1u);
    }
    RunResult rendered =
        run({"render", "--scene", file("order1.glb"), "--transfer", "--size", "32", "-o", file("out.png")});
    EXPECT_EQ(rendered.exitCode, 0) << describe(rendered);
}

} // namespace
} // namespace shprobe::testing
