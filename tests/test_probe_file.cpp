// Coefficient files (docs/conventions.md, "Coefficient files"): what is written reads back the
// same, and every malformed or wrong-schema file is refused with a message naming the file and the
// offending field.
#include "common/error.h"
#include "common/output_file.h"
#include "formats/json_reading.h"
#include "formats/probe_file.h"

#include <algorithm>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <gtest/gtest.h>
#include <limits>
#include <nlohmann/json.hpp>
#include <sys/wait.h>
#include <unistd.h>

namespace shprobe {
namespace {

ShCoefficients sampleProbe(int order, Quantity quantity) {
    ShCoefficients probe = makeCoefficients(order, quantity);
    for (size_t i = 0; i < probe.rgb.size(); ++i)
        probe.rgb[i] = glm::dvec3(0.1 * double(i) - 1.0, 1.0 / (double(i) + 3.0), -2.5e-7 * double(i));
    return probe;
}

// Values are written as text that reads back as themselves: a float in 9 significant digits (the
// float again), a double in the shortest digits that give it back, at most 17. Near a float
// rounding midpoint (values of 1 + k / 1000 moved to just past the midpoint to the next float), the
// 9 digits written before gave the float on the other side of it about half the time, so the JSON
// and binary files of one bake differed by an ulp.
TEST(ProbeFile, RoundTripsEveryOrderAndQuantity) {
    for (int order = 1; order <= 8; ++order)
        for (Quantity quantity : {Quantity::Radiance, Quantity::Irradiance}) {
            ShCoefficients probe = sampleProbe(order, quantity);
            for (size_t i = 0; i < probe.rgb.size(); ++i) {
                const float f = 1.0f + float(i) / 1000.0f, next = std::nextafter(f, 2.0f);
                probe.rgb[i].b = (double(f) + double(next)) / 2.0 + (double(next) - double(f)) * 1e-4;
            }
            ShCoefficients read = parseProbeJson(probeToJson(probe, {}), "probe.json");
            ASSERT_EQ(read.order, order);
            ASSERT_EQ(read.quantity, quantity);
            ASSERT_EQ(read.rgb.size(), probe.rgb.size());
            for (size_t i = 0; i < probe.rgb.size(); ++i)
                for (int c = 0; c < 3; ++c)
                    EXPECT_EQ(read.rgb[i][c], probe.rgb[i][c])
                        << "order " << order << " coefficient " << i << " channel " << c;
        }
    // A float is written in 9 digits, not in the 17 of the double it widens to.
    ShCoefficients floats = makeCoefficients(1, Quantity::Radiance);
    floats.rgb[0] = glm::dvec3(double(0.1f), double(-1.0406155f), 0.5);
    const std::string text = probeToJson(floats, {});
    EXPECT_NE(text.find("[0.100000001, -1.04061556, 0.5]"), std::string::npos) << text;
    EXPECT_EQ(float(parseProbeJson(text, "probe.json").rgb[0].g), -1.0406155f);
}

TEST(ProbeFile, WritesTheRequiredFieldsFirstAndMetadataAfter) {
    ProbeMetadata metadata;
    metadata.source = "sky.exr";
    metadata.faceSize = 128;
    metadata.backend = "gpu";
    nlohmann::json json = nlohmann::json::parse(probeToJson(sampleProbe(3, Quantity::Radiance), metadata));
    EXPECT_EQ(json["format"], "shprobe.sh");
    EXPECT_EQ(json["version"], 1);
    EXPECT_EQ(json["convention"], "real-orthonormal-condon-shortley");
    EXPECT_EQ(json["order"], 3);
    EXPECT_EQ(json["quantity"], "radiance");
    EXPECT_EQ(json["source"], "sky.exr");
    EXPECT_EQ(json["face_size"], 128);
    EXPECT_EQ(json["coefficients"].size(), 9u);
}

TEST(ProbeFile, WritesAtomicallyAndReadsFromDisk) {
    std::filesystem::path folder = std::filesystem::temp_directory_path() / "shprobe_test_probe_file";
    std::filesystem::create_directories(folder);
    std::string path = (folder / "probe.json").string();
    writeProbeFile(path, sampleProbe(5, Quantity::Irradiance), {});
    EXPECT_EQ(readProbeFile(path).order, 5);
    // Only the file itself: the temporary file was renamed into place.
    EXPECT_EQ(std::distance(std::filesystem::directory_iterator(folder), {}), 1);
    std::filesystem::remove_all(folder);
}

TEST(ProbeFile, UnknownFieldsAreIgnored) {
    nlohmann::json json = nlohmann::json::parse(probeToJson(sampleProbe(2, Quantity::Radiance), {}));
    json["timings"] = {{"bake_ms", 12.5}};
    json["window"] = "none";
    EXPECT_EQ(parseProbeJson(json.dump(), "probe.json").order, 2);
}

// Each malformed file names the file and the problem.
void expectRejected(const std::string& text, const std::string& expectedInMessage) {
    try {
        parseProbeJson(text, "bad.json");
        ADD_FAILURE() << "accepted: " << text;
    } catch (const Error& e) {
        EXPECT_EQ(e.kind(), ErrorKind::Input);
        std::string message = e.what();
        EXPECT_NE(message.find("bad.json"), std::string::npos) << message;
        EXPECT_NE(message.find(expectedInMessage), std::string::npos) << message;
    }
}

std::string validWith(const std::string& field, const nlohmann::json& value) {
    nlohmann::json json = nlohmann::json::parse(probeToJson(sampleProbe(3, Quantity::Radiance), {}));
    json[field] = value;
    return json.dump();
}

std::string validWithout(const std::string& field) {
    nlohmann::json json = nlohmann::json::parse(probeToJson(sampleProbe(3, Quantity::Radiance), {}));
    json.erase(field);
    return json.dump();
}

TEST(ProbeFile, RejectsMalformedJson) {
    expectRejected("", "not valid JSON");
    expectRejected("{\"format\": \"shprobe.sh\", ", "not valid JSON");
    expectRejected("[1, 2, 3]", "JSON object");
    std::string valid = probeToJson(sampleProbe(3, Quantity::Radiance), {});
    expectRejected(valid.substr(0, valid.size() / 2), "not valid JSON");
    expectRejected(valid + std::string(1, '\0') + "junk",
                   "a NUL byte at offset " + std::to_string(valid.size()));
    expectRejected(std::string("{\"format\": \"shprobe.sh\",, }"), "parse error at line 1, column 25");
}

TEST(ProbeFile, RejectsMissingRequiredFields) {
    for (const char* field : {"format", "version", "convention", "order", "quantity", "coefficients"})
        expectRejected(validWithout(field), std::string("\"") + field + "\"");
}

TEST(ProbeFile, RejectsWrongValues) {
    expectRejected(validWith("format", "other.sh"), "\"format\"");
    expectRejected(validWith("version", 2), "\"version\"");
    expectRejected(validWith("convention", "real-orthonormal-no-phase"), "\"convention\"");
    expectRejected(validWith("quantity", "luminance"), "\"quantity\"");
    expectRejected(validWith("order", 0), "\"order\"");
    expectRejected(validWith("order", 9), "\"order\"");
    expectRejected(validWith("order", 2.5), "\"order\"");
    expectRejected(validWith("order", 4), "16 rows"); // order 4 needs 16 rows, the file has 9
}

TEST(ProbeFile, RejectsBadCoefficientRows) {
    nlohmann::json rows = nlohmann::json::array();
    for (int i = 0; i < 9; ++i)
        rows.push_back({1.0, 2.0, 3.0});
    EXPECT_EQ(parseProbeJson(validWith("coefficients", rows), "ok.json").rgb[8].b, 3.0);

    nlohmann::json shortRow = rows;
    shortRow[4] = {1.0, 2.0};
    expectRejected(validWith("coefficients", shortRow), "coefficients[4]");
    nlohmann::json textRow = rows;
    textRow[7] = {1.0, "two", 3.0};
    expectRejected(validWith("coefficients", textRow), "coefficients[7]");
    expectRejected(validWith("coefficients", "none"), "\"coefficients\"");
    rows.erase(rows.begin());
    expectRejected(validWith("coefficients", rows), "9 rows");
}

// ---- The optional sun (bake --extract-sun) -----------------------------------------------------

ProbeSun sampleSun() {
    ProbeSun sun;
    sun.direction = glm::dvec3(0.48, 0.6, -0.64); // unit
    sun.radiance = glm::dvec3(21000.0, 19500.5, 0.0);
    sun.angularRadius = 1.146 * M_PI / 180.0;
    return sun;
}

TEST(ProbeFile, SunRoundTrips) {
    ProbeMetadata metadata;
    metadata.sun = sampleSun();
    ShCoefficients coefficients = sampleProbe(5, Quantity::Radiance);
    Probe read = parseProbe(probeToJson(coefficients, metadata), "sun.json");
    ASSERT_TRUE(read.sun.has_value());
    EXPECT_EQ(read.coefficients.order, 5);
    EXPECT_EQ(read.coefficients.rgb.size(), coefficients.rgb.size());
    // nlohmann writes doubles with round-trip precision: the sun reads back to the last bits.
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(read.sun->direction[c], metadata.sun->direction[c], 1e-15);
        EXPECT_EQ(read.sun->radiance[c], metadata.sun->radiance[c]);
    }
    EXPECT_NEAR(read.sun->angularRadius, metadata.sun->angularRadius, 1e-15);

