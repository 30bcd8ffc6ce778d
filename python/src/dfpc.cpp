// DFPCs from Python (cdff.dfpc): run graphs over recordings as `cdff run` does, and the external
// API of seed §7.3 (cdff.dfpc.Cdff) with the C++ function names. Every call that may wait for
// the API's threads (state changes, flush, cancelling a subscription, destruction) releases the
// GIL, and callbacks take it, so a callback never deadlocks with the thread that waits for it.

#include <optional>

#include <fmt/format.h>
#include <pybind11/eigen.h>
#include <pybind11/functional.h>
#include <pybind11/stl.h>

#include "cdff/dfpc/api.hpp"
#include "cdff/dfpc/recording_streams.hpp"
#include "cdff/dfpc/replay.hpp"
#include "common.hpp"

namespace cdff::python {
namespace {

/// getDFPCStatus as a dict with the keys of every other interface (dfpc::statusRecord).
py::dict statusDict(const dfpc::DfpcStatus& s) {
  return py::module_::import("json").attr("loads")(dfpc::statusRecord(s).dump());
}

py::dict runGraphs(const std::vector<std::string>& graphs, const std::vector<std::string>& inputs,
                   const std::string& output, const std::vector<std::string>& remaps,
                   const std::vector<std::string>& settings,
                   const std::vector<std::string>& passthrough, bool record_timing,
                   const std::vector<std::string>& pairs,
                   const std::vector<std::string>& run_while) {
  dfpc::ReplayOptions options;
  options.graph_files = graphs;
  options.parameter_settings = settings;
  options.passthrough_prefixes = passthrough;
  options.record_timing = record_timing;
  for (const std::string& r : remaps) options.remaps.push_back(take(dfpc::parseRemap(r)));
  for (const std::string& p : pairs)
    options.stereo_pairs.push_back(take(dfpc::parseStereoPairing(p)));
  for (const std::string& r : run_while)
    options.run_while.push_back(take(dfpc::parseActivationRule(r)));
  Result<dfpc::ReplayResult> result = Status::ok();
  {
    py::gil_scoped_release release;
    result = dfpc::replayFiles(inputs, output, options);
  }
  const dfpc::ReplayResult& r = take(std::move(result));
  py::dict summary;
  summary["messages"] = r.summary.messages;
  summary["routed"] = r.summary.routed;
  summary["passed_through"] = r.summary.passed_through;
  summary["products"] = r.summary.products;
  summary["events"] = r.summary.events;
  summary["faults"] = r.summary.faults;
  summary["recoveries"] = r.summary.recoveries;
  summary["first"] = r.summary.first ? py::cast(*r.summary.first) : py::none();
  summary["last"] = r.summary.last ? py::cast(*r.summary.last) : py::none();
  py::list dfpcs;
  for (const dfpc::DfpcStatus& s : r.dfpcs) dfpcs.append(statusDict(s));
  py::dict out;
  out["summary"] = summary;
  out["dfpcs"] = dfpcs;
  out["output"] = output;
  return out;
}

/// Keeps a Python callable alive from C++ threads; released with the GIL held.
std::shared_ptr<py::function> keepCallable(py::function f) {
  return std::shared_ptr<py::function>(new py::function(std::move(f)), [](py::function* p) {
    if (!Py_IsInitialized()) return;
    py::gil_scoped_acquire gil;
    delete p;
  });
}

/// Calls `f(now, value_or_error)` on an API thread, with the GIL; an exception in the callback
/// is reported as unraisable (printed) and never stops the API's thread.
template <typename T, typename ToPython>
void callBack(const std::shared_ptr<py::function>& f, Timestamp now, const Result<T>& result,
              ToPython to_python) {
  if (!Py_IsInitialized()) return;
  py::gil_scoped_acquire gil;
  try {
    (*f)(now, result.isOk() ? to_python(result.value()) : errorOf(result.status()));
  } catch (py::error_already_set& e) {
    e.discard_as_unraisable("a cdff.dfpc.Cdff subscription callback");
  }
}

api::StateRequest requestNamed(const std::string& name) {
  for (api::StateRequest r : {api::StateRequest::kInitialize, api::StateRequest::kIdle,
                              api::StateRequest::kReset, api::StateRequest::kStop})
    if (name == api::toString(r)) return r;
  raise(invalidInput(
      "setCDFFState('{}'): not a state request; expected one of {}, {}, {}, {}", name,
      api::toString(api::StateRequest::kInitialize), api::toString(api::StateRequest::kIdle),
      api::toString(api::StateRequest::kReset), api::toString(api::StateRequest::kStop)));
}

/// The API object, its recorded input and its optional output recording.
class PyCdff {
 public:
  PyCdff(const std::vector<std::string>& graphs, const std::vector<std::string>& recordings,
         const std::string& output, bool realtime, std::size_t live_capacity,
         const std::vector<Transform>& static_transforms) {
    api::Config config;
    config.graph_files = graphs;
    config.realtime = realtime;
    config.live_capacity = live_capacity;
    config.static_transforms = static_transforms;
    Status status;
    {
      py::gil_scoped_release release;
      status = [&]() -> Status {
        if (!recordings.empty()) {
          auto input = std::make_shared<dfpc::McapInputStream>();
          CDFF_RETURN_IF_ERROR(input->open(recordings));
          config.input = input;
        }
        if (!output.empty()) {
          sink_ = std::make_unique<dfpc::McapSink>();
          CDFF_RETURN_IF_ERROR(sink_->open(output));
          config.sink = sink_.get();
        }
        Result<std::unique_ptr<api::Cdff>> created = api::Cdff::create(std::move(config));
        if (!created) return created.status();
        cdff_ = std::move(created).value();
        return Status::ok();
      }();
    }
    check(status);
  }

