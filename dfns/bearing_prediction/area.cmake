# dfns/bearing_prediction/area.cmake: the relative motion model shared with BearingFilter.
target_link_libraries(${lib} PUBLIC cdff_tracking)
