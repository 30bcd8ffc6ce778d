# Training renders the model with the simulator's renderer and loads meshes with its loader
# (cdff/egse); matching is OpenCV's LINEMOD (the rgbd contrib module).
target_link_libraries(${lib} PUBLIC cdff_egse opencv_rgbd)
