// Lets one header define GPU structs, constants and small functions for both C++ and GLSL.
// In C++ the GLSL vector names come from GLM (same names and layout), inside namespace shprobe::glsl.
#ifndef SHPROBE_SHARED_H
#define SHPROBE_SHARED_H

#ifdef __cplusplus
#include <glm/glm.hpp>
#define SHPROBE_BEGIN                                                                                        \
    namespace shprobe::glsl {                                                                                \
    using namespace glm;                                                                                     \
    using uint = glm::uint;
#define SHPROBE_END }
#define SHPROBE_FN inline
#define SHPROBE_CONST constexpr
#else
#define SHPROBE_BEGIN
#define SHPROBE_END
#define SHPROBE_FN
#define SHPROBE_CONST const
#endif

#endif
