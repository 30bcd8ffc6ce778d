# EdgeTracker composes the shared tracking library (the model-based tracker's code) and finds the
# model's near-symmetries with the registration library's.
target_link_libraries(${lib} PUBLIC cdff_tracking cdff_registration)
# The test builds the simulator's procedural target (cdff/egse) and renders it with the tests'
# polygon renderer.
if(TARGET test_dfn_${area})
  target_link_libraries(test_dfn_${area} PRIVATE cdff_egse)
endif()
