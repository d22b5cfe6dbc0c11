# cmake --install: the libraries, their headers, the SPIR-V modules, the GLSL includes and a CMake
# package, so that another project can do
#
#   find_package(shprobe 0.1 REQUIRED)
#   target_link_libraries(app PRIVATE shprobe::shprobe)   # or only read ${shprobe_SPIRV_DIR}/*.spv
#
# Installed layout (GNUInstallDirs; <prefix> is CMAKE_INSTALL_PREFIX or `--prefix`):
#   bin/shprobe                                the command-line program
#   lib/libshprobe*.a                          shprobe_sh, shprobe, shprobe_spirv, shprobe_render,
#                                              shprobe_render_spirv (static; exported as shprobe::sh,
#                                              shprobe::shprobe, shprobe::spirv, shprobe::render,
#                                              shprobe::render_spirv)
#   include/shprobe/{sh,io,image,vk,gpu,render}/*.h   C++ headers, included as <shprobe/sh/basis.h>
#                                              (include dir: include), as in the build tree
#   include/shprobe/shprobe_spirv.h            the embedded-module declarations (generated)
#   include/shprobe/glsl/                      shaders/include: the C++/GLSL shared headers
#                                              (<shprobe/glsl/gpu_interface.h>) and the GLSL includes
#   share/shprobe/spirv/*.spv, INTERFACE.md    every module built into the libraries, and its contract
#   lib/cmake/shprobe/                         shprobeConfig.cmake, version file, exported targets
#
# The config file sets shprobe_SPIRV_DIR, shprobe_INTERFACE_DOC, shprobe_GLSL_DIR and shprobe_MODULES.
# The GLFW viewer (shprobe_viewer) stays private: the installed libraries never need a window system.
#
# Only the top-level project installs anything (as VMA does). This file runs after every target is
# defined (the last line of the top-level CMakeLists.txt), so it can adjust their properties here.
if(NOT PROJECT_IS_TOP_LEVEL)
    return()
endif()

include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(SHPROBE_INSTALL_INCLUDEDIR ${CMAKE_INSTALL_INCLUDEDIR}/shprobe)
set(SHPROBE_INSTALL_GLSLDIR ${SHPROBE_INSTALL_INCLUDEDIR}/glsl)
set(SHPROBE_INSTALL_SPIRVDIR ${CMAKE_INSTALL_DATADIR}/shprobe/spirv)
set(SHPROBE_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/shprobe)

# library target -> exported name (shprobe::<name>)
set(shprobe_installed_libraries
    shprobe_sh sh
    shprobe shprobe
    shprobe_spirv spirv
    shprobe_render render
    shprobe_render_spirv render_spirv)

