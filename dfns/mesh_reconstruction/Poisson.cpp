// The only translation unit of this area that includes PCL's Poisson reconstruction.
#include <algorithm>
#include <cmath>

#include <pcl/surface/poisson.h>

#include "MeshReconstruction.gen.hpp"
#include "cdff/types/pcl.hpp"
#include "mesh_common.hpp"

namespace cdff::dfn {

class MeshReconstructionPoisson final : public MeshReconstructionPoissonBase {
 protected:
  Status onProcess() override {
    const meshing::Settings settings = meshing::settingsOf(params_);
    Result<meshing::Prepared> prepared =
        meshing::prepare(*in.cloud, settings, [this](std::string m) { warn(std::move(m)); });
    if (!prepared) return prepared.status();
    const meshing::Prepared& data = prepared.value();
    Result<int> depth = octreeDepth(data);
    if (!depth) return depth.status();
    Result<pcl::PointCloud<pcl::PointNormal>::Ptr> input = toPclWithNormals(data.cloud);
    if (!input) return input.status();

    pcl::Poisson<pcl::PointNormal> poisson;
    poisson.setInputCloud(input.value());
    poisson.setDepth(depth.value());
    poisson.setMinDepth(std::min(5, depth.value()));
    poisson.setSamplesPerNode(static_cast<float>(params_.samples_per_node));
    poisson.setPointWeight(static_cast<float>(params_.point_weight));
    poisson.setScale(kScale);
    poisson.setDegree(2);
    poisson.setManifold(true);
    poisson.setOutputPolygons(false);  // triangles
    pcl::PointCloud<pcl::PointNormal> surface;
    std::vector<pcl::Vertices> polygons;
    poisson.reconstruct(surface, polygons);

    std::vector<Eigen::Vector3f> vertices;
    vertices.reserve(surface.size());
    for (const pcl::PointNormal& p : surface) vertices.push_back(p.getVector3fMap());
    std::vector<meshing::Triangle> triangles;
    triangles.reserve(polygons.size());
    for (const pcl::Vertices& polygon : polygons) {
      if (polygon.vertices.size() != 3) continue;  // PCL triangulates: not expected
      meshing::Triangle t;
      bool valid = true;
      for (int k = 0; k < 3; ++k) {
        const auto index = static_cast<std::size_t>(polygon.vertices[k]);
        valid = valid && index < vertices.size();
        t[k] = static_cast<std::uint32_t>(index);
      }
      if (valid) triangles.push_back(t);
    }
    if (params_.trim_spacings > 0)
      meshing::trimFarFromPoints(data, params_.trim_spacings * data.spacing, vertices, triangles);
    meshing::orientByNearestPoints(data, vertices, triangles);
    return meshing::publish(out, data, settings, meshing::buildMesh(data, vertices, triangles));
  }

 private:
  static constexpr float kScale = 1.1f;  // the octree's cube over the points' bounding cube
  static constexpr int kMaxDepth = 14;   // the parameter's range

  /// `depth`, or the smallest depth whose finest cell is at most the point spacing.
  Result<int> octreeDepth(const meshing::Prepared& data) const {
    if (params_.depth > 0) return params_.depth;
    const double extent = static_cast<double>((data.max - data.min).maxCoeff());
    const double cells = kScale * extent / data.spacing;
    const int depth = std::max(1, static_cast<int>(std::ceil(std::log2(std::max(cells, 1.0)))));
    if (depth > kMaxDepth)
      return invalidInput(
          "input 'cloud' (frame '{}') spans {:.3g} m at a point spacing of {:.3g} m: an octree "
          "of depth {} would be needed, more than {}; expected a coarser cloud (a voxel filter) "
          "or the parameter 'depth'",
          data.cloud.frame_id, extent, data.spacing, depth, kMaxDepth);
    return depth;
  }
};

CDFF_REGISTER_DFI(MeshReconstructionPoisson);

}  // namespace cdff::dfn
