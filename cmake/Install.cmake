# cmake --install: the libraries, their headers, the SPIR-V modules, the GLSL includes, a CMake
# package and a pkg-config file, so that another project can do
#
#   find_package(shprobe 0.1 REQUIRED)
#   target_link_libraries(app PRIVATE shprobe::shprobe)   # or only read ${shprobe_SPIRV_DIR}/*.spv
#
# or `c++ -std=c++20 app.cpp $(pkg-config --cflags --libs shprobe)` (add --static after a static
# build), and include <shprobe/formats/probe_file.h>, <shprobe/version.h>, ...
#
# Installed layout (GNUInstallDirs; <prefix> is CMAKE_INSTALL_PREFIX or `--prefix`):
#   bin/shprobe                                the command-line program (RUNPATH $ORIGIN/../lib when
#                                              the libraries are shared); needs no window system
#   bin/shprobe-view                           the viewer, which `shprobe view` runs from shprobe's
#                                              folder; the only file that needs GLFW (same RUNPATH; not
#                                              built with -DSHPROBE_BUILD_VIEWER=OFF)
#   bin/shprobe-bench                          `shprobe bench`'s measurements alone: links no project
#                                              library (no RUNPATH) and needs only the Vulkan loader
#                                              (loaded at run, as shprobe does), so the file can be
#                                              copied alone to a GPU machine
#   lib/libshprobe{_sh,,_render}.a             shprobe_sh, shprobe, shprobe_render (exported as
#     or .so -> .so.0.1 -> .so.0.1.0           shprobe::sh, shprobe::shprobe, shprobe::render): static
#                                              by default, shared with -DBUILD_SHARED_LIBS=ON (soname
#                                              major.minor, RUNPATH $ORIGIN)
#   lib/libshprobe{,_scene,_render}_spirv.a    the embedded modules, static and position-independent in
#                                              both builds (exported as shprobe::spirv,
#                                              shprobe::scene_spirv and shprobe::render_spirv; inside
#                                              the .so files when shared)
#   include/shprobe/<floor>/*.h                C++ headers of src/'s floors, included as
#                                              <shprobe/sh/basis.h> (include dir: include); they
#                                              include each other as "sh/coefficients.h", as in src/
#                                              (include dir: include/shprobe)
#   include/shprobe/version.h                  SHPROBE_VERSION_MAJOR/MINOR/PATCH/STRING (generated)
#   include/shprobe/shprobe{,_scene,_render}_spirv.h  the embedded-module declarations (generated)
#   include/shprobe/glsl/                      src/glsl: the C++/GLSL shared headers
#                                              (<shprobe/glsl/gpu_interface.h>) and the GLSL includes
#   share/shprobe/spirv/*.spv, INTERFACE.md    the modules of shprobe_spirv and shprobe_render_spirv
#                                              (the scene capture's stay inside), and their contract
#   share/shprobe/shaders/*.glsl               the modules' sources (compile with -I include/shprobe/glsl)
#   lib/cmake/shprobe/                         shprobeConfig.cmake, shprobeConfigVersion.cmake (same
#                                              major.minor: 0.x may break the interface), the targets
#   lib/pkgconfig/shprobe.pc                   Cflags -I<prefix>/include{,/shprobe}; Libs render, shprobe, sh;
#                                              Requires glm, Requires.private vulkan (its
#                                              headers); static builds add Libs.private
#                                              (the spirv archives)
#   lib/shprobe/libshprobe_exr.so              the OpenEXR plugin (image/exr_plugin.h), loaded when
#                                              the first EXR file is read or written
#   lib/shprobe/libshprobe_oiio.so             the OpenImageIO plugin (image/oiio_plugin.h), loaded
#                                              only for formats shprobe does not read itself
#   lib/shprobe/libshprobe_embree.so           the Embree plugin (scene/embree_rays.h), loaded when
#                                              rays are first cast on the CPU
#   share/doc/shprobe/LICENSE                  the license
#   share/doc/shprobe/conventions.md           the SH, cube-map and coefficient-file conventions
#
# The config file sets shprobe_SPIRV_DIR, shprobe_INTERFACE_DOC, shprobe_GLSL_DIR and shprobe_MODULES,
# and finds only what the installed headers include (Vulkan, glm): no installed header includes
# OpenEXR, OpenImageIO or nlohmann/json, which the plugins alone link or the libraries use inside
# (see "what a static build's consumers link" below for the static case). The GLFW viewer (shprobe_viewer) stays private: the
# installed libraries and bin/shprobe never need a window system; only bin/shprobe-view links it.
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
    shprobe_scene_spirv scene_spirv
    shprobe_render render
    shprobe_render_spirv render_spirv)

# The targets name source- and build-tree include directories, which an export may not carry.
# Keep each for the build tree only; install(TARGETS ... INCLUDES DESTINATION) below adds include/
# and include/shprobe/.
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
endfunction()

