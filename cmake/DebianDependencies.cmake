# Run by cpack (CPACK_PRE_BUILD_SCRIPTS) once the files are staged: dpkg-shlibdeps over every ELF
# file of the package, those of CPACK_SHPROBE_RECOMMENDED_FILES as -dRecommends and the rest as
# -dDepends, into CPACK_DEBIAN_PACKAGE_DEPENDS and CPACK_DEBIAN_PACKAGE_RECOMMENDS (cmake/Package.cmake
# says which file is which and why). dpkg-shlibdeps leaves out of Recommends what Depends has.
set(root "${CPACK_TEMPORARY_DIRECTORY}")
set(prefix "${CPACK_PACKAGING_INSTALL_PREFIX}")
string(REGEX REPLACE "^/" "" prefix "${prefix}")

find_program(SHPROBE_DPKG_SHLIBDEPS dpkg-shlibdeps)
if(NOT SHPROBE_DPKG_SHLIBDEPS)
    message(FATAL_ERROR "cmake/DebianDependencies.cmake: dpkg-shlibdeps (package dpkg-dev) is needed "
                        "to compute the package's dependencies")
endif()

set(depends_files "")
set(recommends_files "")
file(GLOB_RECURSE files LIST_DIRECTORIES false RELATIVE "${root}" "${root}/*")
foreach(file IN LISTS files)
    if(IS_SYMLINK "${root}/${file}")
        continue() # a shared library's soname links: the file itself is listed too
    endif()
    file(READ "${root}/${file}" magic LIMIT 4 HEX)
    if(NOT magic STREQUAL "7f454c46") # ELF; the static archives and the rest are not
        continue()
    endif()
    string(REPLACE "${prefix}/" "" installed "${file}")
    list(FIND CPACK_SHPROBE_RECOMMENDED_FILES "${installed}" recommended) # cpack sets no policies: no IN_LIST
    if(recommended GREATER -1)
        list(APPEND recommends_files "${file}")
    else()
        list(APPEND depends_files "${file}")
    endif()
endforeach()
if(NOT depends_files)
    message(FATAL_ERROR "cmake/DebianDependencies.cmake: no ELF file staged in ${root}")
endif()

# dpkg-shlibdeps wants a debian/control, and finds the package's own libraries ($ORIGIN) from the
# DEBIAN folder above them; both are removed before the package is made.
file(WRITE "${root}/debian/control" "")
file(MAKE_DIRECTORY "${root}/DEBIAN")
set(arguments -O --ignore-missing-info -dDepends ${depends_files})
if(recommends_files)
    list(APPEND arguments -dRecommends ${recommends_files})
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -E env LC_ALL=C ${SHPROBE_DPKG_SHLIBDEPS} ${arguments}
    WORKING_DIRECTORY "${root}" RESULT_VARIABLE result OUTPUT_VARIABLE output ERROR_VARIABLE errors)
file(REMOVE_RECURSE "${root}/debian" "${root}/DEBIAN")
if(NOT result EQUAL 0)
    message(FATAL_ERROR "cmake/DebianDependencies.cmake: dpkg-shlibdeps ${arguments} failed:\n${errors}")
endif()

foreach(field Depends Recommends)
    string(TOUPPER ${field} FIELD)
    if(output MATCHES "shlibs:${field}=([^\n]*)")
        set(found "${CMAKE_MATCH_1}")
        if(CPACK_DEBIAN_PACKAGE_${FIELD})
            string(APPEND found ", ${CPACK_DEBIAN_PACKAGE_${FIELD}}")
        endif()
        set(CPACK_DEBIAN_PACKAGE_${FIELD} "${found}")
    endif()
    message(STATUS "${field}: ${CPACK_DEBIAN_PACKAGE_${FIELD}}")
endforeach()
