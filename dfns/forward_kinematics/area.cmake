# The chain read from URDF with its KDL kinematics (src/cdff/kinematics).
target_link_libraries(${lib} PUBLIC cdff_kinematics)
if(TARGET test_dfn_${area})
  target_compile_definitions(test_dfn_${area} PRIVATE CDFF_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
endif()
