// The engine exports (formats/engine_export.h, docs/exports.md) checked by the engines' own code where
// it runs here (three.js, Babylon.js, the Khronos glTF validator: tests/engines/*.mjs under node,
// with the npm packages scripts/test.sh installs into BUILD/npm) and by the engines' published
// shader formulas, transcribed below with their source, where it does not (Filament, Unity, Godot).
// Each evaluates the exported file at 1,000 directions mapped through the documented frame
// (F d, engineFrame) and must equal shprobe's own evaluation at d. Without node or the packages the
// JS checks are skipped with a message (ctest shows them as skipped), never passed.
// docs/exports.md's loader snippets are checked here too, read out of the docs (tests/engines/common.mjs
// for the JS ones, which threejs.mjs and babylon.mjs load the files through; CMake copies the others
// into BUILD/snippets): see "docs/exports.md's loader snippets" below.
#include "formats/engine_export.h"
#include "formats/probe_file.h"
#include "render/run_program.h"
#include "sh/basis.h"
#include "sh/irradiance.h"
#include "sh/lights.h"
#include "sh/rotation.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <numbers>
#include <regex>
#include <spawn.h>
#include <sstream>
#include <sys/wait.h>

// docs/exports.md's Filament snippet, compiled against tests/engines/filament_stub: it defines
// loadShprobeLight.
#include "filament.cpp"

// docs/exports.md's Godot shader include, which is GLSL, compiled as C++: GLSL's vec3 as GLM's,
// its float as double (the precision of the transcriptions here; only the arithmetic is checked).
namespace godot_snippet {
using vec3 = glm::dvec3;
#define float double
#include "godot-include.glsl"
#undef float
} // namespace godot_snippet

namespace shprobe {
namespace {
namespace fs = std::filesystem;
using testing::readText;

// Engine evaluation vs ours, relative to the probe's scale (the largest |value| over the directions
// and channels): the engines compute in double (JS) from the shortest round-trip decimals we write,
// so 1e-6 leaves room only for their own rounded constants (three.js and Godot print 6 digits).
constexpr double kEngineTolerance = 1e-6;
constexpr int kDirectionCount = 1000;

// A probe with every band of order 3 in it, bright upward, and a band 3 the exports drop.
ShCoefficients testProbe() {
    ShCoefficients probe = makeCoefficients(4, Quantity::Radiance);
    addAmbient(probe, {0.6, 0.5, 0.4});
    addDirectionalLight(probe, {glm::normalize(glm::dvec3(0.3, 0.8, -0.5)), {2.0, 1.5, 1.0}});
    addSphericalLight(probe, {glm::normalize(glm::dvec3(-0.7, 0.2, 0.4)), 0.3, {1.0, 2.0, 3.0}});
    return probe;
}

// The probe as its file holds it (probe.json: the numbers as probeToJson prints them).
ShCoefficients writtenProbe() {
    static const ShCoefficients probe = parseProbeJson(probeToJson(testProbe(), {}), "test probe");
    return probe;
}

ShCoefficients bandsUpTo2(const ShCoefficients& probe) {
    ShCoefficients bands = makeCoefficients(3, probe.quantity);
    std::copy_n(probe.rgb.begin(), 9, bands.rgb.begin());
    return bands;
}

// Fibonacci-sphere directions: even, deterministic, every octant.
std::vector<glm::dvec3> testDirections() {
    std::vector<glm::dvec3> directions;
    const double golden = std::numbers::pi * (3.0 - std::sqrt(5.0));
    for (int k = 0; k < kDirectionCount; ++k) {
        const double y = 1.0 - 2.0 * (k + 0.5) / kDirectionCount, r = std::sqrt(1.0 - y * y);
        directions.push_back({r * std::cos(golden * k), y, r * std::sin(golden * k)});
    }
    return directions;
}

struct Comparison {
    double worst = 0.0; // largest |engine - ours| / scale
    std::string where;
};

// values[k] is the engine's at F d_k, expected(d_k) ours.
Comparison compare(const std::vector<glm::dvec3>& values,
                   const std::function<glm::dvec3(glm::dvec3)>& expected) {
    const std::vector<glm::dvec3> directions = testDirections();
    double scale = 0.0;
    for (const glm::dvec3& d : directions)
        for (int c = 0; c < 3; ++c)
            scale = std::max(scale, std::abs(expected(d)[c]));
    Comparison result;
    for (size_t k = 0; k < directions.size(); ++k) {
        for (int c = 0; c < 3; ++c) {
            double error = std::abs(values[k][c] - expected(directions[k])[c]) / scale;
            if (error > result.worst)
                result = {error, "direction " + std::to_string(k) + " channel " + std::to_string(c)};
        }
    }
    return result;
}

glm::dvec3 radianceAt(glm::dvec3 d) {
    return evaluate(bandsUpTo2(writtenProbe()), d);
}
glm::dvec3 irradianceAt(glm::dvec3 d) {
    return evaluate(convolveIrradiance(bandsUpTo2(writtenProbe())), d);
}
glm::dvec3 irradianceOverPiAt(glm::dvec3 d) {
    return irradianceAt(d) / std::numbers::pi;
}

class EngineExports : public ::testing::Test {
  protected:
    void SetUp() override {
        folder_ = fs::temp_directory_path() / ("shprobe_engine_exports_" + std::to_string(getpid()));
        fs::remove_all(folder_);
        fs::create_directories(folder_);
        writeProbeFile(path("probe.json"), testProbe(), {});
    }
    void TearDown() override { fs::remove_all(folder_); }

