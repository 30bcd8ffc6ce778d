# The registration algorithms are in src/cdff/registration/ (cdff_registration); PclIcpPointToPlane
# also uses PCL's registration (ICP) and search (KD-tree) components.
target_link_libraries(${lib} PUBLIC cdff_registration cdff_types_pcl ${PCL_REGISTRATION_LIBRARIES}
                                    ${PCL_SEARCH_LIBRARIES} ${PCL_KDTREE_LIBRARIES})