  ~PyCdff() { close(); }

  /// Stops the API's threads and closes the output; later calls are errors.
  void close() {
    py::gil_scoped_release release;
    cdff_.reset();
    if (sink_) (void)sink_->close();
  }

  api::Cdff& api(const char* call) const {
    if (!cdff_)
      raise(invalidInput("cdff.dfpc.Cdff.{}: the Cdff is closed; expected an open one", call));
    return *cdff_;
  }

  /// Runs `f` on the API without the GIL.
  template <typename F>
  auto unlocked(const char* call, F f) const {
    api::Cdff& a = api(call);
    py::gil_scoped_release release;
    return f(a);
  }

  std::unique_ptr<api::Cdff> cdff_;
  std::unique_ptr<dfpc::McapSink> sink_;
};

py::object velocityDict(const api::VelocityWithCovariance& v) {
  py::dict d;
  d["stamp"] = v.stamp;
  d["frame"] = v.frame;
  d["target_frame"] = v.target_frame;
  d["linear"] = v.twist.linear;
  d["angular"] = v.twist.angular;
  d["covariance"] = v.covariance;
  return d;
}

/// The state machine and the DFPCs' life cycle.
void bindLifecycle(py::class_<PyCdff>& cdff) {
  cdff.def(
          "setCDFFState",
          [](PyCdff& c, const std::string& request) {
            const api::StateRequest r = requestNamed(request);
            check(c.unlocked("setCDFFState", [r](api::Cdff& a) { return a.setCDFFState(r); }));
          },
          py::arg("request"), "'initialize', 'idle', 'reset' or 'stop'.")
      .def("getCDFFState",
           [](PyCdff& c) {
             return std::string(api::toString(c.api("getCDFFState").getCDFFState()));
           })
      .def(
          "getDFPCStatus",
          [](PyCdff& c, const std::string& dfpc) {
            auto s =
                c.unlocked("getDFPCStatus", [&](api::Cdff& a) { return a.getDFPCStatus(dfpc); });
            return statusDict(take(std::move(s)));
          },
          py::arg("dfpc"))
      .def(
          "initDFPC",
          [](PyCdff& c, const std::string& d) {
            check(c.unlocked("initDFPC", [&](api::Cdff& a) { return a.initDFPC(d); }));
          },
          py::arg("dfpc"))
      .def(
          "stopDFPC",
          [](PyCdff& c, const std::string& d) {
            check(c.unlocked("stopDFPC", [&](api::Cdff& a) { return a.stopDFPC(d); }));
          },
          py::arg("dfpc"));
}

/// The synchronous queries: the target's pose, velocity and model.
void bindQueries(py::class_<PyCdff>& cdff) {
  cdff.def(
          "getTargetRelativePose",
          [](PyCdff& c, const std::string& frame) {
            return take(c.unlocked("getTargetRelativePose",
                                   [&](api::Cdff& a) { return a.getTargetRelativePose(frame); }));
          },
          py::arg("frame"))
      .def(
          "getTargetRelativeVelocity",
          [](PyCdff& c, const std::string& frame) {
            return velocityDict(take(c.unlocked("getTargetRelativeVelocity", [&](api::Cdff& a) {
              return a.getTargetRelativeVelocity(frame);
            })));
          },
          py::arg("frame"))
      .def("getModelOfTarget", [](PyCdff& c) -> py::object {
        api::TargetModel model =
            take(c.unlocked("getModelOfTarget", [](api::Cdff& a) { return a.getModelOfTarget(); }));
        if (model.mesh) return py::cast(std::make_shared<TriangleMesh>(*model.mesh));
        return py::cast(std::make_shared<PointCloud>(*model.cloud));
      });
}

/// The asynchronous queries (callbacks at a rate) and their cancellation.
void bindSubscriptions(py::class_<PyCdff>& cdff) {
  cdff.def(
          "getDFPCPose",
          [](PyCdff& c, const std::string& dfpc, double hz, py::function callback) {
            auto f = keepCallable(std::move(callback));
            api::PoseCallback cb = [f](Timestamp now, const Result<PoseWithCovariance>& pose) {
              callBack(f, now, pose, [](const PoseWithCovariance& p) {
                return py::cast(std::make_shared<PoseWithCovariance>(p));
              });
            };
            return take(c.unlocked("getDFPCPose",
                                   [&](api::Cdff& a) { return a.getDFPCPose(dfpc, hz, cb); }));
          },
          py::arg("dfpc"), py::arg("frequency_hz"), py::arg("callback"),
          "Calls callback(now, pose) at frequency_hz with the DFPC's latest pose (a "
          "PoseWithCovariance), or a cdff.Error instance while it has none; returns the "
          "subscription's id.")
      .def(
          "getDFPCStatus",
          [](PyCdff& c, const std::string& dfpc, double hz, py::function callback) {
            auto f = keepCallable(std::move(callback));
            api::StatusCallback cb = [f](Timestamp now, const Result<dfpc::DfpcStatus>& s) {
              callBack(f, now, s, [](const dfpc::DfpcStatus& st) { return statusDict(st); });
            };
            return take(c.unlocked("getDFPCStatus",
                                   [&](api::Cdff& a) { return a.getDFPCStatus(dfpc, hz, cb); }));
          },
          py::arg("dfpc"), py::arg("frequency_hz"), py::arg("callback"),
          "Calls callback(now, status) at frequency_hz with the DFPC's status dict.")
      .def(
          "cancelSubscription",
          [](PyCdff& c, api::SubscriptionId id) {
            check(c.unlocked("cancelSubscription",
                             [id](api::Cdff& a) { return a.cancelSubscription(id); }));
          },
          py::arg("id"));
}

/// Live input and the Data Product Manager's products.
void bindData(py::class_<PyCdff>& cdff) {
  cdff.def(
          "push",
          [](PyCdff& c, const std::string& channel, py::handle value,
             std::optional<Timestamp> stamp, const std::string& type) {
            Value v = valueOf(value, type, fmt::format("Cdff.push('{}')", channel));
            const std::optional<Timestamp> own =
                v.type().info().own_stamp ? v.type().info().own_stamp(v.raw()) : std::nullopt;
            if (!stamp && !own)
              raise(
                  invalidInput("Cdff.push('{}'): a {} has no stamp of its own; expected "
                               "stamp=... (µs)",
                               channel, v.type().name()));
            dfpc::Message message{channel, stamp.value_or(own.value_or(0)), std::move(v)};
            check(c.unlocked("push", [&](api::Cdff& a) { return a.push(std::move(message)); }));
          },
          py::arg("channel"), py::arg("value"), py::arg("stamp") = py::none(), py::arg("type") = "",
          "Queues a sensor message (live input); its stamp is the value's own unless given.")
      .def(
          "flush",
          [](PyCdff& c, double timeout_s) {
            check(c.unlocked("flush", [&](api::Cdff& a) { return a.flush(timeout_s); }));
          },
          py::arg("timeout_s") = 60.0,
          "Waits until every pushed message was processed, or the recording consumed.")
      .def("product_names", [](PyCdff& c) { return c.api("product_names").products()->names(); })
      .def(
          "product",
          [](PyCdff& c, const std::string& name) {
            dfpc::Product p = take(c.api("product").products()->latest(name));
            return py::make_tuple(p.stamp, toPython(p.value));
          },
          py::arg("name"), "(stamp, value) of a product's latest value.")
      .def(
          "history",
          [](PyCdff& c, const std::string& name) {
            py::list out;
            for (const dfpc::Product& p : take(c.api("history").products()->history(name)))
              out.append(py::make_tuple(p.stamp, toPython(p.value)));
            return out;
          },
          py::arg("name"), "[(stamp, value), ...] of a product's kept history, oldest first.");
}

void bindCdffApi(py::module_& m) {
  py::class_<PyCdff> cdff(
      m, "Cdff",
      "The external API of seed §7.3: DFPC graphs run on a recording (recordings=[...]) or on "
      "messages pushed live (push()), their products read or subscribed to. The methods keep "
      "the C++ names; callbacks run on the API's thread with the GIL taken; close() (or leaving "
      "a `with` block) stops the threads and closes the output recording.");
  cdff.def(py::init<const std::vector<std::string>&, const std::vector<std::string>&,
                    const std::string&, bool, std::size_t, const std::vector<Transform>&>(),
           py::arg("graphs"), py::arg("recordings") = std::vector<std::string>{},
           py::arg("output") = "", py::arg("realtime") = false, py::arg("live_capacity") = 1024,
           py::arg("static_transforms") = std::vector<Transform>{})
      .def("close", &PyCdff::close)
      .def("__enter__", [](PyCdff& c) -> PyCdff& { return c; })
      .def("__exit__", [](PyCdff& c, py::args) { c.close(); });
  bindLifecycle(cdff);
  bindQueries(cdff);
  bindSubscriptions(cdff);
  bindData(cdff);
}

}  // namespace

void bindDfpc(py::module_& root) {
  py::module_ m = root.def_submodule("_dfpc", "DFPCs (see cdff.dfpc).");
  m.def("run", &runGraphs, py::arg("graphs"), py::arg("inputs"), py::arg("output"),
        py::arg("remaps") = std::vector<std::string>{},
        py::arg("settings") = std::vector<std::string>{},
        py::arg("passthrough") = dfpc::ReplayOptions{}.passthrough_prefixes,
        py::arg("record_timing") = true, py::arg("pairs") = std::vector<std::string>{},
        py::arg("run_while") = std::vector<std::string>{});
  bindCdffApi(m);
}

}  // namespace cdff::python
