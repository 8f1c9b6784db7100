# Included by the top-level CMakeLists.txt when export/ is part of the build.
#
# export/ is C++17 (VTK and OpenVDB are C++ libraries) behind a C header.  CMake
# wants a language enabled in the directory that holds every target compiled or
# *linked* with it: the CLI (cli/), the tests and libivoct link ivoct_export, so
# enabling C++ in export/ alone leaves them without C++ link rules.  Hence this
# file, included at the top; the C++ standard and flags stay set in export/ only.
#
# The C++ compiler follows the C one unless given (-DCMAKE_CXX_COMPILER, $CXX):
# clang -> clang++, gcc -> g++, so the sanitizer build links a single runtime.
if(NOT CMAKE_CXX_COMPILER AND NOT DEFINED ENV{CXX})
    get_filename_component(_ivoct_cc_dir "${CMAKE_C_COMPILER}" DIRECTORY)
    get_filename_component(_ivoct_cc_name "${CMAKE_C_COMPILER}" NAME)
    set(_ivoct_cxx_name "")
    if(_ivoct_cc_name MATCHES "^(.*-)?clang(-[0-9.]+)?$")
        set(_ivoct_cxx_name "${CMAKE_MATCH_1}clang++${CMAKE_MATCH_2}")
    elseif(_ivoct_cc_name MATCHES "^(.*-)?gcc(-[0-9.]+)?$")
        set(_ivoct_cxx_name "${CMAKE_MATCH_1}g++${CMAKE_MATCH_2}")
    elseif(_ivoct_cc_name STREQUAL "cc")
        set(_ivoct_cxx_name "c++")
    endif()
    if(_ivoct_cxx_name AND EXISTS "${_ivoct_cc_dir}/${_ivoct_cxx_name}")
        set(CMAKE_CXX_COMPILER "${_ivoct_cc_dir}/${_ivoct_cxx_name}")
    endif()
endif()
enable_language(CXX)
if(NOT CMAKE_CXX_COMPILER_ID STREQUAL CMAKE_C_COMPILER_ID)
    message(WARNING "C compiler ${CMAKE_C_COMPILER_ID}, C++ compiler ${CMAKE_CXX_COMPILER_ID}: "
        "the sanitizer build needs both of one family (set CMAKE_CXX_COMPILER)")
endif()
