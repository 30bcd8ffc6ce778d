# The algorithm lives in the shared model-based tracking library (src/cdff/tracking).
target_link_libraries(${lib} PUBLIC cdff_tracking)
