# The mesh_file parameter is read with the simulator's loader (cdff/egse/model_io.hpp): one
# mesh loader in the project.
target_link_libraries(${lib} PUBLIC cdff_egse)
