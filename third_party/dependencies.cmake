# Dependency glue: every external package comes from Debian and is found here, once.
# Targets used by the rest of the build:
#   Vulkan::Vulkan, Vulkan::glslangValidator, SPIRV_VAL (program path), glm::glm,
#   OpenImageIO::OpenImageIO, nlohmann_json::nlohmann_json, CLI11::CLI11, GTest::gtest_main.
find_package(Vulkan 1.3 REQUIRED COMPONENTS glslangValidator)
find_program(SPIRV_VAL spirv-val REQUIRED)
find_package(glm CONFIG REQUIRED)
find_package(OpenImageIO CONFIG REQUIRED)
find_package(nlohmann_json CONFIG REQUIRED)
find_package(CLI11 CONFIG REQUIRED)
if(SHPROBE_BUILD_TESTS)
    find_package(GTest REQUIRED)
endif()

# Debian's glm config defines the target without the namespace on some versions.
if(NOT TARGET glm::glm AND TARGET glm)
    add_library(glm::glm ALIAS glm)
endif()

# Debian's OpenImageIO config names /usr/include/opencv4 as an include directory even when OpenCV
# is not installed (OpenCV is an optional plugin dependency we do not use); CMake rejects targets
# with missing include paths, so keep only the directories that exist.
foreach(oiio_target OpenImageIO::OpenImageIO OpenImageIO::OpenImageIO_Util)
    if(TARGET ${oiio_target})
        get_target_property(oiio_includes ${oiio_target} INTERFACE_INCLUDE_DIRECTORIES)
        if(oiio_includes)
            set(existing_includes "")
            foreach(dir IN LISTS oiio_includes)
                if(EXISTS "${dir}" OR dir MATCHES "^\\$<")
                    list(APPEND existing_includes "${dir}")
                endif()
            endforeach()
            set_target_properties(${oiio_target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${existing_includes}")
        endif()
    endif()
endforeach()
