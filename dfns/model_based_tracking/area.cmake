# EdgeTracker composes the shared tracking library; VispMbt reaches ViSP through a bridge library
# whose single translation unit includes ViSP. ViSP 3.5's headers are not valid C++20, so the
# bridge is built as C++17 and exposes only standard-library types. GLOBAL makes ViSP's imported
# targets visible to every program that links the DFNs.
target_link_libraries(${lib} PUBLIC cdff_tracking)
find_package(VISP 3.5 REQUIRED COMPONENTS visp_core visp_me visp_klt visp_mbt GLOBAL)
if(NOT TARGET cdff_visp_bridge)
  add_library(cdff_visp_bridge STATIC ${dir}/visp/visp_mbt_bridge.cpp)
  set_target_properties(cdff_visp_bridge PROPERTIES CXX_STANDARD 17 CXX_STANDARD_REQUIRED ON)
  target_include_directories(cdff_visp_bridge PUBLIC ${dir}/visp)
  target_link_libraries(cdff_visp_bridge PRIVATE visp_mbt visp_klt visp_me visp_core)
endif()
target_link_libraries(${lib} PUBLIC cdff_visp_bridge)
# Its tests also chain it with the EKF, as the visual tracking DFPC does.
if(TARGET test_dfn_${area})
  target_link_libraries(test_dfn_${area} PRIVATE cdff_dfn_estimation_filter)
endif()
