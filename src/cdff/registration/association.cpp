#include "cdff/registration/association.hpp"

#include <algorithm>
#include <cmath>

namespace cdff::registration {

Correspondences& Association::match(std::span<const Eigen::Vector3f> points,
                                    const Eigen::Isometry3d& pose, double distance, bool first,
                                    NearestPoints nearest) {
  const ModelIndex& model = *model_.index;
  found_.pairs.clear();
  found_.abs_residuals.clear();
  found_.distances.clear();
  if (first) previous_.assign(points.size(), kNoMatch);
  const Eigen::Matrix3d rotation = pose.linear();
  const Eigen::Vector3d translation = pose.translation();
  const Eigen::Matrix3f r_inv = rotation.transpose().cast<float>();
  const Eigen::Vector3f t = translation.cast<float>();
  const float max_sq = static_cast<float>(distance * distance);
  // The viewpoint in the model frame: visible model points have normals facing it.
  const Eigen::Vector3f eye = r_inv * (options_.viewpoint - t);
  const bool use_grid = model_.grid && nearest == NearestPoints::kGridWhereItReaches &&
                        distance <= model_.grid->band();
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f& p = points[i];
    const Eigen::Vector3f pm = r_inv * (p - t);
    KdTree3f::Neighbour nn;
    const bool found = use_grid ? nearestFromGrid(pm, eye, max_sq, nn)
                                : nearestVisible(pm, eye, max_sq, previous_[i], nn);
    if (!found) {
      previous_[i] = kNoMatch;
      continue;
    }
    previous_[i] = nn.index;
    const Eigen::Vector3f nm = model.normals[nn.index].vec();
    const float r = nm.dot(pm - model.points[nn.index].vec());
    const Eigen::Vector3d n = rotation * nm.cast<double>();
    Correspondence pair;
    pair.j << -n, n.cross(p.cast<double>() - translation);
    pair.r = r;
    pair.rq = rotation * model.points[nn.index].vec().cast<double>();
    pair.offset = pair.rq + translation - p.cast<double>();
    found_.pairs.push_back(pair);
    found_.abs_residuals.push_back(std::abs(r));
    found_.distances.push_back(std::sqrt(nn.squared_distance));
  }
  return found_;
}

bool Association::facesEye(std::uint32_t index, const Eigen::Vector3f& eye) const {
  return model_.index->normals[index].vec().dot(eye - model_.index->points[index].vec()) > 0;
}

bool Association::nearestVisible(const Eigen::Vector3f& q, const Eigen::Vector3f& eye, float max_sq,
                                 std::uint32_t previous, KdTree3f::Neighbour& found) const {
  const ModelIndex& model = *model_.index;
  const bool facing = options_.back_face_rejection;
  float bound = max_sq;
  if (previous != kNoMatch && (!facing || facesEye(previous, eye))) {
    const float d = (model.points[previous].vec() - q).squaredNorm();
    bound = std::min(max_sq, d * 1.0001f + 1e-12f);
  }
  auto search = [&](float b) {
    return facing ? model.tree.nearestFacing(q, eye, b, found) : model.tree.nearest(q, b, found);
  };
  if (search(bound) || (bound < max_sq && search(max_sq))) return true;
  return facing && model.tree.nearest(q, max_sq, found);
}

bool Association::nearestFromGrid(const Eigen::Vector3f& q, const Eigen::Vector3f& eye,
                                  float max_sq, KdTree3f::Neighbour& found) {
  NearestGrid& grid = *model_.grid;
  const std::size_t cell = grid.cellAt(q);
  if (cell == NearestGrid::kOutside) return false;
  std::uint32_t label = grid.label(cell);
  if (label == NearestGrid::kNone) return false;  // farther than the band from the model
  if (options_.back_face_rejection && !facesEye(label, eye)) {
    const std::uint32_t other = grid.opposite(cell, model_.index->tree, model_.index->normals);
    if (other == NearestGrid::kNone || !facesEye(other, eye))
      return nearestVisible(q, eye, max_sq, kNoMatch, found);
    label = other;
  }
  const float d = (model_.index->points[label].vec() - q).squaredNorm();
  if (d > max_sq) return false;
  found = {label, d};
  return true;
}

}  // namespace cdff::registration
