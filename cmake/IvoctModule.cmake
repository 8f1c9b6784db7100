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

# The SIMD paths: portable everywhere, and on x86-64 also avx2 and avx512 (chosen at
# run time by expr/eval.c; tests/ runs some tests once per path).
if(CMAKE_SYSTEM_PROCESSOR MATCHES "^(x86_64|AMD64|amd64)$")
    set(IVOCT_SIMD_PATHS portable avx2 avx512)
else()
    set(IVOCT_SIMD_PATHS portable)
endif()

# ivoct_simd_kernels(<target> <stem>)
# Adds <stem>_<path>.c of the current folder to <target> for each SIMD path: one
# source (a header each of them includes) compiled once per path with that path's
# flags, so every path does the same IEEE operations in the same order and only the
# vector width differs.  On x86-64 the target gets IVOCT_SIMD_X86.
#   - The flags name instruction sets, not a CPU, so the code runs on any CPU that
#     has them; -mprefer-vector-width=512 because gcc otherwise keeps AVX-512 code
#     at 256 bits.  No -mfma: contraction is off anyway (ivoct_options above).
#   - -fno-trapping-math: without it gcc will not turn the selects of the outward
#     rounding (x == INFINITY ? DBL_MAX : y) into vector blends, except with
#     AVX-512's masks, so the lane loops stay scalar.  It lets the compiler assume
#     no FP trap is enabled (none ever is) and changes no result: contraction,
#     reassociation and the rounding mode are untouched.  (clang's default.)
#   - gcc's default inlining limits stop short of the larger lane loops (an iv_mul
#     left out of line keeps its loop scalar), hence the params.
#   - clang: -Wno-pass-failed, because a loop whose vectorisation the source asks
#     for (K_LANES in ilie/affine_kernels.h) stays scalar under the sanitizers'
#     instrumentation, and clang warns about it.
function(ivoct_simd_kernels target stem)
    foreach(path IN LISTS IVOCT_SIMD_PATHS)
        ivoct_simd_kernel_source(${target} ${CMAKE_CURRENT_SOURCE_DIR}/${stem}_${path}.c ${path})
    endforeach()
    if("avx2" IN_LIST IVOCT_SIMD_PATHS)
        target_compile_definitions(${target} PRIVATE IVOCT_SIMD_X86)
    endif()
endfunction()

# ivoct_simd_kernel_source(<target> <source> <path>)
# Adds one source to <target>, compiled with the flags of SIMD path <path>
# (above): for a unit of a path's passes beside <stem>_<path>.c.
function(ivoct_simd_kernel_source target src path)
    target_sources(${target} PRIVATE ${src})
    set_property(SOURCE ${src} APPEND PROPERTY COMPILE_OPTIONS "-fno-trapping-math"
        "$<$<C_COMPILER_ID:GNU>:--param=max-inline-insns-single=2000;--param=inline-unit-growth=400;--param=large-function-growth=1000>"
        "$<$<C_COMPILER_ID:Clang>:-Wno-pass-failed>")
    if(path STREQUAL "avx2")
        set_property(SOURCE ${src} APPEND PROPERTY COMPILE_OPTIONS "-mavx2")
    elseif(path STREQUAL "avx512")
        set_property(SOURCE ${src} APPEND PROPERTY COMPILE_OPTIONS
            "-mavx512f;-mavx512dq;-mavx512vl;-mavx512bw;-mprefer-vector-width=512")
    endif()
endfunction()
