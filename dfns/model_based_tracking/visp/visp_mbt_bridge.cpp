// The only translation unit that includes ViSP (compiled as C++17, see visp_mbt_bridge.hpp).
#include "visp_mbt_bridge.hpp"

#include <cmath>
#include <exception>
#include <iostream>
#include <map>
#include <sstream>

#include <visp3/core/vpCameraParameters.h>
#include <visp3/core/vpHomogeneousMatrix.h>
#include <visp3/core/vpImage.h>
#include <visp3/klt/vpKltOpencv.h>
#include <visp3/mbt/vpMbGenericTracker.h>
#include <visp3/me/vpMe.h>

namespace cdff::visp_bridge {

namespace {

vpHomogeneousMatrix toVisp(const Matrix4& m) {
  vpHomogeneousMatrix h;
  for (unsigned r = 0; r < 4; ++r)
    for (unsigned c = 0; c < 4; ++c) h[r][c] = m[r * 4 + c];
  return h;
}

Matrix4 fromVisp(const vpHomogeneousMatrix& h) {
  Matrix4 m{};
  for (unsigned r = 0; r < 4; ++r)
    for (unsigned c = 0; c < 4; ++c) m[r * 4 + c] = h[r][c];
  return m;
}

// Each camera's intrinsics (pinhole, no distortion) and camera_T_reference under ViSP's name
// for it: the image cameras, then the depth one.
void setCameras(vpMbGenericTracker& t, const std::vector<std::string>& names,
                const std::vector<Camera>& cameras, const Camera* depth) {
  std::map<std::string, vpCameraParameters> intrinsics;
  std::map<std::string, vpHomogeneousMatrix> extrinsics;
  const std::size_t n = cameras.size() + (depth ? 1 : 0);
  for (std::size_t i = 0; i < n; ++i) {
    const Camera& c = i < cameras.size() ? cameras[i] : *depth;
    vpCameraParameters p;
    p.initPersProjWithoutDistortion(c.intrinsics.fx, c.intrinsics.fy, c.intrinsics.cx,
                                    c.intrinsics.cy);
    intrinsics[names[i]] = p;
    extrinsics[names[i]] = toVisp(c.camera_T_reference);
  }
  t.setCameraParameters(intrinsics);
  t.setCameraTransformationMatrix(extrinsics);
}

// The settings of the features ViSP tracks (moving edges, KLT points, dense depth) and of its
// visibility test.
void setTracking(vpMbGenericTracker& t, const Settings& s, bool depth) {
  vpMe me;
  me.setMaskSize(static_cast<unsigned>(s.me_mask_size));
  me.setMaskNumber(static_cast<unsigned>(s.me_mask_number));
  me.setRange(static_cast<unsigned>(s.me_range));
  me.setThreshold(s.me_threshold);
  me.setMu1(s.me_mu1);
  me.setMu2(s.me_mu2);
  me.setSampleStep(s.me_sample_step);
  if (s.edges) t.setMovingEdge(me);
  if (s.klt) {
    vpKltOpencv klt;
    klt.setMaxFeatures(s.klt_max_features);
    klt.setWindowSize(s.klt_window_size);
    klt.setQuality(s.klt_quality);
    klt.setMinDistance(s.klt_min_distance);
    klt.setHarrisFreeParameter(s.klt_harris);
    klt.setBlockSize(s.klt_block_size);
    klt.setPyramidLevels(s.klt_pyramid_levels);
    t.setKltOpencv(klt);
    t.setKltMaskBorder(static_cast<unsigned>(s.klt_mask_border));
  }
  if (depth)
    t.setDepthDenseSamplingStep(static_cast<unsigned>(s.depth_dense_step),
                                static_cast<unsigned>(s.depth_dense_step));
  t.setAngleAppear(s.angle_appear);
  t.setAngleDisappear(s.angle_disappear);
  t.setNearClippingDistance(s.near_clipping);
  t.setFarClippingDistance(s.far_clipping);
  if (s.fov_clipping) t.setClipping(t.getClipping() | vpMbtPolygon::FOV_CLIPPING);
  t.setScanLineVisibilityTest(s.scanline_visibility);
  t.setCovarianceComputation(s.covariance);
}

// ViSP reports what it read on std::cout; the DFI reports through its status instead.
void loadModelQuietly(vpMbGenericTracker& t, const std::string& model_path) {
  std::ostringstream chatter;
  std::streambuf* previous = std::cout.rdbuf(chatter.rdbuf());
  try {
    t.loadModel(model_path);
  } catch (...) {
    std::cout.rdbuf(previous);
    throw;
  }
  std::cout.rdbuf(previous);
}

}  // namespace

struct MbtTracker::Impl {
  std::unique_ptr<vpMbGenericTracker> tracker;
  std::vector<Camera> cameras;
  bool has_depth = false;
  Camera depth;
  bool has_pose = false;
  bool covariance = false;
  std::vector<vpImage<unsigned char>> images;  // ViSP owns its pixels: one copy per frame
  std::vector<vpColVector> cloud;              // reused between frames (no reallocation)
  std::vector<std::string> names;  // ViSP's camera names: the image cameras, then the depth one