set(shprobe_export_targets "")
while(shprobe_installed_libraries)
    list(POP_FRONT shprobe_installed_libraries target export_name)
    shprobe_relocate_includes(${target})
    target_compile_features(${target} INTERFACE cxx_std_20) # the headers use std::span and friends
    set_target_properties(${target} PROPERTIES EXPORT_NAME ${export_name})
    list(APPEND shprobe_export_targets ${target})
endwhile()
get_target_property(shprobe_library_type shprobe TYPE) # STATIC_LIBRARY or SHARED_LIBRARY
# The programs that link the libraries, installed side by side: `shprobe view` runs shprobe-view from
# shprobe's folder. shprobe-bench, installed beside them, links none (so needs no RUNPATH).
set(shprobe_programs shprobe_cli)
if(TARGET shprobe_view_cli) # SHPROBE_BUILD_VIEWER
    list(APPEND shprobe_programs shprobe_view_cli)
endif()

# --- what a static build's consumers link --------------------------------------------------------
# A static library's PRIVATE dependencies are still link items of whatever links it, so CMake exports
# them as $<LINK_ONLY:...>, and the package config would have to find them. The libraries have none
# that a consumer needs: nlohmann_json and stb are header-only, included by no installed header, and
# linked as $<BUILD_INTERFACE:...>; OpenEXR and OpenImageIO are the plugins' alone
# (libshprobe_exr.so, libshprobe_oiio.so), loaded at run time, never linked by the libraries. This
# check keeps it so.
foreach(target IN LISTS shprobe_export_targets)
    get_target_property(links ${target} INTERFACE_LINK_LIBRARIES)
    foreach(item IN LISTS links)
        if(item MATCHES "^\\$<LINK_ONLY:(OpenEXR|Imath|OpenImageIO|nlohmann_json|stb)::")
            message(FATAL_ERROR "cmake/Install.cmake: ${target} links ${item}, which the package would "
                                "have to find for its consumers; link it as $<BUILD_INTERFACE:...>")
        endif()
    endforeach()
endforeach()

# --- shared libraries: sonames and run paths -----------------------------------------------------
# The soname carries major.minor, the compatibility shprobeConfigVersion.cmake promises (0.x: a minor
# version may break the interface), so a program built against 0.1 never loads a 0.2 library.
# In the build tree, CMake's build RPATH lets the programs and tests find the shared libraries.
# Installed, the program finds them in the prefix's library folder ($ORIGIN/../lib) and each library
# its sibling (libshprobe_render.so needs libshprobe.so; a RUNPATH serves only the dependencies of
# the file that carries it), so a prefix works wherever it is unpacked, without LD_LIBRARY_PATH.
if(shprobe_library_type STREQUAL "SHARED_LIBRARY")
    file(RELATIVE_PATH bin_to_lib ${CMAKE_INSTALL_FULL_BINDIR} ${CMAKE_INSTALL_FULL_LIBDIR})
    set_target_properties(${shprobe_programs} PROPERTIES INSTALL_RPATH "$ORIGIN/${bin_to_lib}")
    set_target_properties(shprobe_sh shprobe shprobe_render PROPERTIES
        INSTALL_RPATH "$ORIGIN"
        VERSION ${PROJECT_VERSION}
        SOVERSION ${PROJECT_VERSION_MAJOR}.${PROJECT_VERSION_MINOR})
endif()

install(TARGETS ${shprobe_export_targets}
    EXPORT shprobeTargets
    ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
    LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
    INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} ${SHPROBE_INSTALL_INCLUDEDIR})
install(TARGETS ${shprobe_programs} shprobe_bench_cli RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(TARGETS shprobe_exr shprobe_oiio shprobe_embree # image/*_plugin.h, scene/embree_rays.h
    LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}/shprobe)

# --- headers -------------------------------------------------------------------------------------
# The public API: the headers of the floors the installed libraries hold, laid out as in src/ under
# include/shprobe/, less those of the libraries' insides (their Vulkan commands, the glTF reader's
# tinygltf side, their JSON reading), the Embree reference and plugin and the viewer's window-system headers. glsl/ holds the
# C++/GLSL shared headers and the GLSL includes.
foreach(folder common glsl sh vk image formats scene gpu render)
    install(DIRECTORY ${PROJECT_SOURCE_DIR}/src/${folder}/
        DESTINATION ${SHPROBE_INSTALL_INCLUDEDIR}/${folder}
        FILES_MATCHING PATTERN "*.h" PATTERN "*.glsl"
        PATTERN "vulkan_commands.h" EXCLUDE # the libraries' own Vulkan commands, named as the loader's
        PATTERN "json_reading.h" EXCLUDE
        PATTERN "gltf_geometry.h" EXCLUDE
        PATTERN "gltf_schema.h" EXCLUDE
        PATTERN "reference_tracer.h" EXCLUDE
        PATTERN "embree_rays.h" EXCLUDE # the plugin's and the reference's own, not in the libraries
        PATTERN "swapchain.h" EXCLUDE
        PATTERN "viewer.h" EXCLUDE
        PATTERN "viewer_frames.h" EXCLUDE)
