# Precompiled headers for the DFN libraries and the tests.
#
# A DFI or a test file is a few hundred lines, but it parses ~200 000 lines of headers first
# (Eigen, OpenCV's core, yaml-cpp, fmt, GoogleTest and the DFN framework): most of a fresh
# build's time. Those headers are compiled once into a precompiled header per kind (`dfn`: the
# DFN object libraries; `test`: the GoogleTest programs) that every target of the kind reuses
# (CMake's REUSE_FROM), which takes a third off each such file's compile time.
#
# GCC uses a precompiled header only when the options that shape code match (it warns otherwise,
# -Winvalid-pch, and parses the headers as usual): every consumer is compiled position
# independent (-fPIC, as the DFN libraries already are, so that the test programs, -fPIE by
# default and -fPIC where PCL asks for it, agree on one setting), and the donors link the same
# libraries for the same definitions (fmt's FMT_SHARED, GoogleTest's GTEST_HAS_PTHREAD).
# ccache caches such files only with the sloppiness set in the compiler launcher (CMakeLists.txt).
# The framework's headers are named by absolute path: a test that does not include them itself
# (and lacks their include directory) still compiles with the header.
# CDFF_PRECOMPILED_HEADERS=OFF compiles every file on its own (e.g. to check a file's includes).
option(CDFF_PRECOMPILED_HEADERS "Reuse precompiled common headers in the DFNs and the tests" ON)

set(CDFF_PCH_COMMON_HEADERS
  <algorithm> <cmath> <memory> <optional> <string> <string_view> <vector>
  <Eigen/Core> <Eigen/Geometry> <opencv2/core.hpp> <yaml-cpp/yaml.h> <fmt/format.h>
  ${PROJECT_SOURCE_DIR}/src/cdff/dfn/node.hpp ${PROJECT_SOURCE_DIR}/src/cdff/dfn/parameters.hpp
  ${PROJECT_SOURCE_DIR}/src/cdff/dfn/registry.hpp)

# Defines the donor targets cdff_pch_dfn and cdff_pch_test (after cdff_dfn and
# cdff_types_opencv, before the DFN areas).
function(cdff_define_precompiled_headers)
  if(NOT CDFF_PRECOMPILED_HEADERS)
    return()
  endif()
  # A C++ and a C file: a consumer that also compiles C (a linked object library's, e.g. the DDS
  # types' generated code) needs the donor's C header too (a trivial one).
  set(sources ${PROJECT_BINARY_DIR}/generated/pch_donor.cpp
              ${PROJECT_BINARY_DIR}/generated/pch_donor.c)
  foreach(source ${sources})
    if(NOT EXISTS ${source})
      file(WRITE ${source} "/* The precompiled headers' donor targets (cmake/CdffPch.cmake). */\n")
    endif()
  endforeach()
  set(cxx_headers ${CDFF_PCH_COMMON_HEADERS})
  list(TRANSFORM cxx_headers REPLACE ">" "$<ANGLE-R>")
  list(TRANSFORM cxx_headers REPLACE "^(.+)$" "$<$<COMPILE_LANGUAGE:CXX>:\\1>")
  set(c_header "$<$<COMPILE_LANGUAGE:C>:<stddef.h$<ANGLE-R>>")
  add_library(cdff_pch_dfn OBJECT ${sources})
  target_link_libraries(cdff_pch_dfn PRIVATE cdff_dfn cdff_types_opencv)
  target_precompile_headers(cdff_pch_dfn PRIVATE ${cxx_headers} ${c_header})
  if(CDFF_BUILD_TESTS)
    add_library(cdff_pch_test OBJECT ${sources})
    target_link_libraries(cdff_pch_test PRIVATE cdff_dfn cdff_types_opencv GTest::gtest)
    target_compile_options(cdff_pch_test PRIVATE -fPIC)
    target_precompile_headers(cdff_pch_test PRIVATE ${cxx_headers}
                              "$<$<COMPILE_LANGUAGE:CXX>:<gtest/gtest.h$<ANGLE-R>>" ${c_header})
  endif()
endfunction()

# cdff_use_precompiled_headers(TARGET KIND): TARGET's C++ files reuse the KIND (dfn or test)
# precompiled header.
function(cdff_use_precompiled_headers target kind)
  if(NOT CDFF_PRECOMPILED_HEADERS OR NOT TARGET cdff_pch_${kind})
    return()
  endif()
  target_precompile_headers(${target} REUSE_FROM cdff_pch_${kind})
  target_compile_options(${target} PRIVATE -fPIC -Winvalid-pch)
endfunction()

# Every GoogleTest program defined under DIR (recursively) reuses the test precompiled header,
# but for those compiled to another C++ standard than the project's (ViSP's C++17 test).
function(cdff_use_test_precompiled_headers dir)
  get_property(targets DIRECTORY ${dir} PROPERTY BUILDSYSTEM_TARGETS)
  foreach(target ${targets})
    get_target_property(type ${target} TYPE)
    get_target_property(libraries ${target} LINK_LIBRARIES)
    get_target_property(standard ${target} CXX_STANDARD)
    if(type STREQUAL "EXECUTABLE" AND libraries MATCHES "GTest::"
       AND (NOT standard OR standard EQUAL CMAKE_CXX_STANDARD))
      cdff_use_precompiled_headers(${target} test)
    endif()
  endforeach()
  get_property(subdirectories DIRECTORY ${dir} PROPERTY SUBDIRECTORIES)
  foreach(subdirectory ${subdirectories})
    cdff_use_test_precompiled_headers(${subdirectory})
  endforeach()
endfunction()
