# dfns/bundle_adjustment/area.cmake: the Ceres DFI uses Ceres Solver 2.1 (Debian's libceres-dev).
# GLOBAL: the programs that link every DFN (benchmarks, apps) see the imported target too.
find_package(Ceres 2.1 REQUIRED GLOBAL)
target_link_libraries(${lib} PUBLIC Ceres::ceres)
