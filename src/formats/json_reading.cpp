#include "formats/json_reading.h"

#include "common/error.h"

namespace shprobe {

namespace {

// Throws JsonTooDeep where a value of `text` lies inside more than `maxDepth` arrays and objects
// (the depth nlohmann's parse callback would be given for it). Scanned apart from the parse: with a
// callback, nlohmann searches the parent of each object it ends for values to discard, so n objects
// in one array took n^2 steps (200,000 empty objects in a glTF's extras: 23 s).
void requireDepth(std::string_view text, int maxDepth) {
    int open = 0;
    bool inString = false, escaped = false;
    for (const char c : text) {
        if (inString) {
            if (escaped)
                escaped = false;
            else if (c == '\\')
                escaped = true;
            else if (c == '"')
                inString = false;
            continue;
        }
        if (c == ']' || c == '}') {
            --open;
            continue;
        }
        if (c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == ',' || c == ':') continue;
        if (open > maxDepth) throw JsonTooDeep{};
        if (c == '[' || c == '{') ++open;
        inString = c == '"';
    }
}

} // namespace

nlohmann::json parseBoundedJson(std::string_view text, int maxDepth) {
    requireDepth(text, maxDepth);
    return nlohmann::json::parse(text);
}

std::string jsonProblem(const nlohmann::json::exception& error) {
    std::string text = error.what();
    const size_t end = text.find("] ");
    return end == std::string::npos ? text : text.substr(end + 2);
}

const nlohmann::json& requireField(const nlohmann::json& object, const char* field, const std::string& name) {
    auto it = object.find(field);
    if (it == object.end()) throw Error(ErrorKind::Input, name + ": missing field \"" + field + "\"");
    return *it;
}

std::string requireString(const nlohmann::json& object, const char* field, const std::string& name) {
    const nlohmann::json& value = requireField(object, field, name);
    if (!value.is_string())
        throw Error(ErrorKind::Input, name + ": field \"" + field + "\" must be a string");
    return value.get<std::string>();
}

} // namespace shprobe
