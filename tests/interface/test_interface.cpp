// shaders/INTERFACE.md against the built modules: every module the libraries embed has exactly one
// `interface` block, and the block's statements equal the module's reflection (spirv-cross
// --reflect for resources, spirv-dis for version, capabilities and extensions). Statements are
// compared as sets, so the failure names each line the document lacks or has too many.
#undef NDEBUG
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace {

using Statements = std::multiset<std::string>;
using json = nlohmann::json;

std::vector<std::string> split(const std::string& text, char separator) {
    std::vector<std::string> parts;
    std::string part;
    std::istringstream stream(text);
    while (std::getline(stream, part, separator))
        if (!part.empty()) parts.push_back(part);
    return parts;
}

std::vector<std::string> words(const std::string& line) {
    std::istringstream stream(line);
    std::vector<std::string> result;
    for (std::string word; stream >> word;)
        result.push_back(word);
    return result;
}

std::string join(const std::vector<std::string>& parts, size_t from = 0) {
    std::string result;
    for (size_t i = from; i < parts.size(); ++i)
        result += (i > from ? " " : "") + parts[i];
    return result;
}

std::string readFile(const std::string& path) {
    std::ifstream file(path, std::ios::binary);
    if (!file) throw std::runtime_error("cannot read " + path);
    std::ostringstream text;
    text << file.rdbuf();
    return text.str();
}

// Runs a command and returns its standard output; throws when it fails.
std::string run(const std::string& command) {
    FILE* pipe = popen(command.c_str(), "r");
    if (!pipe) throw std::runtime_error("cannot run " + command);
    std::string output;
    char buffer[4096];
    for (size_t n; (n = fread(buffer, 1, sizeof(buffer), pipe)) > 0;)
        output.append(buffer, n);
    if (pclose(pipe) != 0) throw std::runtime_error("failed: " + command);
    return output;
}

// --- the document --------------------------------------------------------------------------------

// Statements of each `interface` block, by module. A member statement is prefixed with the
// resource it belongs to ("member 0.1 ..." or "member push ..."), as reflection produces it.
std::map<std::string, Statements> parseDocument(const std::string& text) {
    std::map<std::string, Statements> modules;
    std::istringstream stream(text);
    std::string line, module, owner;
    bool inBlock = false;
    while (std::getline(stream, line)) {
        if (!inBlock) {
            inBlock = line.rfind("```interface", 0) == 0;
            module.clear();
            continue;
        }
        if (line.rfind("```", 0) == 0) {
            inBlock = false;
            continue;
        }
        std::vector<std::string> w = words(line.substr(0, line.find('#')));
        if (w.empty()) continue;
        if (w[0] == "module") {
            module = w.at(1);
            if (modules.count(module)) throw std::runtime_error("INTERFACE.md: two blocks for " + module);
            modules[module];
            continue;
        }
        if (module.empty())
            throw std::runtime_error("INTERFACE.md: an interface block must start with module");
        if (w[0] == "storage_buffer" || w[0] == "uniform_buffer") owner = w.at(1) + "." + w.at(2);
        if (w[0] == "push_constant") owner = "push";
        if (w[0] == "member") w.insert(w.begin() + 1, owner);
        modules[module].insert(join(w));
    }
    return modules;
}

// --- reflection ----------------------------------------------------------------------------------

// Size in bytes of a member, for the push-constant block's size (the reflection gives none).
uint32_t memberSize(const json& member) {
    static const std::map<std::string, uint32_t> sizes{{"uint", 4},   {"int", 4},   {"float", 4},
                                                       {"vec2", 8},   {"vec3", 12}, {"vec4", 16},
                                                       {"uvec4", 16}, {"mat4", 64}};
    uint32_t size = sizes.at(member.at("type").get<std::string>());
    if (member.contains("array"))
        size = member.at("array_stride").get<uint32_t>() * member["array"][0].get<uint32_t>();
    return size;
}

// Flattens a block's members into statements; returns the end of the last member.
uint32_t flatten(const json& types, const std::string& type, const std::string& owner,
                 const std::string& prefix, uint32_t base, Statements& out) {
    uint32_t end = 0;
    for (const json& member : types.at(type).at("members")) {
        std::string path = prefix + member.at("name").get<std::string>();
        uint32_t offset = base + member.at("offset").get<uint32_t>();
        std::string memberType = member.at("type");
        if (types.contains(memberType) && !member.contains("array")) {
            end = std::max(end, flatten(types, memberType, owner, path + ".", offset, out));
            continue;
        }
        std::string line = "member " + owner + " " + path + " " + memberType;
        if (member.contains("array")) {
            uint32_t count = member["array"][0];
            line += count == 0 ? "[]" : "[" + std::to_string(count) + "]";
        }
        line += " " + std::to_string(offset);
        if (member.contains("array_stride"))
            line += " stride " + std::to_string(member["array_stride"].get<int>());
        if (member.contains("matrix_stride"))
            line += " matrix_stride " + std::to_string(member["matrix_stride"].get<int>());
        if (member.value("row_major", false)) line += " row_major";
        out.insert(line);
        end = std::max(end, offset + memberSize(member));
    }
    return end;
}

std::string location(const json& variable) {
    return std::to_string(variable.at("location").get<int>()) + " " + variable.at("type").get<std::string>() +
           " " + variable.at("name").get<std::string>();
}

Statements reflectResources(const json& r) {
    Statements out;
    const json& types = r.contains("types") ? r["types"] : json::object();
    const json& entry = r.at("entryPoints").at(0);
    out.insert("entry " + entry.at("name").get<std::string>() + " " + entry.at("mode").get<std::string>());
    if (entry.contains("workgroup_size")) {
        std::string line = "workgroup";
        for (int axis = 0; axis < 3; ++axis) {
            bool spec = entry["workgroup_size_is_spec_constant_id"][axis];
            line += (spec ? " spec:" : " ") + std::to_string(entry["workgroup_size"][axis].get<int>());
        }
        out.insert(line);
    }
    for (const json& c : r.value("specialization_constants", json::array())) {
        std::string name = c.at("name");
        out.insert("spec " + std::to_string(c.at("id").get<int>()) + " " + c.at("type").get<std::string>() +
                   " " + std::to_string(c.at("default_value").get<long long>()) + " " +
                   (name.empty() ? "-" : name));
    }
    for (const json& v : r.value("inputs", json::array()))
        out.insert("input " + location(v));
    for (const json& v : r.value("outputs", json::array()))
        out.insert("output " + location(v));
    for (const json& b : r.value("ssbos", json::array())) {
        std::string owner =
            std::to_string(b.at("set").get<int>()) + "." + std::to_string(b.at("binding").get<int>());
        std::string access = b.value("readonly", false)    ? "readonly"
                             : b.value("writeonly", false) ? "writeonly"
                                                           : "readwrite";
        out.insert("storage_buffer " + std::to_string(b["set"].get<int>()) + " " +
                   std::to_string(b["binding"].get<int>()) + " " + access + " " +
                   b.at("name").get<std::string>());
        flatten(types, b.at("type"), owner, "", 0, out);
    }
    for (const json& b : r.value("ubos", json::array())) {
        std::string owner =
            std::to_string(b.at("set").get<int>()) + "." + std::to_string(b.at("binding").get<int>());
        out.insert("uniform_buffer " + std::to_string(b["set"].get<int>()) + " " +
                   std::to_string(b["binding"].get<int>()) + " " + b.at("name").get<std::string>() + " " +
                   std::to_string(b.at("block_size").get<int>()));
        flatten(types, b.at("type"), owner, "", 0, out);
    }
    for (const json& t : r.value("textures", json::array()))
        out.insert("sampler " + std::to_string(t.at("set").get<int>()) + " " +
                   std::to_string(t.at("binding").get<int>()) + " " + t.at("type").get<std::string>() + " " +
                   t.at("name").get<std::string>());
    for (const json& t : r.value("images", json::array()))
        out.insert("storage_image " + std::to_string(t.at("set").get<int>()) + " " +
                   std::to_string(t.at("binding").get<int>()) + " " +
                   (t.value("readonly", false)    ? "readonly"
                    : t.value("writeonly", false) ? "writeonly"
                                                  : "readwrite") +
                   " " + t.at("type").get<std::string>() + " " + t.value("format", std::string("unknown")) +
                   " " + t.at("name").get<std::string>());
    for (const char* kind :
         {"separate_images", "separate_samplers", "acceleration_structures", "subpass_inputs"})
        for (const json& other : r.value(kind, json::array()))
            out.insert(std::string("unsupported ") + kind + " " + other.value("name", std::string()));
    for (const json& p : r.value("push_constants", json::array())) {
        Statements members;
        uint32_t size = flatten(types, p.at("type"), "push", "", 0, members);
        out.insert(members.begin(), members.end());
        out.insert("push_constant " + std::to_string(size));
    }
    return out;
}

// Version, capabilities and extensions from the disassembly.
Statements reflectHeader(const std::string& disassembly) {
    Statements out;
    std::smatch match;
    std::regex version("^; Version: (\\d+\\.\\d+)");
    std::regex capability("^\\s*OpCapability (\\w+)");
    std::regex extension("^\\s*OpExtension \"([^\"]+)\"");
    std::vector<std::string> capabilities, extensions;
    std::istringstream stream(disassembly);
    for (std::string line; std::getline(stream, line);) {
        if (std::regex_search(line, match, version)) out.insert("spirv " + match[1].str());
        if (std::regex_search(line, match, capability)) capabilities.push_back(match[1]);
        if (std::regex_search(line, match, extension)) extensions.push_back(match[1]);
    }
    out.insert("capabilities " + join(capabilities));
    out.insert("extensions " + (extensions.empty() ? std::string("none") : join(extensions)));
    return out;
}

Statements reflectModule(const std::string& spv) {
    Statements out =
        reflectResources(json::parse(run(std::string(SPIRV_CROSS) + " '" + spv + "' --reflect")));
    Statements header = reflectHeader(run(std::string(SPIRV_DIS) + " '" + spv + "'"));
    out.insert(header.begin(), header.end());
    return out;
}

std::string listDifference(const Statements& a, const Statements& b) {
    Statements only;
    std::set_difference(a.begin(), a.end(), b.begin(), b.end(), std::inserter(only, only.begin()));
    std::string text;
    for (const std::string& s : only)
        text += "\n    " + s;
    return text;
}

const std::map<std::string, Statements>& documented() {
    static const std::map<std::string, Statements> modules = parseDocument(readFile(SHPROBE_INTERFACE_DOC));
    return modules;
}

const std::vector<std::string> kLibraryModules = split(SHPROBE_MODULES, ',');

TEST(Interface, DocumentsExactlyTheLibraryModules) {
    ASSERT_FALSE(kLibraryModules.empty());
    std::set<std::string> built(kLibraryModules.begin(), kLibraryModules.end());
    std::set<std::string> described;
    for (const auto& [module, statements] : documented())
        described.insert(module);
    EXPECT_EQ(built, described) << "the modules of shprobe_spirv and shprobe_render_spirv must each have one "
                                   "interface block in "
                                << SHPROBE_INTERFACE_DOC;
}

TEST(Interface, EveryModuleMatchesItsReflection) {
    for (const std::string& module : kLibraryModules) {
        SCOPED_TRACE(module);
        auto found = documented().find(module);
        if (found == documented().end()) continue; // reported by DocumentsExactlyTheLibraryModules
        Statements reflected = reflectModule(std::string(SHPROBE_SPIRV_DIR) + "/" + module + ".spv");
        const Statements& written = found->second;
        EXPECT_TRUE(written == reflected)
            << module << ".spv against INTERFACE.md\n  in the module, not in the document:"
            << listDifference(reflected, written)
            << "\n  in the document, not in the module:" << listDifference(written, reflected);
    }
}

// The checker itself: each kind of drift in reduce.comp's block is caught.
TEST(Interface, CheckerCatchesDrift) {
    const std::string text = readFile(SHPROBE_INTERFACE_DOC);
    const Statements reflected = reflectModule(std::string(SHPROBE_SPIRV_DIR) + "/reduce.comp.spv");
    ASSERT_EQ(parseDocument(text).at("reduce.comp"), reflected);
    // The first `from` after "module reduce.comp" becomes `to`.
    auto drifted = [&](const std::string& from, const std::string& to) {
        std::string changed = text;
        size_t at = changed.find(from, changed.find("module reduce.comp"));
        EXPECT_NE(at, std::string::npos) << from;
        if (at != std::string::npos) changed.replace(at, from.size(), to);
        return parseDocument(changed).at("reduce.comp");
    };
    EXPECT_NE(drifted("member params.partialCount uint 0", "member params.partialCount uint 4"), reflected);
    EXPECT_NE(drifted("push_constant 4", "push_constant 8"), reflected);
    EXPECT_NE(drifted("storage_buffer 0 1 writeonly", "storage_buffer 0 2 writeonly"), reflected);
    EXPECT_NE(drifted("storage_buffer 0 0 readonly", "storage_buffer 0 0 readwrite"), reflected);
    EXPECT_NE(drifted("capabilities Shader", "capabilities Shader GroupNonUniform"), reflected);
    EXPECT_NE(drifted("spec 1 uint 3", "spec 2 uint 3"), reflected);
    EXPECT_NE(drifted("workgroup spec:0 1 1", "workgroup 64 1 1"), reflected);
    EXPECT_NE(drifted("member coefficients vec4[] 0 stride 16\n", ""), reflected);
}

} // namespace
