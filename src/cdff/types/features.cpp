#include "cdff/types/features.hpp"

#include "cdff/types/geometry.hpp"

namespace cdff {

Status DescriptorMatrix::validate(const char* what) const {
  if (rows < 0 || cols < 0)
    return invalidInput("{} have shape {}x{}; expected non-negative", what, rows, cols);
  const std::size_t needed = static_cast<std::size_t>(rows) * cols * elementSize();
  const bool binary = element == Element::kUint8;
  if (binary != (distance != Distance::kL2))
    return invalidInput("{} are {} but compare with {}; expected Hamming distances for uint8 "
                        "descriptors and L2 for float32 ones",
                        what, binary ? "uint8" : "float32",
                        distance == Distance::kL2 ? "L2" : "Hamming");
  if (data.size() != needed)
    return invalidInput("{} hold {} bytes; expected {} for {}x{} elements of {} bytes", what,
                        data.size(), needed, rows, cols, elementSize());
  return Status::ok();
}

template <typename Features>
static Status validateFeatures(const Features& f, const char* what) {
  CDFF_RETURN_IF_ERROR(f.descriptors.validate(what));
  if (!f.descriptors.empty() && static_cast<std::size_t>(f.descriptors.rows) != f.keypoints.size())
    return invalidInput("{} have {} keypoints but {} descriptors; expected one per keypoint", what,
                        f.keypoints.size(), f.descriptors.rows);
  for (std::size_t i = 0; i < f.keypoints.size(); ++i) {
    if (!f.keypoints[i].position.allFinite())
      return invalidInput("{} keypoint {} has a non-finite position", what, i);
  }
  return Status::ok();
}

Status Features2D::validate(const char* what) const { return validateFeatures(*this, what); }
Status Features3D::validate(const char* what) const { return validateFeatures(*this, what); }

template <typename A, typename B>
static Status validatePairs(const A& a, const B& b, const char* what) {
  if (a.size() != b.size())
    return invalidInput("{} have {} and {} entries; expected equal counts", what, a.size(),
                        b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (!a[i].allFinite() || !b[i].allFinite())
      return invalidInput("{} entry {} is not finite", what, i);
  }
  return Status::ok();
}

Status Correspondences2D::validate(const char* what) const {
  return validatePairs(first, second, what);
}
Status Correspondences3D::validate(const char* what) const {
  return validatePairs(first, second, what);
}
Status Correspondences2D3D::validate(const char* what) const {
  return validatePairs(points, pixels, what);
}

}  // namespace cdff
