# The check is the library of Registration3D/FastIcp (src/cdff/registration/symmetry_check.hpp).
target_link_libraries(${lib} PUBLIC cdff_registration)
# The test scans the procedural targets of the simulator (cdff/egse).
if(TARGET test_dfn_${area})
  target_link_libraries(test_dfn_${area} PRIVATE cdff_egse)
endif()
