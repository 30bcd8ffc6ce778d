# The tests drive the simulator's arm (cdff/egse/arm_simulator.hpp) and the ForwardKinematics
# DFN (the contact in the target frame through the measured joints).
if(TARGET test_dfn_${area})
  target_link_libraries(test_dfn_${area} PRIVATE cdff_egse cdff_dfn_forward_kinematics)
  target_compile_definitions(test_dfn_${area} PRIVATE CDFF_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
endif()
