# Shared settings for every ivoct target.

# Warnings and floating-point rules go on the targets through this interface
# library rather than into CMAKE_C_FLAGS, so only our own code gets them.
# -ffp-contract=off: a fused multiply-add skips the rounding that the outward
# widening of expr/interval.h accounts for, so it would break the enclosures.
add_library(ivoct_options INTERFACE)
target_compile_options(ivoct_options INTERFACE
    -Wall -Wextra -Werror -pedantic -ffp-contract=off)
if(IVOCT_SANITIZE)
    set(_ivoct_san -fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer)
    target_compile_options(ivoct_options INTERFACE ${_ivoct_san})
    target_link_options(ivoct_options INTERFACE ${_ivoct_san})
endif()

# Flags, include root and libm for any target (libraries, the CLI, tests).
# Sources include headers from the tree root: #include "expr/tape.h".
function(ivoct_target_defaults target)
    target_link_libraries(${target} PRIVATE ivoct_options)
    target_include_directories(${target} PUBLIC $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}>)
    target_link_libraries(${target} PUBLIC m)
endfunction()

# ivoct_module(<target> [HEADERS h...])
# Called by a module folder after add_library(<target> STATIC ...): applies the
# defaults, registers the library (the CLI, the tests and libivoct link all
# registered ones) and installs the public HEADERS under include/ivoct/<folder>/.
# Internal headers are simply not listed.
function(ivoct_module target)
    cmake_parse_arguments(ARG "" "" "HEADERS" ${ARGN})
    ivoct_target_defaults(${target})
    # PIC so the same objects also go into the shared libivoct.
    set_target_properties(${target} PROPERTIES POSITION_INDEPENDENT_CODE ON)
    target_link_libraries(${target} PUBLIC OpenMP::OpenMP_C)
    set_property(GLOBAL APPEND PROPERTY IVOCT_LIBRARIES ${target})
    if(ARG_HEADERS)
        cmake_path(GET CMAKE_CURRENT_SOURCE_DIR FILENAME folder)
        install(FILES ${ARG_HEADERS} DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/ivoct/${folder})
    endif()
endfunction()