    std::string path(const std::string& name) const { return (folder_ / name).string(); }

    // `shprobe convert probe.json -o NAME [args]`; the file's path.
    std::string convert(const std::string& name, const std::vector<std::string>& args = {}) {
        std::vector<std::string> all{"convert", path("probe.json"), "-o", path(name)};
        all.insert(all.end(), args.begin(), args.end());
        testing::RunResult run = testing::runProgram(all, folder_ / "logs");
        EXPECT_EQ(run.exitCode, 0) << testing::describe(run);
        return path(name);
    }

    // The directions F d, one "x y z" a line.
    std::string directionsFile(Engine engine, bool mirror = true) {
        std::ofstream out(path("directions.txt"));
        out.precision(17);
        for (const glm::dvec3& d : testDirections()) {
            glm::dvec3 e = engineFrame(engine, mirror) * d;
            out << e.x << ' ' << e.y << ' ' << e.z << '\n';
        }
        return path("directions.txt");
    }

    fs::path folder_;
};

// ---- node -------------------------------------------------------------------------------------

std::string modulesFolder() {
    const char* override = std::getenv("SHPROBE_NODE_MODULES");
    return override ? override : SHPROBE_NODE_MODULES;
}

// The reason the JS checks cannot run here, or empty.
std::string nodeMissing() {
    if (std::system("node --version > /dev/null 2>&1") != 0) return "node is not installed";
    for (const char* package : {"three", "@babylonjs/core", "gltf-validator"})
        if (!fs::exists(fs::path(modulesFolder()) / package))
            return std::string(package) + " is not in " + modulesFolder() +
                   " (npm install failed or was not run)";
    return "";
}

#define SKIP_WITHOUT_NODE()                                                                                  \
    do {                                                                                                     \
        std::string missing = nodeMissing();                                                                 \
        if (!missing.empty()) GTEST_SKIP() << "engine check skipped: " << missing;                           \
    } while (0)

// Runs ARGS (no shell; ARGS[0] found on the PATH) in FOLDER's files NAME.out and NAME.err; the test
// fails unless it exits 0. Its stdout.
std::string runTool(const std::vector<std::string>& args, const fs::path& folder, const std::string& name,
                    const testing::EnvironmentChanges& changes = {}) {
    const fs::path out = folder / (name + ".out"), err = folder / (name + ".err");
    std::vector<std::string> arguments = args, env = testing::changedEnvironment(changes);
    std::vector<char*> argv = testing::pointersTo(arguments), envp = testing::pointersTo(env);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_addopen(&actions, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    pid_t pid = 0;
    int status = -1;
    if (posix_spawnp(&pid, argv[0], &actions, nullptr, argv.data(), envp.data()) == 0)
        waitpid(pid, &status, 0);
    posix_spawn_file_actions_destroy(&actions);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0)
        << name << ": " << readText(err) << readText(out);
    return readText(out);
}

// Runs `node tests/engines/SCRIPT FILE DIRECTIONS` and parses its JSON line.
nlohmann::json runNode(const std::string& script, const std::string& file, const std::string& directions,
                       const fs::path& folder) {
    std::string out = runTool({"node", std::string(SHPROBE_ENGINE_SCRIPTS) + "/" + script, file, directions},
                              folder, script, {{"SHPROBE_NODE_MODULES", modulesFolder()}});
    return nlohmann::json::parse(out, nullptr, false);
}

std::vector<glm::dvec3> vectors(const nlohmann::json& rows) {
    std::vector<glm::dvec3> values;
    for (const nlohmann::json& row : rows)
        values.push_back({row[0].get<double>(), row[1].get<double>(), row[2].get<double>()});
    return values;
}

void expectWithin(const Comparison& comparison, double tolerance, const std::string& what) {
    EXPECT_LT(comparison.worst, tolerance) << what << " at " << comparison.where;
    std::printf("  %s: worst difference %.3g of the probe's scale\n", what.c_str(), comparison.worst);
}

TEST_F(EngineExports, ThreeJsLightProbeEvaluatesToOurs) {
    SKIP_WITHOUT_NODE();
    nlohmann::json result =
        runNode("threejs.mjs", convert("probe.three.json"), directionsFile(Engine::ThreeJs), folder_);
    ASSERT_FALSE(result.is_discarded());
    // three.js's 6-digit constants (getAt's 0.315392 is 1.4e-6 off sqrt(5/16pi), getIrradianceAt's
    // 2 x 0.511664 1.3e-6 off 2pi/3 sqrt(3/4pi)) are what limits the agreement.
    expectWithin(compare(vectors(result["radiance"]), radianceAt), kEngineTolerance, "three.js getAt");
    expectWithin(compare(vectors(result["irradiance"]), irradianceAt), kEngineTolerance,
                 "three.js getIrradianceAt");
}

TEST_F(EngineExports, BabylonHarmonicsEvaluateToOurs) {
    SKIP_WITHOUT_NODE();
    nlohmann::json result =
        runNode("babylon.mjs", convert("probe.babylon.json"), directionsFile(Engine::Babylon), folder_);
    ASSERT_FALSE(result.is_discarded());
    expectWithin(compare(vectors(result["irradianceOverPi"]), irradianceOverPiAt), kEngineTolerance,
                 "Babylon.js computeEnvironmentIrradiance");
}

// The specular chain as gltf.mjs read it: log2(size / 16) + 1 mips of 6 square faces, halving from
// specularImageSize down to 16.
void expectSpecularChain(const nlohmann::json& result, int size) {
    ASSERT_EQ(result["specularImageSize"].get<int>(), size);
    const nlohmann::json& mips = result["specularMips"];
    ASSERT_EQ(int(mips.size()), int(std::log2(size / 16)) + 1);
    for (size_t mip = 0; mip < mips.size(); ++mip) {
        ASSERT_EQ(mips[mip].size(), 6u) << "mip " << mip;
        for (const nlohmann::json& face : mips[mip])
            EXPECT_EQ(face, nlohmann::json::array({size >> mip, size >> mip})) << "mip " << mip;
    }
    EXPECT_EQ(size >> (mips.size() - 1), 16);
}

TEST_F(EngineExports, GltfPassesTheValidatorAndEvaluatesToOurs) {
    SKIP_WITHOUT_NODE();
    nlohmann::json result = runNode("gltf.mjs", convert("probe.gltf"), directionsFile(Engine::Gltf), folder_);
    ASSERT_FALSE(result.is_discarded());
    EXPECT_EQ(result["numErrors"].get<int>(), 0) << result["messages"].dump(2);
    EXPECT_EQ(result["numWarnings"].get<int>(), 0) << result["messages"].dump(2);
    expectWithin(compare(vectors(result["irradianceOverPi"]), irradianceOverPiAt), kEngineTolerance,
                 "glTF through Babylon's loader");
    expectSpecularChain(result, 128);
}

// bake's glTF, its specular chain prefiltered from the environment with the lights drawn in, at
// another size: valid too.
TEST_F(EngineExports, GltfFromBakePassesTheValidator) {
    SKIP_WITHOUT_NODE();
    testing::RunResult run = testing::runProgram({"bake", "--face-size", "32", "--backend", "cpu", "-q",
                                                  "--ambient", "0.1,0.1,0.1", "--sphere", "0,1,0", "10",
                                                  "5,5,5", "--map-size", "64", "-o", path("bake.gltf")},
                                                 folder_ / "logs");
    ASSERT_EQ(run.exitCode, 0) << testing::describe(run);
    nlohmann::json result = runNode("gltf.mjs", path("bake.gltf"), directionsFile(Engine::Gltf), folder_);
    ASSERT_FALSE(result.is_discarded());
    EXPECT_EQ(result["numErrors"].get<int>(), 0) << result["messages"].dump(2);
    EXPECT_EQ(result["numWarnings"].get<int>(), 0) << result["messages"].dump(2);
    expectSpecularChain(result, 64);
}

// ---- Published shader formulas ----------------------------------------------------------------

// Every number in the text, in order.
std::vector<double> numbersIn(const std::string& text) {
    std::vector<double> numbers;
    static const std::regex number(R"([-+]?[0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)");
    std::string values = text;
    for (auto it = std::sregex_iterator(values.begin(), values.end(), number); it != std::sregex_iterator();
         ++it)
        numbers.push_back(std::stod(it->str()));
    return numbers;
}

std::vector<glm::dvec3> evaluateAtEngineDirections(Engine engine, bool mirror,
                                                   const std::function<glm::dvec3(glm::dvec3)>& shader) {
    std::vector<glm::dvec3> values;
    for (const glm::dvec3& d : testDirections())
        values.push_back(shader(engineFrame(engine, mirror) * d));
    return values;
}

// Filament shaders/src/light_indirect.fs Irradiance_SphericalHarmonics (3 bands): the nine
// pre-scaled values times 1, y, z, x, yx, yz, 3z^2-1, zx, x^2-y^2, clamped at 0: E(n)/pi.
glm::dvec3 filamentIrradiance(const std::vector<double>& v, glm::dvec3 n) {
    const double p[9] = {
        1, n.y, n.z, n.x, n.y * n.x, n.y * n.z, 3 * n.z * n.z - 1, n.z * n.x, n.x * n.x - n.y * n.y};
    glm::dvec3 sum(0.0);
    for (int i = 0; i < 9; ++i)
        sum += p[i] * glm::dvec3(v[size_t(3 * i)], v[size_t(3 * i + 1)], v[size_t(3 * i + 2)]);
    return glm::max(sum, glm::dvec3(0.0));
}

TEST_F(EngineExports, FilamentShaderEvaluatesToOurs) {
    for (bool mirror : {true, false}) {
        std::string file = convert("probe.filament.txt", {"--mirror", mirror ? "on" : "off"});
        std::string text = readText(file);
        EXPECT_NE(text.find("// L00, irradiance, pre-scaled base"), std::string::npos) << text;
        // Each line is "(r, g, b); // Llm, ...": the numbers before the comment.
        std::vector<double> values;
        std::istringstream lines(text);
        for (std::string line; std::getline(lines, line);)
            for (double x : numbersIn(line.substr(0, line.find("//"))))
                values.push_back(x);
        ASSERT_EQ(values.size(), 27u) << text;
        expectWithin(
            compare(evaluateAtEngineDirections(Engine::Filament, mirror,
                                               [&](glm::dvec3 n) { return filamentIrradiance(values, n); }),
                    irradianceOverPiAt),
            kEngineTolerance, mirror ? "Filament (mirrored)" : "Filament (--mirror off)");
    }
}

// Unity: SetSHCoefficients' packing (unity_SHAr = (sh[r,3], sh[r,1], sh[r,2], sh[r,0] - sh[r,6]),
// unity_SHBr = (sh[r,4], sh[r,5], 3 sh[r,6], sh[r,7]), unity_SHC = sh[.,8]) and UnityCG.cginc
// ShadeSH9 = SHEvalLinearL0L1 (dot(SHA, (n, 1))) + SHEvalLinearL2 (dot(SHB, n.xyzz * n.yzzx) +
// SHC (x^2 - y^2)): E(n)/pi.
glm::dvec3 unityShadeSH9(const std::vector<double>& sh, glm::dvec3 n) {
    glm::dvec3 result;
    for (int c = 0; c < 3; ++c) {
        auto at = [&](int i) { return sh[size_t(9 * c + i)]; };
        const double a[4] = {at(3), at(1), at(2), at(0) - at(6)};
        const double b[4] = {at(4), at(5), 3 * at(6), at(7)};
        const double vB[4] = {n.x * n.y, n.y * n.z, n.z * n.z, n.z * n.x};
        double value = a[0] * n.x + a[1] * n.y + a[2] * n.z + a[3];
        for (int k = 0; k < 4; ++k)
            value += b[k] * vB[k];
        result[c] = value + at(8) * (n.x * n.x - n.y * n.y);
    }
    return result;
}

TEST_F(EngineExports, UnityShadeSH9EvaluatesToOurs) {
    nlohmann::json file = nlohmann::json::parse(readText(convert("probe.unity.json")));
    std::vector<double> sh = file["coefficients"].get<std::vector<double>>();
    ASSERT_EQ(sh.size(), 27u);
    expectWithin(compare(evaluateAtEngineDirections(Engine::Unity, true,
                                                    [&](glm::dvec3 n) { return unityShadeSH9(sh, n); }),
                         irradianceOverPiAt),
                 kEngineTolerance, "Unity ShadeSH9");
}

// Godot servers/rendering/renderer_rd/shaders/forward_clustered/scene_forward_clustered.glsl,
// the lightmap-capture branch of the fragment shader: Ramamoorthi & Hanrahan's irradiance with
// c1 = 0.429043, c2 = 0.511664, c3 = 0.743125, c4 = 0.886227, c5 = 0.247708 on 9 radiance colors
// without the Condon-Shortley phase: E(n).
glm::dvec3 godotCapture(const std::vector<glm::dvec3>& sh, glm::dvec3 n) {
    const double c1 = 0.429043, c2 = 0.511664, c3 = 0.743125, c4 = 0.886227, c5 = 0.247708;
    return c1 * sh[8] * (n.x * n.x - n.y * n.y) + c3 * sh[6] * n.z * n.z + c4 * sh[0] - c5 * sh[6] +
           2.0 * c1 * (sh[4] * n.x * n.y + sh[7] * n.x * n.z + sh[5] * n.y * n.z) +
           2.0 * c2 * (sh[3] * n.x + sh[1] * n.y + sh[2] * n.z);
}

TEST_F(EngineExports, GodotCaptureEvaluatesToOurs) {
    std::vector<glm::dvec3> sh = vectors(nlohmann::json::parse(readText(convert("probe.godot.json"))));
    ASSERT_EQ(sh.size(), 9u);
    // Godot's 6-digit constants (c2 1.3e-6 and c3 1.5e-6 off their exact values) limit the
    // agreement, as three.js's do.
    expectWithin(compare(evaluateAtEngineDirections(Engine::Godot, true,
                                                    [&](glm::dvec3 n) { return godotCapture(sh, n); }),
                         irradianceAt),
                 kEngineTolerance, "Godot lightmap capture");
}

// ---- docs/exports.md's loader snippets --------------------------------------------------------
// The three.js and Babylon.js snippets run in threejs.mjs and babylon.mjs (the tests above). Here
// the Filament, Unity and Godot ones run on the file shprobe wrote; what they hand the engine is
// evaluated with the engine's formula above and compared at kEngineTolerance. The C++ and C#
// snippets keep the values in float (2^-24 relative each, a few 1e-8 of the probe's scale over 9
// terms), well inside it.

std::string snippetFile(const std::string& name) {
    return std::string(SHPROBE_SNIPPETS) + "/" + name;
}

TEST_F(EngineExports, FilamentSnippetHandsFilamentTheFile) {
    filament::Engine engine;
    std::unique_ptr<filament::IndirectLight> light(
        loadShprobeLight(engine, convert("probe.filament.txt").c_str()));
    ASSERT_EQ(light->bands, 3);
    std::vector<double> values;
    for (const filament::math::float3& c : light->sh)
        values.insert(values.end(), {c.r, c.g, c.b});
    expectWithin(
        compare(evaluateAtEngineDirections(Engine::Filament, true,
                                           [&](glm::dvec3 n) { return filamentIrradiance(values, n); }),
                irradianceOverPiAt),
        kEngineTolerance, "Filament snippet's irradiance(3, sh)");
}

// The reason the C# snippet cannot run here, or empty.
std::string monoMissing() {
    for (const char* tool : {"mcs", "mono"})
        if (std::system(("command -v " + std::string(tool) + " > /dev/null 2>&1").c_str()) != 0)
            return std::string(tool) + " is not installed (Debian's mono-mcs; scripts/install-deps.sh)";
    return "";
}

// mcs compiles the snippet with tests/engines/unity_stub.cs, whose Main runs its Start on the file
// and prints the SphericalHarmonicsL2 it set as RenderSettings.ambientProbe.
TEST_F(EngineExports, UnitySnippetSetsShadeSH9sProbe) {
    if (std::string missing = monoMissing(); !missing.empty())
        GTEST_SKIP() << "Unity snippet check skipped: " << missing;
    std::string file = convert("probe.unity.json");
    runTool({"mcs", "-out:" + path("snippet.exe"), snippetFile("unity.cs"),
             std::string(SHPROBE_ENGINE_SCRIPTS) + "/unity_stub.cs"},
            folder_, "mcs");
    std::vector<double> sh = numbersIn(runTool({"mono", path("snippet.exe"), file}, folder_, "mono"));
    ASSERT_EQ(sh.size(), 27u);
    expectWithin(compare(evaluateAtEngineDirections(Engine::Unity, true,
                                                    [&](glm::dvec3 n) { return unityShadeSH9(sh, n); }),
                         irradianceOverPiAt),
                 kEngineTolerance, "Unity snippet's ambientProbe through ShadeSH9");
}

// What follows the Godot include in the fragment shader glslangValidator parses.
constexpr const char* kGlslCaller = R"(layout(location = 0) out vec4 color;
void main() {
    vec3 sh[9];
    for (int i = 0; i < 9; ++i) sh[i] = vec3(i);
    color = vec4(shIrradiance(sh, vec3(0.0, 1.0, 0.0)), 1.0);
}
)";

// No Debian 12 package reads Godot 4's shader language or GDScript (bookworm's godot3 is Godot
// 3.2.3, another syntax), so neither the shader nor the script runs. Checked: the include parses
// as GLSL (glslangValidator, inside a fragment shader), its arithmetic on the file's colors equals
// ours (compiled as C++ above, within kEngineTolerance: Godot's 6-digit constants), the shader
// includes it and sets the uniform the script fills. Not checked: Godot's own parsing of the
// three blocks, the script's JSON reading, and the world-space normal.
TEST_F(EngineExports, GodotSnippetsParseAndEvaluateToOurs) {
    const std::string include = readText(snippetFile("godot-include.glsl")),
                      shader = readText(snippetFile("godot-shader.gdshader")),
                      script = readText(snippetFile("godot-script.gd"));
    std::ofstream(path("snippet.frag")) << "#version 450\n" << include << kGlslCaller;
    runTool({SHPROBE_GLSLANG, path("snippet.frag")}, folder_, "glslangValidator");

    std::vector<glm::dvec3> sh = vectors(nlohmann::json::parse(readText(convert("probe.godot.json"))));
    ASSERT_EQ(sh.size(), 9u);
    expectWithin(compare(evaluateAtEngineDirections(
                             Engine::Godot, true,
                             [&](glm::dvec3 n) { return godot_snippet::shIrradiance(sh.data(), n); }),
                         irradianceAt),
                 kEngineTolerance, "Godot snippet's shIrradiance");

    std::smatch includeName, uniform, parameter;
    ASSERT_TRUE(std::regex_search(shader, includeName, std::regex(R"re(#include "res://([\w.]+)")re")));
    EXPECT_NE(include.find(includeName[1].str()), std::string::npos) << "the include names itself otherwise";
    EXPECT_NE(shader.find("shIrradiance(sh, "), std::string::npos) << shader;
    ASSERT_TRUE(std::regex_search(shader, uniform, std::regex(R"(uniform vec3 (\w+)\[9\])")));
    ASSERT_TRUE(std::regex_search(script, parameter, std::regex(R"re(set_shader_parameter\("(\w+)")re")));
    EXPECT_EQ(parameter[1].str(), uniform[1].str());
}

// ---- Conversions ------------------------------------------------------------------------------

TEST_F(EngineExports, ConvertJsonToJsonIsTheIdentity) {
    ShCoefficients back = readProbeFile(convert("copy.json"));
    ShCoefficients original = readProbeFile(path("probe.json"));
    ASSERT_EQ(back.order, original.order);
    for (size_t i = 0; i < original.rgb.size(); ++i)
        EXPECT_EQ(back.rgb[i], original.rgb[i]) << "coefficient " << i;
}

TEST_F(EngineExports, GltfExtensionChoosesGltf) {
    nlohmann::json asset = nlohmann::json::parse(readText(convert("light.gltf")));
    EXPECT_EQ(asset["asset"]["version"], "2.0");
    EXPECT_EQ(asset["extensionsUsed"][0], "EXT_lights_image_based");
    EXPECT_EQ(asset["extensions"]["EXT_lights_image_based"]["lights"][0]["irradianceCoefficients"].size(),
              9u);
}

TEST_F(EngineExports, AnIrradianceProbeExportsAsItsRadiance) {
    ShCoefficients radiance = testProbe();
    ShCoefficients irradiance = convolveIrradiance(bandsUpTo2(radiance));
    for (Engine engine :
         {Engine::ThreeJs, Engine::Babylon, Engine::Gltf, Engine::Filament, Engine::Unity, Engine::Godot}) {
        EngineCoefficients a = engineCoefficients(radiance, engine),
                           b = engineCoefficients(irradiance, engine);
        for (size_t i = 0; i < a.size(); ++i)
            for (int c = 0; c < 3; ++c)
                EXPECT_NEAR(a[i][c], b[i][c], 1e-12 * (1.0 + std::abs(a[i][c]))) << "engine " << int(engine);
    }
}

// A reflection (det -1) through makeShRotation: the reflected probe is f(Q^T w) at every direction,
// through order 8. Within each band SH are closed under O(3), so this is the projection of the
// reflected environment exactly; the recurrence needs no special case (D^l is homogeneous of
// degree l in Q).
TEST(EngineFrames, ReflectionsRotateAsTheReflectedEnvironment) {
    const glm::dmat3 reflections[] = {
        glm::dmat3(glm::dvec3(1, 0, 0), glm::dvec3(0, 1, 0), glm::dvec3(0, 0, -1)), -glm::dmat3(1.0),
        engineFrame(Engine::Unity), engineFrame(Engine::Filament, false)};
    ShCoefficients probe = makeCoefficients(kMaxOrder, Quantity::Radiance);
    for (size_t i = 0; i < probe.rgb.size(); ++i)
        probe.rgb[i] = glm::dvec3(std::sin(1.0 + i), std::cos(2.0 * i), 0.5 - 0.01 * double(i));
    for (const glm::dmat3& q : reflections) {
        ASSERT_LT(glm::determinant(q), 0.0);
        ShCoefficients reflected = rotate(makeShRotation(q, kMaxOrder), probe);
        for (const glm::dvec3& w : testDirections()) {
            glm::dvec3 expected = evaluate(probe, glm::transpose(q) * w), got = evaluate(reflected, w);
            for (int c = 0; c < 3; ++c)
                ASSERT_NEAR(got[c], expected[c], 1e-9) << "at (" << w.x << ", " << w.y << ", " << w.z << ")";
        }
    }
}

TEST_F(EngineExports, RotateTakesAReflection) {
    testing::RunResult run = testing::runProgram(
        {"rotate", path("probe.json"), "--matrix", "1,0,0,0,1,0,0,0,-1", "-o", path("mirrored.json")},
        folder_ / "logs");
    ASSERT_EQ(run.exitCode, 0) << testing::describe(run);
    ShCoefficients mirrored = readProbeFile(path("mirrored.json")), probe = writtenProbe();
    for (const glm::dvec3& d : testDirections()) {
        glm::dvec3 a = evaluate(mirrored, d), b = evaluate(probe, {d.x, d.y, -d.z});
        for (int c = 0; c < 3; ++c)
            ASSERT_NEAR(a[c], b[c], 1e-9);
    }
}

} // namespace
} // namespace shprobe
