// JSON read with a bound on its nesting, for every reader of JSON files (probe files, probe
// volumes, glTF): nlohmann's parser recurses once per level, so a hostile file could exhaust the
// stack. Internal to the libraries (not installed: it includes nlohmann/json).
#pragma once
#include <nlohmann/json.hpp>

#include <string>
#include <string_view>

namespace shprobe {

// Thrown by parseBoundedJson for text nested deeper than it allows.
struct JsonTooDeep {};

// Parses `text`, throwing JsonTooDeep past `maxDepth` levels and nlohmann::json::exception for
// anything else it refuses (syntax, numbers beyond double's range).
nlohmann::json parseBoundedJson(std::string_view text, int maxDepth);

// `value` as compact JSON text. A file name need not be UTF-8, which JSON text must be: bytes that
// are not are written as U+FFFD (nlohmann's plain dump throws at them).
template <typename Json> std::string jsonText(const Json& value) {
    return value.dump(-1, ' ', false, Json::error_handler_t::replace);
}
inline std::string jsonText(const std::string& text) {
    return jsonText(nlohmann::json(text));
}

// nlohmann's "[json.exception.parse_error.101] parse error at line 3, column 1: ..." without the
// bracketed prefix.
std::string jsonProblem(const nlohmann::json::exception& error);

// The member `field` of a JSON object; throws Error(Input) "NAME: missing field \"FIELD\"".
const nlohmann::json& requireField(const nlohmann::json& object, const char* field, const std::string& name);
// The same, a string; throws Error(Input) "NAME: field \"FIELD\" must be a string" for another type.
std::string requireString(const nlohmann::json& object, const char* field, const std::string& name);

} // namespace shprobe
