# cdff_add_dfn_area(DIR): adds one DFN type folder under dfns/.
#
# The folder holds <Name>.yaml (the description), one .cpp per DFI and *_test.cpp unit tests.
# The description is read and checked by `cdff_dfn_describe` (the project's schema reader, with
# each port's C++ type from the type registry) into <Name>.json, which scripts/dfn_codegen.py turns
# into <Name>.gen.hpp/.gen.cpp at build time (and, with every other description, into the Python
# package's `cdff.dfn` module: python/CMakeLists.txt);
# the DFIs and generated code into the object library `cdff_dfn_<area>` (object files, so that
# every DFI's self-registration is linked in), and the tests into one GoogleTest executable per
# folder that links only its own area. `cdff_dfns` (dfns/CMakeLists.txt) gathers every area.
# An area that needs more than the common libraries adds an `area.cmake` beside its YAML: it is
# included last, with `${lib}` (the area's target), `${dir}` (the folder) and `${area}` set (the
# test target is `test_dfn_${area}` when it exists), e.g.
# `target_link_libraries(${lib} PUBLIC cdff_tracking)`.
set(CDFF_DFN_CODEGEN ${PROJECT_SOURCE_DIR}/scripts/dfn_codegen.py)
set(CDFF_DFN_GEN_DIR ${PROJECT_BINARY_DIR}/generated/dfns)

function(cdff_add_dfn_area dir)
  get_filename_component(area ${dir} NAME)
  file(GLOB descriptions CONFIGURE_DEPENDS ${dir}/*.yaml)
  if(NOT descriptions)
    return()  # not a DFN folder (yet)
  endif()
  set(lib cdff_dfn_${area})
  add_library(${lib} OBJECT)
  target_include_directories(${lib} PUBLIC ${CDFF_DFN_GEN_DIR} ${dir})
  target_link_libraries(${lib} PUBLIC cdff_dfn cdff_types_opencv ${CDFF_DFN_COMMON_LIBS})
  set_property(GLOBAL APPEND PROPERTY CDFF_DFN_AREA_LIBS ${lib})
  foreach(description ${descriptions})
    get_filename_component(name ${description} NAME_WE)
    set(gen_hpp ${CDFF_DFN_GEN_DIR}/${name}.gen.hpp)
    set(gen_cpp ${CDFF_DFN_GEN_DIR}/${name}.gen.cpp)
    set(checked ${CDFF_DFN_GEN_DIR}/${name}.json)
    file(RELATIVE_PATH source_file ${PROJECT_SOURCE_DIR} ${description})
    add_custom_command(
      OUTPUT ${checked}
      COMMAND cdff_dfn_describe ${description} --area ${area} --source-file ${source_file}
              --out ${checked}
      DEPENDS ${description} cdff_dfn_describe
      COMMENT "Checking the ${name} DFN description"
      VERBATIM)
    add_custom_command(
      OUTPUT ${gen_hpp} ${gen_cpp}
      COMMAND ${CDFF_PYTHON} ${CDFF_DFN_CODEGEN} ${checked} --out ${CDFF_DFN_GEN_DIR}
      DEPENDS ${checked} ${CDFF_DFN_CODEGEN}
      COMMENT "Generating the ${name} DFN interface"
      VERBATIM)
    target_sources(${lib} PRIVATE ${gen_cpp} ${gen_hpp})
    if(source_file MATCHES "^dfns/")  # not the test-only probe DFNs of tests/
      set_property(GLOBAL APPEND PROPERTY CDFF_DFN_DESCRIPTION_JSONS ${checked})
    endif()
  endforeach()
  file(GLOB sources CONFIGURE_DEPENDS ${dir}/*.cpp)
  file(GLOB tests CONFIGURE_DEPENDS ${dir}/*_test.cpp)
  if(tests)
    list(REMOVE_ITEM sources ${tests})
  endif()
  target_sources(${lib} PRIVATE ${sources})
  cdff_use_precompiled_headers(${lib} dfn)
  if(tests AND CDFF_BUILD_TESTS)
    add_executable(test_dfn_${area} ${tests})
    target_link_libraries(test_dfn_${area} PRIVATE ${lib} cdff_test_support cdff_gtest_main)
    cdff_use_precompiled_headers(test_dfn_${area} test)
    gtest_discover_tests(test_dfn_${area} DISCOVERY_TIMEOUT 60 PROPERTIES LABELS dfn)
  endif()
  if(EXISTS ${dir}/area.cmake)
    include(${dir}/area.cmake)
  endif()
endfunction()
