# PointCloudAssembly/Pcl uses PCL's VoxelGrid and StatisticalOutlierRemoval.
target_link_libraries(${lib} PUBLIC cdff_types_pcl ${PCL_FILTERS_LIBRARIES})