endforeach()
install(FILES
        ${SHPROBE_GENERATED_DIR}/shprobe/version.h
        ${SHPROBE_GENERATED_DIR}/shprobe/shprobe_spirv.h
        ${SHPROBE_GENERATED_DIR}/shprobe/shprobe_scene_spirv.h
        ${SHPROBE_GENERATED_DIR}/shprobe/shprobe_render_spirv.h
    DESTINATION ${SHPROBE_INSTALL_INCLUDEDIR})

# --- SPIR-V modules ------------------------------------------------------------------------------
# Exactly the modules embedded in the installed libraries (test-only modules that share the build's
# spirv/ folder stay out), found from the generated headers shprobe_compile_shaders adds to each
# library: <embed_dir>/project_comp.spv.h is spirv/project.comp.spv.
set(shprobe_modules "")
foreach(target shprobe_spirv shprobe_render_spirv) # the scene capture's modules are its own
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
# The modules' sources (INTERFACE.md, "Sources": glslangValidator --target-env vulkan1.1
# -I <prefix>/include/shprobe/glsl).
list(TRANSFORM shprobe_modules APPEND ".glsl" OUTPUT_VARIABLE shprobe_module_sources)
list(TRANSFORM shprobe_module_sources PREPEND "${PROJECT_SOURCE_DIR}/shaders/")
install(FILES ${shprobe_module_sources} DESTINATION ${CMAKE_INSTALL_DATADIR}/shprobe/shaders)

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

# What the installed headers include and the libraries link publicly; nothing else is needed
# (cmake/Install.cmake, "what a static build's consumers link").
include(CMakeFindDependencyMacro)
find_dependency(Vulkan)
find_dependency(glm CONFIG)
if(NOT TARGET glm::glm AND TARGET glm) # some of Debian's glm configs define only `glm`
    add_library(glm::glm ALIAS glm)
endif()

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

# --- pkg-config ----------------------------------------------------------------------------------
# shprobe.pc names absolute paths, and `cmake --install --prefix` picks the prefix after configure:
# the file is configured here with everything but the prefix, which the install step fills in.
set(SHPROBE_INSTALL_PKGCONFIGDIR ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
foreach(dir LIBDIR INCLUDEDIR DATADIR)
    if(IS_ABSOLUTE "${CMAKE_INSTALL_${dir}}")
        set(SHPROBE_PC_${dir} "${CMAKE_INSTALL_${dir}}")
    else()
        set(SHPROBE_PC_${dir} "\${prefix}/${CMAKE_INSTALL_${dir}}")
    endif()
endforeach()
# Libraries every link needs come in Libs. A static build's links also need the embedded modules
# (pkg-config --static); a shared build's libraries carry them.
if(shprobe_library_type STREQUAL "STATIC_LIBRARY")
    set(SHPROBE_PC_PRIVATE "Libs.private: -lshprobe_render_spirv -lshprobe_scene_spirv -lshprobe_spirv")
else()
    set(SHPROBE_PC_PRIVATE "")
endif()
set(SHPROBE_PC_PREFIX "@CMAKE_INSTALL_PREFIX@") # for the install step's configure_file
configure_file(${PROJECT_SOURCE_DIR}/cmake/shprobe.pc.in ${PROJECT_BINARY_DIR}/pkgconfig/shprobe.pc.in @ONLY)
install(CODE "set(shprobe_pc_template \"${PROJECT_BINARY_DIR}/pkgconfig/shprobe.pc.in\")
set(shprobe_pc_destination \"${SHPROBE_INSTALL_PKGCONFIGDIR}\")")
install(CODE [[
    if(NOT IS_ABSOLUTE "${shprobe_pc_destination}")
        set(shprobe_pc_destination "${CMAKE_INSTALL_PREFIX}/${shprobe_pc_destination}")
    endif()
    get_filename_component(shprobe_pc_folder "${shprobe_pc_template}" DIRECTORY)
    configure_file("${shprobe_pc_template}" "${shprobe_pc_folder}/shprobe.pc" @ONLY)
    file(INSTALL "${shprobe_pc_folder}/shprobe.pc" DESTINATION "${shprobe_pc_destination}")
]])

# --- license and conventions ---------------------------------------------------------------------
install(FILES ${PROJECT_SOURCE_DIR}/LICENSE ${PROJECT_SOURCE_DIR}/docs/conventions.md
        DESTINATION ${CMAKE_INSTALL_DATADIR}/doc/shprobe)
