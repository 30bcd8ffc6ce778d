# KeypointExtraction3D: UniformSampling uses PCL's filters (precompiled UniformSampling), Iss
# PCL's keypoints header (ISSKeypoint3D, with its KD-tree search and octree).
target_link_libraries(${lib} PUBLIC cdff_types_pcl ${PCL_FILTERS_LIBRARIES}
                      ${PCL_KEYPOINTS_LIBRARIES} ${PCL_SEARCH_LIBRARIES} ${PCL_KDTREE_LIBRARIES})
