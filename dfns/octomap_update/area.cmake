# The map is octomap's OcTree (Debian liboctomap-dev); its config defines the imported targets in
# this directory only, so the libraries are linked by path for every program that links the DFNs.
find_package(octomap REQUIRED)
target_link_libraries(${lib} PUBLIC ${OCTOMAP_LIBRARIES})
target_include_directories(${lib} SYSTEM PUBLIC ${OCTOMAP_INCLUDE_DIRS})
