#include "formats/json_reading.h"

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

} // namespace shprobe
