#include "formats/json_reading.h"

#include "common/error.h"

namespace shprobe {

nlohmann::json parseBoundedJson(std::string_view text, int maxDepth) {
    return nlohmann::json::parse(text, [maxDepth](int depth, nlohmann::json::parse_event_t, nlohmann::json&) {
        if (depth > maxDepth) throw JsonTooDeep{};
        return true;
    });
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