# The targets name source- and build-tree include directories, which an export may not carry.
# Keep each for the build tree only and add its installed counterpart.
function(shprobe_relocate_includes target)
    get_target_property(includes ${target} INTERFACE_INCLUDE_DIRECTORIES)
    if(NOT includes)
        return()
    endif()
    set(relocated "")
    foreach(dir IN LISTS includes)
        if(dir MATCHES "^\\$<")
            list(APPEND relocated "${dir}")
        else()
            list(APPEND relocated "$<BUILD_INTERFACE:${dir}>")
        endif()
    endforeach()
    set_target_properties(${target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${relocated}")
    target_include_directories(${target} INTERFACE $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
endfunction()

set(shprobe_export_targets "")
while(shprobe_installed_libraries)
    list(POP_FRONT shprobe_installed_libraries target export_name)
    shprobe_relocate_includes(${target})
    target_compile_features(${target} INTERFACE cxx_std_20) # the headers use std::span and friends
    set_target_properties(${target} PROPERTIES EXPORT_NAME ${export_name})
    list(APPEND shprobe_export_targets ${target})
endwhile()

install(TARGETS ${shprobe_export_targets}
    EXPORT shprobeTargets
    ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
    LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
    INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(TARGETS shprobe_cli RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})

# --- headers -------------------------------------------------------------------------------------
# The public API: everything under these folders of src/ except the viewer's window-system headers.
foreach(folder sh io image vk gpu render)
    install(DIRECTORY ${PROJECT_SOURCE_DIR}/src/${folder}/
        DESTINATION ${SHPROBE_INSTALL_INCLUDEDIR}/${folder}
        FILES_MATCHING PATTERN "*.h"
        PATTERN "swapchain.h" EXCLUDE
        PATTERN "viewer.h" EXCLUDE
        PATTERN "viewer_frames.h" EXCLUDE)
endforeach()
install(FILES
        ${PROJECT_BINARY_DIR}/generated/shprobe/shprobe_spirv.h
        ${PROJECT_BINARY_DIR}/generated/shprobe/shprobe_render_spirv.h
    DESTINATION ${SHPROBE_INSTALL_INCLUDEDIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/shaders/include/ DESTINATION ${SHPROBE_INSTALL_GLSLDIR})

# --- SPIR-V modules ------------------------------------------------------------------------------
# Exactly the modules embedded in the installed libraries (test-only modules that share the build's
# spirv/ folder stay out), found from the generated headers shprobe_compile_shaders adds to each
# library: <embed_dir>/project_comp.spv.h is spirv/project.comp.spv.
set(shprobe_modules "")
foreach(target shprobe_spirv shprobe_render_spirv)
    get_target_property(sources ${target} SOURCES)
    foreach(source IN LISTS sources)
        if(source MATCHES "/([a-z0-9_]+)_([a-z]+)\\.spv\\.h$")
            list(APPEND shprobe_modules "${CMAKE_MATCH_1}.${CMAKE_MATCH_2}")
        endif()
    endforeach()
endforeach()
if(NOT shprobe_modules)
    message(FATAL_ERROR "cmake/Install.cmake: found no SPIR-V module in shprobe_spirv's sources")
endif()
list(TRANSFORM shprobe_modules APPEND ".spv" OUTPUT_VARIABLE shprobe_module_files)
list(TRANSFORM shprobe_module_files PREPEND "${PROJECT_BINARY_DIR}/spirv/")
install(FILES ${shprobe_module_files} ${PROJECT_SOURCE_DIR}/shaders/INTERFACE.md
    DESTINATION ${SHPROBE_INSTALL_SPIRVDIR})

# --- CMake package -------------------------------------------------------------------------------
install(EXPORT shprobeTargets NAMESPACE shprobe:: DESTINATION ${SHPROBE_INSTALL_CMAKEDIR})

# The config template lives here so that the install rules stay in one file; written verbatim,
# configure_package_config_file fills in the @...@ values.
set(shprobe_config_template ${PROJECT_BINARY_DIR}/shprobeConfig.cmake.in)
file(WRITE ${shprobe_config_template} [==[
# shprobe's CMake package. Targets: shprobe::shprobe (library: image I/O, probe files, Vulkan
# context, GPU bake), shprobe::sh (SH math and the CPU reference), shprobe::render (offscreen
# renderer), shprobe::spirv and shprobe::render_spirv (embedded modules).
# Variables:
#   shprobe_SPIRV_DIR      folder of the .spv modules and INTERFACE.md
#   shprobe_INTERFACE_DOC  INTERFACE.md: bindings, push constants, specialization constants
#   shprobe_GLSL_DIR       the GLSL includes and the C++/GLSL shared headers (gpu_interface.h, ...)
#   shprobe_MODULES        the module names (project.comp, ...); files are <name>.spv
@PACKAGE_INIT@

# Before find_dependency: the dependencies' own configs may redefine PACKAGE_PREFIX_DIR.
set_and_check(shprobe_SPIRV_DIR "@PACKAGE_SHPROBE_INSTALL_SPIRVDIR@")
set_and_check(shprobe_INTERFACE_DOC "@PACKAGE_SHPROBE_INSTALL_SPIRVDIR@/INTERFACE.md")
set_and_check(shprobe_GLSL_DIR "@PACKAGE_SHPROBE_INSTALL_GLSLDIR@")
set(shprobe_MODULES "@shprobe_modules@")

include(CMakeFindDependencyMacro)
find_dependency(Vulkan)
find_dependency(glm CONFIG)
find_dependency(OpenImageIO CONFIG)
find_dependency(nlohmann_json CONFIG)

include("${CMAKE_CURRENT_LIST_DIR}/shprobeTargets.cmake")

check_required_components(shprobe)
]==])
configure_package_config_file(${shprobe_config_template} ${PROJECT_BINARY_DIR}/shprobeConfig.cmake
    INSTALL_DESTINATION ${SHPROBE_INSTALL_CMAKEDIR}
    PATH_VARS SHPROBE_INSTALL_SPIRVDIR SHPROBE_INSTALL_GLSLDIR)
# 0.x: a minor version may break the interface.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/shprobeConfigVersion.cmake
    COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/shprobeConfig.cmake ${PROJECT_BINARY_DIR}/shprobeConfigVersion.cmake
    DESTINATION ${SHPROBE_INSTALL_CMAKEDIR})

# --- license -------------------------------------------------------------------------------------
install(FILES ${PROJECT_SOURCE_DIR}/LICENSE DESTINATION ${CMAKE_INSTALL_DATADIR}/doc/shprobe)
