#include <cmath>
#include <filesystem>
#include <optional>

#include "ModelPointCloud.gen.hpp"
#include "cdff/egse/model_io.hpp"

namespace cdff::dfn {

class ModelPointCloudMeshSampler final : public ModelPointCloudMeshSamplerBase {
 protected:
  // The mesh file is read here, not at the first call: a graph naming a file that is not there
  // (a relative path from another working directory, say) fails to start, with the file's name,
  // instead of running with a model node that faults at every step.
  Status onConfigure() override {
    model_.reset();  // new parameters, new model
    file_mesh_.reset();
    if (params_.mesh_file.empty()) return Status::ok();
    // The simulator's loader, so that the tracker reads a mesh file exactly as the simulator
    // that rendered the target did.
    egse::MeshLoadOptions options;
    options.scale = params_.scale;
    Result<egse::TargetModel> loaded = egse::loadModel(params_.mesh_file, options);
    if (!loaded) {
      std::string where;
      std::error_code ec;
      if (std::filesystem::path(params_.mesh_file).is_relative())
        where = " (a relative path: from the working directory '" +
                std::filesystem::current_path(ec).string() + "')";
      return Status(loaded.status().code(),
                    "parameter 'mesh_file': " + loaded.status().message() + where);
    }
    file_mesh_ = std::move(loaded->mesh);
    file_mesh_->frame_id = params_.frame_id;
    // The surface's reflectivity to a LIDAR or ToF camera, per triangle, from the file's
    // materials (a file without materials gets the loader's default).
    file_reflectivity_.clear();
    if (loaded->triangle_material.size() == file_mesh_->triangleCount())
      for (std::size_t t = 0; t < file_mesh_->triangleCount(); ++t)
        file_reflectivity_.push_back(loaded->triangleMaterial(t).lidar_reflectivity);
    return Status::ok();
  }

  Status onProcess() override {
    if (in.mesh.isFresh()) {
      CDFF_RETURN_IF_ERROR(in.mesh->validate("input 'mesh'"));
      Result<PointCloud> model = sample(*in.mesh, "input 'mesh'");
      if (!model) return model.status();
      model_ = std::make_shared<const PointCloud>(std::move(model).value());
    } else if (!model_) {
      if (in.mesh.hasValue()) {
        // Parameters changed since the last mesh: resample it.
        Result<PointCloud> model = sample(*in.mesh, "input 'mesh'");
        if (!model) return model.status();
        model_ = std::make_shared<const PointCloud>(std::move(model).value());
      } else if (file_mesh_) {
        Result<PointCloud> model = sample(*file_mesh_, "mesh_file", file_reflectivity_);
        if (!model) return model.status();
        model_ = std::make_shared<const PointCloud>(std::move(model).value());
      } else {
        return invalidInput(
            "no mesh: expected a 'mesh' input or the parameter 'mesh_file' naming a .obj, .ply, "
            ".stl, .gltf or .glb file");
      }
    }
    out.model.set(model_);
    return Status::ok();
  }

 private:
  /// `reflectivity`: per triangle of `mesh`, the cloud's intensity (none when empty).
  Result<PointCloud> sample(const TriangleMesh& mesh, const char* what,
                            const std::vector<float>& reflectivity = {}) const {
    const double area = mesh.surfaceArea();
    const double count = std::round(area / (params_.point_spacing * params_.point_spacing));
    if (count > params_.max_points)
      return invalidParameter(
          "{} has {:.4g} m^2 of surface: {:.0f} points at point_spacing = {} m, more than "
          "max_points = {}; expected a coarser spacing or a larger max_points",
          what, area, count, params_.point_spacing, params_.max_points);
    const SampleNormals normals = params_.normals == "face"     ? SampleNormals::kFace
                                  : params_.normals == "vertex" ? SampleNormals::kVertex
                                                                : SampleNormals::kAuto;
    std::vector<std::uint32_t> triangles;
    Result<PointCloud> cloud =
        sampleSurface(mesh, static_cast<std::size_t>(std::max(1.0, count)),
                      static_cast<std::uint64_t>(params_.seed), normals, &triangles);
    if (!cloud || reflectivity.empty()) return cloud;
    std::vector<float> intensity;
    intensity.reserve(triangles.size());
    for (std::uint32_t t : triangles) intensity.push_back(reflectivity[t]);
    cloud->intensity = Buffer<float>::fromVector(std::move(intensity));
    return cloud;
  }

  std::shared_ptr<const PointCloud> model_;
  std::optional<TriangleMesh> file_mesh_;
  std::vector<float> file_reflectivity_;  // per triangle of file_mesh_
};

CDFF_REGISTER_DFI(ModelPointCloudMeshSampler);

}  // namespace cdff::dfn
