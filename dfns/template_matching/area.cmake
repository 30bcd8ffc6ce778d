# dfns/template_matching/area.cmake: the Ecc DFI uses OpenCV's video module (findTransformECC).
target_link_libraries(${lib} PUBLIC opencv_video)
