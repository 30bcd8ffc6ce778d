# The registration is the library of Registration3D/FastIcp (src/cdff/registration/).
target_link_libraries(${lib} PUBLIC cdff_registration)
# The test scans the simulator's procedural targets (cdff/egse).
if(TARGET test_dfn_${area})
  target_link_libraries(test_dfn_${area} PRIVATE cdff_egse)
endif()
