// The only translation unit of this area that includes PCL's greedy projection triangulation.
#include <pcl/surface/gp3.h>

#include "MeshReconstruction.gen.hpp"
#include "cdff/types/pcl.hpp"
#include "mesh_common.hpp"

namespace cdff::dfn {

class MeshReconstructionGreedyProjection final : public MeshReconstructionGreedyProjectionBase {
 protected:
  Status onConfigure() override {
    // The ranges keep min_angle <= 60 deg <= max_angle (a triangle's angles sum to 180 deg);
    // both at 60 deg would allow only equilateral triangles.
    if (!(params_.min_angle < params_.max_angle))
      return invalidParameter(
          "parameter 'min_angle' = {:.3g} deg is not below 'max_angle' = {:.3g} deg; expected "
          "min_angle < max_angle",
          params_.min_angle * 180.0 / M_PI, params_.max_angle * 180.0 / M_PI);
    return Status::ok();
  }

  Status onProcess() override {
    const meshing::Settings settings = meshing::settingsOf(params_);
    Result<meshing::Prepared> prepared =
        meshing::prepare(*in.cloud, settings, [this](std::string m) { warn(std::move(m)); });
    if (!prepared) return prepared.status();
    const meshing::Prepared& data = prepared.value();
    Result<pcl::PointCloud<pcl::PointNormal>::Ptr> input = toPclWithNormals(data.cloud);
    if (!input) return input.status();

    pcl::GreedyProjectionTriangulation<pcl::PointNormal> gp3;
    gp3.setInputCloud(input.value());
    gp3.setSearchRadius(params_.radius_spacings * data.spacing);
    gp3.setMu(params_.mu);
    gp3.setMaximumNearestNeighbors(params_.max_neighbours);
    gp3.setMaximumSurfaceAngle(params_.max_surface_angle);
    gp3.setMinimumAngle(params_.min_angle);
    gp3.setMaximumAngle(params_.max_angle);
    gp3.setNormalConsistency(true);  // prepare() oriented them
    gp3.setConsistentVertexOrdering(true);
    std::vector<pcl::Vertices> polygons;
    gp3.reconstruct(polygons);  // indices into the input points

    std::vector<Eigen::Vector3f> vertices, normals;
    vertices.reserve(data.cloud.size());
    normals.reserve(data.cloud.size());
    for (std::size_t i = 0; i < data.cloud.size(); ++i) {
      vertices.push_back(data.cloud.points[i].vec());
      normals.push_back(data.cloud.normals[i].vec());
    }
    std::vector<meshing::Triangle> triangles;
    triangles.reserve(polygons.size());
    for (const pcl::Vertices& polygon : polygons)
      if (polygon.vertices.size() == 3)
        triangles.push_back({static_cast<std::uint32_t>(polygon.vertices[0]),
                             static_cast<std::uint32_t>(polygon.vertices[1]),
                             static_cast<std::uint32_t>(polygon.vertices[2])});
    meshing::orientByVertexNormals(vertices, normals, triangles);
    return meshing::publish(out, data, settings, meshing::buildMesh(data, vertices, triangles));
  }
};

CDFF_REGISTER_DFI(MeshReconstructionGreedyProjection);

}  // namespace cdff::dfn
