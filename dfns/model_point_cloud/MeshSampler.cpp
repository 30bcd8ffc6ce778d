#include <cmath>
#include <optional>

#include "ModelPointCloud.gen.hpp"
#include "cdff/egse/model_io.hpp"

namespace cdff::dfn {

class ModelPointCloudMeshSampler final : public ModelPointCloudMeshSamplerBase {
 protected:
  Status onConfigure() override {
    model_.reset();  // new parameters, new model
    file_mesh_.reset();
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
      } else if (!params_.mesh_file.empty()) {
        if (!file_mesh_) {
          // The simulator's loader, so that the tracker reads a mesh file exactly as the
          // simulator that rendered the target did.
          egse::MeshLoadOptions options;
          options.scale = params_.scale;
          Result<egse::TargetModel> loaded = egse::loadModel(params_.mesh_file, options);
          if (!loaded)
            return Status(loaded.status().code(),
                          "parameter 'mesh_file': " + loaded.status().message());
          file_mesh_ = std::move(loaded->mesh);
          file_mesh_->frame_id = params_.frame_id;
        }
        Result<PointCloud> model = sample(*file_mesh_, "mesh_file");
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
  Result<PointCloud> sample(const TriangleMesh& mesh, const char* what) const {
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
    return sampleSurface(mesh, static_cast<std::size_t>(std::max(1.0, count)),
                         static_cast<std::uint64_t>(params_.seed), normals);
  }

  std::shared_ptr<const PointCloud> model_;
  std::optional<TriangleMesh> file_mesh_;
};

CDFF_REGISTER_DFI(ModelPointCloudMeshSampler);

}  // namespace cdff::dfn
