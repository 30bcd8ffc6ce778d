# OpenCvPpf uses OpenCV contrib's surface matching (cv::ppf_match_3d::PPF3DDetector).
target_link_libraries(${lib} PUBLIC opencv_surface_matching)
# The test scans the simulator's procedural targets (cdff/egse).
if(TARGET test_dfn_${area})
  target_link_libraries(test_dfn_${area} PRIVATE cdff_egse)
endif()
