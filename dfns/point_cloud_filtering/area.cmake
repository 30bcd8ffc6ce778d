# PointCloudFiltering/Pcl uses PCL's filters (CropBox, VoxelGrid, StatisticalOutlierRemoval).
target_link_libraries(${lib} PUBLIC cdff_types_pcl ${PCL_FILTERS_LIBRARIES})
