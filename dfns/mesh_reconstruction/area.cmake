# MeshReconstruction's DFIs use PCL's surface reconstruction (Poisson, greedy projection).
target_link_libraries(${lib} PUBLIC cdff_types_pcl ${PCL_SURFACE_LIBRARIES} ${PCL_SEARCH_LIBRARIES}
                                    ${PCL_KDTREE_LIBRARIES})
