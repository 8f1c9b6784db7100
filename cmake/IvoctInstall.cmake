# The combined shared library and everything `make install` puts in PREFIX:
#   bin/ivoct, lib/libivoct.so, include/ivoct/<module>/*.h,
#   lib/pkgconfig/ivoct.pc, lib/cmake/ivoct/ (find_package(ivoct) -> ivoct::ivoct).
include(CMakePackageConfigHelpers)

# libivoct is made of the objects of every module library (built once, with PIC).
set(_objects "")
foreach(lib IN LISTS IVOCT_LIBRARIES)
    list(APPEND _objects $<TARGET_OBJECTS:${lib}>)
endforeach()
add_library(libivoct SHARED ${_objects})
# Target libivoct (the CLI owns the name ivoct), file libivoct.so, imported as ivoct::ivoct.
set_target_properties(libivoct PROPERTIES EXPORT_NAME ivoct
    OUTPUT_NAME ivoct VERSION ${PROJECT_VERSION} SOVERSION ${PROJECT_VERSION_MAJOR})
ivoct_target_defaults(libivoct)
# The module libraries again, only for their external dependencies (inih, OpenMP, ...);
# their members are already in the objects above, so nothing is linked twice.
target_link_libraries(libivoct PRIVATE ${IVOCT_LIBRARIES})
# Installed headers include each other relatively ("../expr/error.h"), so users
# write #include <ivoct/scene/scene.h>.
target_include_directories(libivoct INTERFACE $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)

install(TARGETS libivoct EXPORT ivoctTargets
    LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
if(TARGET ivoct)
    install(TARGETS ivoct RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
endif()

set(_cmakedir ${CMAKE_INSTALL_LIBDIR}/cmake/ivoct)
install(EXPORT ivoctTargets NAMESPACE ivoct:: DESTINATION ${_cmakedir})
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/ivoctConfig.cmake.in
    ${PROJECT_BINARY_DIR}/ivoctConfig.cmake INSTALL_DESTINATION ${_cmakedir})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/ivoctConfigVersion.cmake
    COMPATIBILITY SameMajorVersion)
install(FILES ${PROJECT_BINARY_DIR}/ivoctConfig.cmake
              ${PROJECT_BINARY_DIR}/ivoctConfigVersion.cmake
        DESTINATION ${_cmakedir})

# The prefix is fixed at configure time: the Makefile's install target
# reconfigures with -DCMAKE_INSTALL_PREFIX=$(PREFIX) first.
configure_file(${PROJECT_SOURCE_DIR}/cmake/ivoct.pc.in ${PROJECT_BINARY_DIR}/ivoct.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/ivoct.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