  void copyImages(const std::vector<GreyImage>& in) {
    images.resize(in.size());
    for (std::size_t i = 0; i < in.size(); ++i) {
      vpImage<unsigned char>& out = images[i];
      if (out.getWidth() != static_cast<unsigned>(in[i].width) ||
          out.getHeight() != static_cast<unsigned>(in[i].height))
        out.resize(static_cast<unsigned>(in[i].height), static_cast<unsigned>(in[i].width));
      for (int y = 0; y < in[i].height; ++y)
        std::copy(in[i].data + static_cast<std::size_t>(y) * in[i].stride,
                  in[i].data + static_cast<std::size_t>(y) * in[i].stride + in[i].width, out[y]);
    }
  }

  std::map<std::string, const vpImage<unsigned char>*> imageMap() const {
    std::map<std::string, const vpImage<unsigned char>*> map;
    for (std::size_t i = 0; i < images.size(); ++i) map[names[i]] = &images[i];
    return map;
  }
};

MbtTracker::MbtTracker() : impl_(std::make_unique<Impl>()) {}
MbtTracker::~MbtTracker() = default;

bool MbtTracker::hasPose() const {
  return impl_->has_pose;
}

std::string MbtTracker::configure(const Settings& s, const std::vector<Camera>& cameras,
                                  const Camera* depth, const std::string& model_path) {
  try {
    impl_ = std::make_unique<Impl>();
    impl_->cameras = cameras;
    impl_->has_depth = depth != nullptr;
    if (depth) impl_->depth = *depth;
    std::vector<int> types;
    int image_type = 0;
    if (s.edges) image_type |= vpMbGenericTracker::EDGE_TRACKER;
    if (s.klt) image_type |= vpMbGenericTracker::KLT_TRACKER;
    for (std::size_t i = 0; i < cameras.size(); ++i) types.push_back(image_type);
    if (depth) types.push_back(vpMbGenericTracker::DEPTH_DENSE_TRACKER);
    impl_->tracker = std::make_unique<vpMbGenericTracker>(types);
    vpMbGenericTracker& t = *impl_->tracker;
    // "Camera" for one camera, "Camera1", "Camera2", ... for several, in the order created.
    impl_->names = t.getCameraNames();
    if (impl_->names.size() != types.size())
      return "ViSP created " + std::to_string(impl_->names.size()) + " cameras; expected " +
             std::to_string(types.size());

    setCameras(t, impl_->names, cameras, depth);
    setTracking(t, s, depth != nullptr);
    impl_->covariance = s.covariance;
    loadModelQuietly(t, model_path);
    return {};
  } catch (const vpException& e) {
    impl_->tracker.reset();
    return std::string("ViSP refused the configuration: ") + e.getMessage();
  } catch (const std::exception& e) {
    impl_->tracker.reset();
    return std::string("ViSP refused the configuration: ") + e.what();
  }
}

std::string MbtTracker::setPose(const std::vector<GreyImage>& images,
                                const Matrix4& reference_T_model) {
  if (!impl_->tracker) return "the ViSP tracker is not configured";
  try {
    impl_->copyImages(images);
    const vpHomogeneousMatrix r_T_m = toVisp(reference_T_model);
    if (impl_->names.size() == 1) {
      if (impl_->has_pose)
        impl_->tracker->setPose(impl_->images[0], r_T_m);
      else
        impl_->tracker->initFromPose(impl_->images[0], r_T_m);
    } else {
      // Several cameras (a depth camera counts): every one gets its pose and an image (the depth
      // camera the reference image, of which ViSP only reads the size).
      auto map = impl_->imageMap();
      std::map<std::string, vpHomogeneousMatrix> poses;
      for (std::size_t i = 0; i < impl_->cameras.size(); ++i)
        poses[impl_->names[i]] = toVisp(impl_->cameras[i].camera_T_reference) * r_T_m;
      if (impl_->has_depth) {
        const std::string& name = impl_->names.back();
        map[name] = &impl_->images[0];
        poses[name] = toVisp(impl_->depth.camera_T_reference) * r_T_m;
      }
      if (impl_->has_pose)
        impl_->tracker->setPose(map, poses);
      else
        impl_->tracker->initFromPose(map, poses);
    }
    impl_->has_pose = true;
    return {};
  } catch (const vpException& e) {
    return std::string("ViSP could not take the pose: ") + e.getMessage();
  } catch (const std::exception& e) {
    return std::string("ViSP could not take the pose: ") + e.what();
  }
}

std::string MbtTracker::track(const std::vector<GreyImage>& images, const DepthImage* depth,
                              TrackOutput& output) {
  if (!impl_->tracker || !impl_->has_pose) return "the ViSP tracker has no pose yet";
  try {
    impl_->copyImages(images);
    auto map = impl_->imageMap();
    vpMbGenericTracker& t = *impl_->tracker;
    if (impl_->has_depth) {
      if (!depth) return "the tracker was configured with a depth camera but got no depth map";
      const Intrinsics& k = impl_->depth.intrinsics;
      const std::size_t count = static_cast<std::size_t>(depth->width) * depth->height;
      if (impl_->cloud.size() != count) impl_->cloud.assign(count, vpColVector(3, 0.0));
      for (int v = 0; v < depth->height; ++v)
        for (int u = 0; u < depth->width; ++u) {
          const std::size_t i = static_cast<std::size_t>(v) * depth->width + u;
          const float z = depth->metres[i];
          vpColVector& p = impl_->cloud[i];
          const double zz = std::isfinite(z) ? z : 0.0;
          p[0] = zz * (u - k.cx) / k.fx;
          p[1] = zz * (v - k.cy) / k.fy;
          p[2] = zz;
        }
      const std::string& name = impl_->names.back();
      std::map<std::string, const std::vector<vpColVector>*> clouds{{name, &impl_->cloud}};
      std::map<std::string, unsigned int> widths{{name, static_cast<unsigned>(depth->width)}};
      std::map<std::string, unsigned int> heights{{name, static_cast<unsigned>(depth->height)}};
      t.track(map, clouds, widths, heights);
    } else {
      t.track(map);
    }
    output.reference_T_model = fromVisp(t.getPose());
    output.covariance.fill(0.0);
    if (impl_->covariance) {
      const vpMatrix cov = t.getCovarianceMatrix();
      if (cov.getRows() == 6 && cov.getCols() == 6)
        for (unsigned r = 0; r < 6; ++r)
          for (unsigned c = 0; c < 6; ++c) output.covariance[r * 6 + c] = cov[r][c];
    }
    const vpColVector w = t.getRobustWeights();
    unsigned good = 0;
    for (unsigned i = 0; i < w.getRows(); ++i) good += w[i] > 0.5 ? 1 : 0;
    output.feature_count = static_cast<int>(w.getRows());
    output.inlier_ratio = w.getRows() ? static_cast<double>(good) / w.getRows() : 0.0;
    return {};
  } catch (const vpException& e) {
    return std::string("ViSP lost the track: ") + e.getMessage();
  } catch (const std::exception& e) {
    return std::string("ViSP lost the track: ") + e.what();
  }
}

Matrix4 MbtTracker::pose() const {
  if (!impl_->tracker) return Matrix4{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  return fromVisp(impl_->tracker->getPose());
}

}  // namespace cdff::visp_bridge
