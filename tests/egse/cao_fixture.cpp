#include "cao_fixture.hpp"

#include "cdff/egse/model_io.hpp"
#include "cdff/egse/model_perturbation.hpp"
#include "cdff/egse/procedural.hpp"

namespace cdff::egse::testing {

namespace {

CaoFixture write(const Result<TargetModel>& model, const std::string& path) {
  CaoFixture fixture;
  if (!model) {
    fixture.error = model.status().toString();
    return fixture;
  }
  if (Status s = writeCao(*model, path); !s) {
    fixture.error = s.toString();
    return fixture;
  }
  fixture.polygon_count = model->polygons.size();
  fixture.aft_face_x = model->mesh.vertices[model->polygons[0].vertices[0]].x();
  return fixture;
}

}  // namespace

CaoFixture writeTargetCao(const std::string& path) {
  return write(makeTargetSatellite(), path);
}

CaoFixture writeHexagonalCao(const std::string& path) {
  return write(makeHexagonalSatellite(), path);
}

CaoFixture writePerturbedCao(const std::string& path) {
  auto model = makeTargetSatellite();
  if (!model) return write(model, path);
  ModelPerturbation p;
  p.scale_error = Eigen::Vector3d::Constant(0.01);
  p.remove_parts = {"antenna"};
  p.add_boxes = {{"payload", {0.3, 0.0, 0.6}, {0.1, 0.1, 0.1}}};
  p.flip_diagonals = true;
  p.max_edge = 0.1;
  return write(perturbModel(*model, p), path);
}

}  // namespace cdff::egse::testing
