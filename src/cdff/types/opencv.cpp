#include "cdff/types/opencv.hpp"

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace cdff {

int cvType(PixelFormat format) {
  switch (format) {
    case PixelFormat::kGray8:
      return CV_8UC1;
    case PixelFormat::kBgr8:
      return CV_8UC3;
    case PixelFormat::kGray16:
      return CV_16UC1;
    case PixelFormat::kFloat32:
      return CV_32FC1;
  }
  return -1;
}

namespace {
// cv::Mat only has a mutable data pointer; CDFF keeps the const contract by documentation.
template <typename T>
T* mutableData(const T* data) {
  return const_cast<T*>(data);
}

// Keeps a Buffer's memory alive while a cv::Mat header refers to it.
template <typename T>
class BufferAllocator final : public cv::MatAllocator {
 public:
  explicit BufferAllocator(std::shared_ptr<const T> owner) : owner_(std::move(owner)) {}
  cv::UMatData* allocate(int, const int*, int, void*, size_t*, cv::AccessFlag,
                         cv::UMatUsageFlags) const override {
    return nullptr;  // never asked: the Mat wraps existing memory
  }
  bool allocate(cv::UMatData*, cv::AccessFlag, cv::UMatUsageFlags) const override { return false; }
  void deallocate(cv::UMatData* data) const override {
    delete data;
    delete this;
  }

 private:
  std::shared_ptr<const T> owner_;
};

template <typename T>
cv::Mat wrapShared(int rows, int cols, int type, const std::shared_ptr<const T>& owner,
                   const void* data, std::size_t step) {
  cv::Mat mat(rows, cols, type, mutableData(static_cast<const std::uint8_t*>(data)), step);
  // Attach a reference count so that the Mat outlives the producer's Buffer safely.
  auto* allocator = new BufferAllocator<T>(owner);
  auto* u = new cv::UMatData(allocator);
  u->data = u->origdata = mat.data;
  u->size = step * static_cast<std::size_t>(rows);
  u->refcount = 1;
  u->flags |= cv::UMatData::USER_ALLOCATED;  // the pixels are not OpenCV's to free
  mat.u = u;
  // mat.allocator stays null: if OpenCV reallocates this Mat (an in-place call that changes its
  // size or type), the new data comes from the default allocator, while u keeps ours for release.
  return mat;
}
}  // namespace

cv::Mat toMat(const Image& image) {
  if (image.empty()) return {};
  return wrapShared(image.height, image.width, cvType(image.format), image.pixels.owner(),
                    image.pixels.data(), image.stride_bytes);
}

Result<Image> fromMat(const cv::Mat& mat, Timestamp stamp, std::string frame_id) {
  PixelFormat format;
  switch (mat.type()) {
    case CV_8UC1:
      format = PixelFormat::kGray8;
      break;
    case CV_8UC3:
      format = PixelFormat::kBgr8;
      break;
    case CV_16UC1:
      format = PixelFormat::kGray16;
      break;
    case CV_32FC1:
      format = PixelFormat::kFloat32;
      break;
    default:
      return invalidInput(
          "cv::Mat has type {} ({} channels, depth {}); expected 8UC1, 8UC3, "
          "16UC1 or 32FC1",
          mat.type(), mat.channels(), mat.depth());
  }
  if (mat.empty() || mat.dims != 2)
    return invalidInput("cv::Mat is empty or not 2-D ({}x{}, {} dims); expected a 2-D image",
                        mat.rows, mat.cols, mat.dims);
  Image image;
  image.stamp = stamp;
  image.frame_id = std::move(frame_id);
  image.width = mat.cols;
  image.height = mat.rows;
  image.format = format;
  image.stride_bytes = mat.step[0];
  const std::size_t bytes = mat.step[0] * static_cast<std::size_t>(mat.rows - 1) +
                            static_cast<std::size_t>(mat.cols) * mat.elemSize();
  auto owner = std::make_shared<cv::Mat>(mat);  // shares the Mat's reference-counted data
  image.pixels = Buffer<std::uint8_t>::view(owner, mat.ptr<std::uint8_t>(0), bytes);
  return image;
}

CameraModel cameraAfterPyrDown(CameraModel camera, int levels) {
  for (int l = 0; l < levels; ++l) {
    camera.width = (camera.width + 1) / 2;
    camera.height = (camera.height + 1) / 2;
    camera.fx /= 2;
    camera.fy /= 2;
    camera.cx /= 2;
    camera.cy /= 2;
  }
  return camera;
}

cv::Mat pyrDownTimes(const cv::Mat& image, int levels) {
  cv::Mat out = image;
  for (int l = 0; l < levels; ++l) {
    cv::Mat next;
    cv::pyrDown(out, next);
    out = next;
  }
  return out;
}

cv::Mat cameraMatrix(const CameraModel& camera) {
  cv::Mat k = (cv::Mat_<double>(3, 3) << camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
  return k;
}

cv::Mat distortionCoefficients(const CameraModel& camera) {
  if (camera.distortion.empty()) return cv::Mat::zeros(1, 4, CV_64F);
  cv::Mat d(1, static_cast<int>(camera.distortion.size()), CV_64F);
  for (std::size_t i = 0; i < camera.distortion.size(); ++i)
    d.at<double>(0, static_cast<int>(i)) = camera.distortion[i];
  return d;
}

Result<std::vector<Eigen::Vector2d>> normalizedCoordinates(
    const CameraModel& camera, const std::vector<Eigen::Vector2d>& pixels, const char* what) {
  CDFF_RETURN_IF_ERROR(camera.validate());
  std::vector<cv::Point2d> in(pixels.size());
  for (std::size_t i = 0; i < pixels.size(); ++i) {
    if (!pixels[i].allFinite())
      return invalidInput("{} pixel {} is ({}, {}); expected finite coordinates", what, i,
                          pixels[i].x(), pixels[i].y());
    in[i] = {pixels[i].x(), pixels[i].y()};
  }
  std::vector<Eigen::Vector2d> out(pixels.size());
  if (pixels.empty()) return out;
  std::vector<cv::Point2d> undistorted;
  try {
    if (camera.distortion_model == DistortionModel::kEquidistant)
      cv::fisheye::undistortPoints(in, undistorted, cameraMatrix(camera),
                                   distortionCoefficients(camera));
    else
      cv::undistortPoints(in, undistorted, cameraMatrix(camera), distortionCoefficients(camera));
  } catch (const cv::Exception& e) {
    return numericalFailure("{}: removing the camera's distortion failed: {}", what, e.what());
  }
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = {undistorted[i].x, undistorted[i].y};
  return out;
}

cv::Mat toMat(const DescriptorMatrix& descriptors) {
  if (descriptors.empty()) return {};
  const int type = descriptors.element == DescriptorMatrix::Element::kUint8 ? CV_8UC1 : CV_32FC1;
  return wrapShared(descriptors.rows, descriptors.cols, type, descriptors.data.owner(),
                    descriptors.data.data(),
                    static_cast<std::size_t>(descriptors.cols) * descriptors.elementSize());
}

Result<DescriptorMatrix> descriptorsFromMat(const cv::Mat& mat) {
  DescriptorMatrix d;
  if (mat.empty()) return d;
  if (mat.type() == CV_8UC1) {
    d.element = DescriptorMatrix::Element::kUint8;
  } else if (mat.type() == CV_32FC1) {
    d.element = DescriptorMatrix::Element::kFloat32;
    d.distance = DescriptorMatrix::Distance::kL2;
  } else {
    return invalidInput("descriptor cv::Mat has type {}; expected CV_8UC1 or CV_32FC1", mat.type());
  }
  cv::Mat packed = mat.isContinuous() ? mat : mat.clone();
  d.rows = packed.rows;
  d.cols = packed.cols;
  auto owner = std::make_shared<cv::Mat>(packed);
  d.data = Buffer<std::uint8_t>::view(owner, packed.ptr<std::uint8_t>(0),
                                      packed.total() * packed.elemSize());
  return d;
}

std::vector<cv::Point2d> toCvPoints(const std::vector<Eigen::Vector2d>& points) {
  std::vector<cv::Point2d> out;
  out.reserve(points.size());
  for (const Eigen::Vector2d& p : points) out.emplace_back(p.x(), p.y());
  return out;
}

std::vector<cv::KeyPoint> toCvKeypoints(const std::vector<Keypoint2D>& keypoints) {
  std::vector<cv::KeyPoint> out;
  out.reserve(keypoints.size());
  for (const auto& k : keypoints)
    out.emplace_back(cv::Point2f(k.position.x(), k.position.y()), k.size, k.angle, k.response,
                     k.octave);
  return out;
}

std::vector<Keypoint2D> fromCvKeypoints(const std::vector<cv::KeyPoint>& keypoints) {
  std::vector<Keypoint2D> out;
  out.reserve(keypoints.size());
  for (const auto& k : keypoints) {
    Keypoint2D p;
    p.position = {k.pt.x, k.pt.y};
    p.size = k.size;
    p.angle = k.angle;
    p.response = k.response;
    p.octave = k.octave;
    out.push_back(p);
  }
  return out;
}

}  // namespace cdff
