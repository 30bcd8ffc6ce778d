// cdff._core: the compiled part of the `cdff` Python package (python/cdff/ is the rest).

#include "common.hpp"

PYBIND11_MODULE(_core, m) {
  namespace py = pybind11;
  using namespace cdff::python;
  m.doc() = "The compiled CDFF binding; import `cdff` rather than this module.";
  m.attr("__version__") = CDFF_VERSION;
  defineErrors(m);
  bindScalars(m);
  bindGeometry(m);
  bindImages(m);
  bindClouds(m);
  bindFeatures(m);
  bindModels(m);
  bindDfn(m);
  bindIo(m);
  bindSimAndEval(m);
  bindDfpc(m);
}
