# The registration is the library of Registration3D/FastIcp (src/cdff/registration/); the test
# renders its depth with the simulator (cdff/egse) and scores the covariance with cdff/eval.
target_link_libraries(${lib} PUBLIC cdff_registration)
if(TARGET test_dfn_${area})
  target_link_libraries(test_dfn_${area} PRIVATE cdff_egse cdff_eval)
endif()
