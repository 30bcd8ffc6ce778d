#pragma once
// Model files: export of target models for the trackers (OBJ + MTL, PLY mesh, PLY dense point
// cloud, ViSP .cao face model, edge list) and loaders for user meshes (OBJ, PLY ascii and
// binary, STL ascii and binary, glTF 2.0 .gltf and .glb).
//
// Loaders report malformed files with the file name and the line (text formats) or byte offset
// (binary formats) of the problem.

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "cdff/egse/model.hpp"

namespace cdff::egse {

struct MeshLoadOptions {
  double scale = 1.0;     // applied to the file's coordinates (e.g. 0.001 for millimetres)
  bool recentre = false;  // move the bounding-box centre to the origin
  /// Faces between triangles bending less than this (rad) are shaded smooth when the file has no
  /// normals.
  double smoothing_angle = 0.5235987755982988;
  MaterialId default_material = MaterialId::kStructure;
};

/// Loads OBJ, PLY, STL, glTF or GLB, chosen by the file extension (case-insensitive).
Result<TargetModel> loadModel(const std::filesystem::path& path,
                              const MeshLoadOptions& options = {});
Result<TargetModel> loadObj(const std::filesystem::path& path, const MeshLoadOptions& options = {});
Result<TargetModel> loadPly(const std::filesystem::path& path, const MeshLoadOptions& options = {});
Result<TargetModel> loadStl(const std::filesystem::path& path, const MeshLoadOptions& options = {});
Result<TargetModel> loadGltf(const std::filesystem::path& path,
                             const MeshLoadOptions& options = {});

/// Wavefront OBJ with a material library `<stem>.mtl` beside it (one `usemtl` per material).
Status writeObj(const TargetModel& model, const std::filesystem::path& path);
/// PLY mesh: vertices with normals, faces with a `material` index; material names as comments.
Status writePly(const TargetModel& model, const std::filesystem::path& path, bool binary = true);
/// PLY point cloud: x y z [nx ny nz] [intensity], binary little-endian.
Status writePointCloudPly(const PointCloud& cloud, const std::filesystem::path& path);
/// Reads a point cloud written by writePointCloudPly (or any PLY with x y z vertices).
Result<PointCloud> readPointCloudPly(const std::filesystem::path& path);
/// ViSP's .cao (version 1): welded 3D points and the model's planar polygons as faces.
Status writeCao(const TargetModel& model, const std::filesystem::path& path);
/// The edge list: one edge per line with its adjacent face normals and flags.
Status writeEdges(const std::vector<ModelEdge>& edges, const std::filesystem::path& path);
Result<std::vector<ModelEdge>> readEdges(const std::filesystem::path& path);

struct ModelExport {
  std::filesystem::path obj, mtl, ply, points_ply, cao, edges;
};
/// Writes every export of `model` into `directory` as `<basename>.obj/.mtl/.ply/_points.ply/
/// .cao/_edges.txt`, with `point_count` points in the dense cloud.
Result<ModelExport> exportModel(const TargetModel& model, const std::filesystem::path& directory,
                                const std::string& basename, std::size_t point_count = 200000,
                                std::uint64_t seed = 1);

/// Gives the triangles of `positions` per-corner normals: corners of faces bending less than
/// `smoothing_angle` share a smoothed normal, sharper creases keep separate vertices. Used by
/// the loaders for files without normals.
TargetModel buildModelFromTriangles(std::string name, const std::vector<Eigen::Vector3f>& positions,
                                    const std::vector<std::array<std::uint32_t, 3>>& triangles,
                                    const std::vector<std::uint16_t>& triangle_material,
                                    std::vector<Material> materials, double smoothing_angle);

}  // namespace cdff::egse
