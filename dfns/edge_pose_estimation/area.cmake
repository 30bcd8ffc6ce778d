# The algorithm lives in the shared model-based tracking library (src/cdff/tracking).
target_link_libraries(${lib} PUBLIC cdff_tracking)
# Its test runs the whole chain of atomic DFNs that feed it.
if(TARGET test_dfn_${area})
  target_link_libraries(test_dfn_${area} PRIVATE cdff_dfn_visibility_determination
    cdff_dfn_contour_sampling cdff_dfn_edge_matching)
endif()
