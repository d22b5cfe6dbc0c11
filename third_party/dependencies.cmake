# Dependency glue: every external package comes from Debian and is found here, once.
# Targets used by the rest of the build:
#   Vulkan::Headers, Vulkan::glslangValidator, SPIRV_VAL (program path), glm::glm,
#   OpenImageIO::OpenImageIO, OpenEXR::OpenEXR, stb::stb, nlohmann_json::nlohmann_json,
#   CLI11::CLI11, GTest::gtest_main, tinygltf::headers, embree.
find_package(Vulkan 1.3 REQUIRED COMPONENTS glslangValidator)
find_program(SPIRV_VAL spirv-val REQUIRED)
find_package(glm CONFIG REQUIRED)
find_package(OpenImageIO CONFIG REQUIRED)
# EXR, Radiance HDR, PNG and JPEG are read and written without OpenImageIO (image/codec.h), whose
# start-up (about 1 s: 264 shared libraries) a run that meets only those formats need not pay.
# OpenEXR 3.1 (libopenexr-dev) reads and writes EXR; its config gives OpenEXR::OpenEXR (with Iex,
# IlmThread, Imath and zlib).
find_package(OpenEXR CONFIG REQUIRED)
# stb_image and stb_image_write (libstb-dev) for HDR, PNG and JPEG, header-only: compiled into
# src/image/stb_codec.cpp with only the three decoders shprobe reads. Debian's libstb.so (every stb
# library, every decoder) is not linked. stb::stb carries the include folder only, as a system
# folder (an imported target's are), so that stb's own code is compiled without our warnings.
find_path(STB_INCLUDE_DIR stb_image.h PATH_SUFFIXES stb REQUIRED)
if(NOT TARGET stb::stb)
    add_library(stb::stb INTERFACE IMPORTED)
    set_target_properties(stb::stb PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${STB_INCLUDE_DIR}")
endif()
find_package(nlohmann_json CONFIG REQUIRED)
# tinygltf (libtinygltf-dev) reads glTF scenes. Debian ships it as libtinygltf.so too; shprobe
# compiles the header's implementation once (src/scene/tinygltf.cpp) without its image and JSON
# copies: images are decoded by shprobe's readers, JSON by nlohmann-json, and no library is added
# to the program's start. tinygltf::headers carries the include folders, as system folders.
find_path(TINYGLTF_INCLUDE_DIR tiny_gltf.h REQUIRED)
find_path(NLOHMANN_INCLUDE_DIR json.hpp PATH_SUFFIXES nlohmann REQUIRED)
if(NOT TARGET tinygltf::headers)
    add_library(tinygltf::headers INTERFACE IMPORTED)
    set_target_properties(tinygltf::headers PROPERTIES
        INTERFACE_INCLUDE_DIRECTORIES "${TINYGLTF_INCLUDE_DIR};${NLOHMANN_INCLUDE_DIR}")
endif()
# Embree 3 (libembree-dev) casts the rays of the cpu backends (its plugin, scene/ray_caster.h) and of
# the scene probes' reference (target `embree`).
find_package(embree 3 CONFIG REQUIRED)
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
