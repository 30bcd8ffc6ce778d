#include "cao_fixture.hpp"

#include "cdff/egse/model_io.hpp"
#include "cdff/egse/procedural.hpp"

namespace cdff::egse::testing {

CaoFixture writeTargetCao(const std::string& path) {
  CaoFixture fixture;
  auto model = makeTargetSatellite();
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

}  // namespace cdff::egse::testing