    // Without the field there is no sun, and the coefficients-only readers ignore it.
    EXPECT_FALSE(parseProbe(probeToJson(coefficients, {}), "plain.json").sun.has_value());
    EXPECT_EQ(parseProbeJson(probeToJson(coefficients, metadata), "sun.json").order, 5);
}

TEST(ProbeFile, SunDirectionIsNormalizedOnRead) {
    nlohmann::json sun = {
        {"direction", {0.0, 3e-200, -4e-200}}, {"radiance", {1, 2, 3}}, {"angular_radius_degrees", 90}};
    Probe read = parseProbe(validWith("sun", sun), "sun.json");
    ASSERT_TRUE(read.sun.has_value());
    EXPECT_NEAR(read.sun->direction.y, 0.6, 1e-15);
    EXPECT_NEAR(read.sun->direction.z, -0.8, 1e-15);
    EXPECT_NEAR(read.sun->angularRadius, M_PI / 2.0, 1e-15);
    sun["direction"] = {2e300, 0.0, 2e300}; // |d| overflows unless scaled first
    read = parseProbe(validWith("sun", sun), "sun.json");
    EXPECT_NEAR(read.sun->direction.x, std::sqrt(0.5), 1e-15);
}

TEST(ProbeFile, RejectsMalformedSun) {
    const nlohmann::json good = {
        {"direction", {0.0, 1.0, 0.0}}, {"radiance", {10.0, 9.0, 8.0}}, {"angular_radius_degrees", 0.5}};
    EXPECT_TRUE(parseProbe(validWith("sun", good), "ok.json").sun.has_value());
    auto with = [&](const char* field, const nlohmann::json& value) {
        nlohmann::json sun = good;
        sun[field] = value;
        return validWith("sun", sun);
    };
    auto without = [&](const char* field) {
        nlohmann::json sun = good;
        sun.erase(field);
        return validWith("sun", sun);
    };
    expectRejected(validWith("sun", "bright"), "\"sun\"");
    expectRejected(validWith("sun", {1, 2, 3}), "\"sun\"");
    for (const char* field : {"direction", "radiance", "angular_radius_degrees"})
        expectRejected(without(field), std::string("\"sun.") + field + "\"");
    expectRejected(with("direction", {0.0, 0.0, 0.0}), "\"sun.direction\" is the zero vector");
    expectRejected(with("direction", {1.0, 2.0}), "\"sun.direction\"");
    expectRejected(with("direction", {1.0, "up", 2.0}), "\"sun.direction\"");
    expectRejected(with("direction", "up"), "\"sun.direction\"");
    expectRejected(with("radiance", {1.0, -0.5, 1.0}), "\"sun.radiance\"");
    expectRejected(with("radiance", {1.0, 1.0}), "\"sun.radiance\"");
    for (const nlohmann::json& radius :
         {nlohmann::json(0.0), nlohmann::json(-1.0), nlohmann::json(90.5), nlohmann::json("1")})
        expectRejected(with("angular_radius_degrees", radius), "\"sun.angular_radius_degrees\"");
    // Numbers beyond double range ("1e999") are already refused by the JSON parser.
    std::string huge = with("angular_radius_degrees", 12345.5);
    expectRejected(huge.replace(huge.find("12345.5"), 7, "1e999"), "not valid JSON");
    EXPECT_TRUE(parseProbe(with("angular_radius_degrees", 90), "ok.json").sun.has_value()) << "90 is allowed";
}

// The reader's checks before parsing: each names the file and says what it is instead. A file
// larger than 1 MiB is refused from its size, and deep nesting as soon as the parser reaches
// level 17: neither is read into a tree (a megabyte of '[' took gigabytes when it was).
TEST(ProbeFile, ReadRefusesWhatIsNotAProbeFile) {
    namespace fs = std::filesystem;
    fs::path folder = fs::temp_directory_path() / ("shprobe_test_probe_read_" + std::to_string(getpid()));
    fs::create_directories(folder / "folder.json");
    std::ofstream(folder / "empty.json").close();
    std::ofstream(folder / "large.json") << std::string((1 << 20) + 1, ' ');
    std::ofstream(folder / "deep.json") << std::string(1 << 20, '[');
    std::string valid = probeToJson(sampleProbe(3, Quantity::Radiance), {});
    std::ofstream(folder / "cut.json") << valid.substr(0, valid.find("\"coefficients\""));
    // Files of the formats beside probe files, by their first bytes: a volume past the JSON size
    // limit is named from its magic before its size is looked at.
    std::ofstream(folder / "volume.json") << "SHPROBEV" << std::string((1 << 20) + 8, '\0');
    std::ofstream(folder / "exr.json") << std::string("\x76\x2f\x31\x01", 4) << std::string(64, '\0');
    std::ofstream(folder / "hdr.json") << "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n";
    std::ofstream(folder / "png.json") << "\x89PNG\r\n\x1a\n";
    std::ofstream(folder / "glb.json") << "glTF" << std::string(16, '\0');
    const std::pair<const char*, const char*> cases[] = {
        {"folder.json", "is a folder"},
        {"empty.json", "the file is empty"},
        {"large.json", "the file has 1048577 bytes, more than a JSON probe file can have (1048576 at most)"},
        {"deep.json", "JSON nested deeper than 16 levels"},
        {"cut.json", "not valid JSON (parse error at line"},
        {"absent.json", "no such file"},
        {"volume.json", "a probe volume, not a probe file (JSON, or binary of one probe)"},
        {"exr.json", "an OpenEXR image, not a probe file"},
        {"hdr.json", "a Radiance HDR image, not a probe file"},
        {"png.json", "a PNG image, not a probe file"},
        {"glb.json", "a binary glTF scene, not a probe file"},
    };
    for (const auto& [name, problem] : cases) {
        std::string path = (folder / name).string();
        try {
            readProbeFile(path);
            ADD_FAILURE() << name << " was accepted";
        } catch (const Error& e) {
            EXPECT_EQ(e.kind(), ErrorKind::Input);
            EXPECT_NE(std::string(e.what()).find(path + ": " + problem), std::string::npos) << e.what();
        }
    }
    EXPECT_THROW(readProbeFile("/dev/null"), Error); // not a regular file
    fs::remove_all(folder);
}

// The nesting bound every JSON reader applies, scanned before the parse: a value inside more than
// maxDepth arrays and objects is refused, at the depth nlohmann's parse callback gives it (an empty
// innermost container counts at its parent's), and brackets inside strings, escaped quotes
// included, are text.
TEST(JsonReading, DepthIsCountedOutsideStrings) {
    EXPECT_NO_THROW(parseBoundedJson("[[1]]", 2));
    EXPECT_THROW(parseBoundedJson("[[[1]]]", 2), JsonTooDeep);
    EXPECT_NO_THROW(parseBoundedJson(R"({"a":{"b":[]}})", 2));
    EXPECT_THROW(parseBoundedJson(R"({"a":{"b":[0]}})", 2), JsonTooDeep);
    EXPECT_EQ(parseBoundedJson(R"(["[[[{{", "\"[[[", "\\"])", 1)[1], "\"[[[");
    EXPECT_THROW(parseBoundedJson(R"(["\\", [[0]]])", 2), JsonTooDeep);
    EXPECT_THROW(parseBoundedJson("[1,", 4), nlohmann::json::exception);
}

// A file name need not be UTF-8 (Linux names are bytes), and the probe's "source" holds it: bytes
// that are not UTF-8 are written as U+FFFD, so the file is JSON; nlohmann's plain dump threw, which
// ended the command with an internal error.
TEST(ProbeFile, SourceThatIsNotUtf8IsWrittenAsReplacement) {
    const std::string text = probeToJson(sampleProbe(3, Quantity::Radiance), {.source = "caf\xe9.exr"});
    const nlohmann::json parsed = nlohmann::json::parse(text);
    EXPECT_EQ(parsed["source"], "caf\xef\xbf\xbd.exr");
}

// Coefficients that overflowed are not written (no file holds infinity): the error names the
// output, and neither it nor a temporary file appears.
TEST(ProbeFile, NonFiniteCoefficientsAreNotWritten) {
    namespace fs = std::filesystem;
    fs::path folder = fs::temp_directory_path() / ("shprobe_test_probe_inf_" + std::to_string(getpid()));
    fs::create_directories(folder);
    ShCoefficients probe = sampleProbe(2, Quantity::Radiance);
    probe.rgb[0].g = std::numeric_limits<double>::infinity();
    std::string path = (folder / "probe.json").string();
    try {
        writeProbeFile(path, probe, {});
        ADD_FAILURE() << "written";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("cannot write " + path + ": coefficient 0 is not finite"),
                  std::string::npos)
            << e.what();
    }
    EXPECT_TRUE(fs::is_empty(folder));
    fs::remove_all(folder);
}

// ---- Atomic files -----------------------------------------------------------------------------

std::vector<std::string> entriesOf(const std::filesystem::path& folder) {
    std::vector<std::string> names;
    for (const auto& entry : std::filesystem::directory_iterator(folder))
        names.push_back(entry.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
}

std::string contentsOf(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
}

// The temporary file exists (hidden, in the destination's folder, with its extension) until the
// commit renames it over the destination; an OutputFile abandoned (an error on the way) removes it
// and leaves an existing destination untouched.
TEST(OutputFile, TemporaryFileIsRenamedOrRemoved) {
    namespace fs = std::filesystem;
    fs::path folder = fs::temp_directory_path() / ("shprobe_test_atomic_" + std::to_string(getpid()));
    fs::create_directories(folder);
    std::ofstream(folder / "out.exr") << "old";
    {
        OutputFile file((folder / "out.exr").string());
        EXPECT_EQ(fs::path(file.temporaryPath()).parent_path(), folder);
        EXPECT_EQ(fs::path(file.temporaryPath()).extension(), ".exr");
        EXPECT_EQ(fs::path(file.temporaryPath()).filename().string().rfind(".out.", 0), 0u);
        EXPECT_TRUE(fs::exists(file.temporaryPath())) << "created empty, with a name no other file has";
        std::ofstream(file.temporaryPath()) << "half";
    }
    EXPECT_EQ(entriesOf(folder), std::vector<std::string>{"out.exr"});
    EXPECT_EQ(contentsOf(folder / "out.exr"), "old");
    writeOutputFile((folder / "out.exr").string(), "new");
    EXPECT_EQ(entriesOf(folder), std::vector<std::string>{"out.exr"});
    EXPECT_EQ(contentsOf(folder / "out.exr"), "new");
    fs::remove_all(folder);
}

// Ctrl-C (and SIGTERM) while a temporary file exists: removeTemporaryFilesOnInterrupt removes it
// and the process ends by the signal; the destination keeps its earlier content. A child process
// plays the program: it installs the handling, opens an OutputFile, writes half of it, says so
// through a pipe and waits to be interrupted.
TEST(OutputFile, InterruptRemovesTemporaryFiles) {
    namespace fs = std::filesystem;
    for (int signal : {SIGINT, SIGTERM}) {
        fs::path folder = fs::temp_directory_path() / ("shprobe_test_interrupt_" + std::to_string(getpid()));
        fs::remove_all(folder);
        fs::create_directories(folder);
        std::ofstream(folder / "probe.json") << "earlier";
        int ready[2];
        ASSERT_EQ(pipe(ready), 0);
        pid_t child = fork();
        ASSERT_GE(child, 0);
        if (child == 0) {
            struct sigaction standard {};
            standard.sa_handler = SIG_DFL;
            sigaction(signal, &standard, nullptr);
            removeTemporaryFilesOnInterrupt();
            OutputFile file((folder / "probe.json").string());
            std::ofstream(file.temporaryPath()) << "half a probe";
            OutputFile second((folder / "other.bin").string());
            (void)!write(ready[1], "r", 1);
            for (;;)
                pause();
        }
        close(ready[1]);
        char byte = 0;
        ASSERT_EQ(read(ready[0], &byte, 1), 1) << "the child failed before its files existed";
        close(ready[0]);
        EXPECT_EQ(entriesOf(folder).size(), 3u) << "the temporary files exist before the signal";
        kill(child, signal);
        int status = 0;
        ASSERT_EQ(waitpid(child, &status, 0), child);
        EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == signal) << "status " << status;
        EXPECT_EQ(entriesOf(folder), std::vector<std::string>{"probe.json"});
        EXPECT_EQ(contentsOf(folder / "probe.json"), "earlier");
        fs::remove_all(folder);
    }
}

TEST(ProbeFile, MissingFileIsAnInputError) {
    try {
        readProbeFile("/nonexistent/probe.json");
        ADD_FAILURE();
    } catch (const Error& e) {
        EXPECT_EQ(e.kind(), ErrorKind::Input);
        EXPECT_NE(std::string(e.what()).find("/nonexistent/probe.json"), std::string::npos);
    }
}

} // namespace
} // namespace shprobe
