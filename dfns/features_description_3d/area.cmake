# FeaturesDescription3D's DFIs use PCL's features (SHOT, BOARD, FPFH) and search (KD-tree).
target_link_libraries(${lib} PUBLIC cdff_types_pcl ${PCL_FEATURES_LIBRARIES} ${PCL_SEARCH_LIBRARIES}
                                    ${PCL_KDTREE_LIBRARIES})
# The test samples the simulator's procedural target (cdff/egse).
if(TARGET test_dfn_${area})
  target_link_libraries(test_dfn_${area} PRIVATE cdff_egse)
endif()
