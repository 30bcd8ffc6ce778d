# CorrespondenceGrouping's DFIs use PCL's recognition (Hough3DGrouping,
# GeometricConsistencyGrouping, with its registration RANSAC), features (BOARD reference frames)
# and search (their KD-trees); grouping_common.cpp uses cdff_types' KD-tree only.
target_link_libraries(${lib} PUBLIC cdff_types_pcl ${PCL_RECOGNITION_LIBRARIES}
                                    ${PCL_FEATURES_LIBRARIES} ${PCL_REGISTRATION_LIBRARIES}
                                    ${PCL_SEARCH_LIBRARIES} ${PCL_KDTREE_LIBRARIES})
