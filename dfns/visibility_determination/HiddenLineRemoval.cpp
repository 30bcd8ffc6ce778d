#include "VisibilityDetermination.gen.hpp"
#include "cdff/tracking/contours.hpp"

namespace cdff::dfn {

class VisibilityDeterminationHiddenLineRemoval final
    : public VisibilityDeterminationHiddenLineRemovalBase {
 protected:
  Status onConfigure() override {
    model_.reset();  // the tessellation parameters may have changed
    return Status::ok();
  }

  Status onProcess() override {
    if (!model_ || in.model.isFresh() || in.model.get() != model_source_) {
      tracking::TrackingModelOptions options;
      options.cylinder_segments = params_.cylinder_segments;
      options.circle_segments = params_.circle_segments;
      Result<tracking::TrackingModel> built = tracking::TrackingModel::build(*in.model, options);
      if (!built) return built.status().withContext("input 'model'");
      model_ = std::make_shared<tracking::TrackingModel>(std::move(built).value());
      model_source_ = in.model.get();
    }
    const CameraModel* camera = in.camera.get();
    if (!camera && in.image.hasValue()) {
      if (!in.image->camera)
        return invalidInput(
            "input 'image' has no camera model; expected a calibrated image or "
            "the 'camera' input");
      camera = &*in.image->camera;
    }
    if (!camera)
      return invalidInput("neither 'camera' nor 'image' is set; expected the camera's intrinsics");
    const Transform extrinsics =
        in.camera_extrinsics.hasValue()
            ? *in.camera_extrinsics
            : Transform::identity(in.pose->parent_frame, in.pose->parent_frame, in.pose->stamp);
    CDFF_RETURN_IF_ERROR(extrinsics.validate().withContext("input 'camera_extrinsics'"));
    Result<Transform> camera_T_model = extrinsics.compose(*in.pose);
    if (!camera_T_model)
      return camera_T_model.status().withContext("inputs 'camera_extrinsics' and 'pose'");
    tracking::VisibilityOptions options;
    options.near_clipping = params_.near_clipping;
    options.far_clipping = params_.far_clipping;
    options.max_view_angle = params_.max_view_angle;
    options.min_crease_angle = params_.min_crease_angle;
    options.two_sided_faces = params_.two_sided_faces;
    options.min_segment_length = params_.min_segment_length;
    options.image_margin = params_.image_margin;
    options.occlusion_tolerance = params_.occlusion_tolerance;
    Result<ModelContours> contours =
        tracking::computeContours(*model_, *camera, *camera_T_model, extrinsics, options);
    if (!contours) return contours.status();
    if (contours->segments.empty())
      warn(
          "no contour of the model is visible from this pose (behind the camera or out of "
          "view)");
    out.segment_count.set(static_cast<int>(contours->segments.size()));
    out.contours.set(std::move(contours).value());
    return Status::ok();
  }

 private:
  std::shared_ptr<const tracking::TrackingModel> model_;
  const PolygonModel* model_source_ = nullptr;
};

CDFF_REGISTER_DFI(VisibilityDeterminationHiddenLineRemoval);

}  // namespace cdff::dfn
