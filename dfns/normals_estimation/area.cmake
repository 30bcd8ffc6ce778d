# NormalsEstimation/Pcl uses PCL's features (NormalEstimation) and search (KD-tree).
target_link_libraries(${lib} PUBLIC cdff_types_pcl ${PCL_FEATURES_LIBRARIES} ${PCL_SEARCH_LIBRARIES})
