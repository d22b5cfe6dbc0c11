# cpack -G DEB: shprobe_<version>_amd64.deb, of exactly what `cmake --install` installs (see
# cmake/Install.cmake), under the prefix the build was configured with: the programs find their
# codec plugins in the configured <libdir>/shprobe, so the package keeps that prefix rather than
# moving the files. scripts/package.sh configures a build with CMAKE_INSTALL_PREFIX=/usr (Debian's
# multiarch libdir, lib/x86_64-linux-gnu) and runs cpack.
#
# Dependencies (cmake/DebianDependencies.cmake, run by cpack on the staged files): dpkg-shlibdeps
# over every ELF file, split by what needs it:
#   Depends      bin/shprobe, bin/shprobe-bench, the libraries and the OpenEXR plugin
#                (libshprobe_exr.so): EXR is the format the program reads and writes HDR images in
#   Recommends   the OpenImageIO plugin (libshprobe_oiio.so: other formats only; OpenImageIO brings
#                FFmpeg, OpenCV, DCMTK and OpenVDB) and the viewer bin/shprobe-view (GLFW, X11, GL),
#                so that `apt-get install --no-install-recommends` gives a headless baker; and
#                libvulkan1, the loader the GPU backend loads at run time (no file links it)
#   Suggests     mesa-vulkan-drivers (lavapipe: the GPU backend without a GPU), and libvulkan-dev
#                and libglm-dev, which the installed CMake package and shprobe.pc require of a
#                program built against the library
if(NOT PROJECT_IS_TOP_LEVEL)
    return()
endif()

set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME shprobe)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION}) # project(shprobe VERSION ...), as <shprobe/version.h>
# The Maintainer field; a distributor sets its own (-DCPACK_PACKAGE_CONTACT="Name <address>").
if(NOT CPACK_PACKAGE_CONTACT)
    set(CPACK_PACKAGE_CONTACT "The shprobe authors")
endif()
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "Bake HDR environments and scenes into spherical-harmonics light probes")
set(CPACK_PACKAGE_DESCRIPTION
    "shprobe projects HDR environments (EXR, Radiance HDR, PNG, JPEG: equirect maps, crosses, cube
faces) and glTF scenes onto spherical-harmonics radiance and irradiance probes, with Vulkan
compute shaders or on the CPU, and writes them as JSON or engine formats. The package holds the
program, the C++ libraries and headers, the SPIR-V modules with their sources, a CMake package
and a pkg-config file.")
set(CPACK_PACKAGING_INSTALL_PREFIX ${CMAKE_INSTALL_PREFIX})
set(CPACK_STRIP_FILES ON) # the programs and plugins; the static archives are kept whole
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT) # shprobe_0.1.0_amd64.deb
set(CPACK_DEBIAN_PACKAGE_SECTION graphics)
# dpkg-shlibdeps runs in cmake/DebianDependencies.cmake instead, which splits Depends and Recommends.
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS OFF)
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS libvulkan1)
set(CPACK_DEBIAN_PACKAGE_SUGGESTS "mesa-vulkan-drivers, libvulkan-dev, libglm-dev")
# Files named here (relative to the prefix) have their libraries recommended, not required. Only
# CPACK_* variables reach cpack.
set(CPACK_SHPROBE_RECOMMENDED_FILES
    ${CMAKE_INSTALL_BINDIR}/shprobe-view
    ${CMAKE_INSTALL_LIBDIR}/shprobe/libshprobe_oiio.so)
set(CPACK_PRE_BUILD_SCRIPTS ${PROJECT_SOURCE_DIR}/cmake/DebianDependencies.cmake)
include(CPack)
