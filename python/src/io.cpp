// Recordings from Python (cdff.io): read MCAP files as Messages whose values are CDFF data
// types (large arrays share the file's decompressed chunk), write them with the recording
// library's schemas, and list a recording's channels.

#include <optional>

#include <fmt/format.h>
#include <pybind11/stl.h>

#include "cdff/io/recorder.hpp"
#include "cdff/io/replay.hpp"
#include "common.hpp"

namespace cdff::python {
namespace {

/// One recorded message: its channel, log time (µs) and value (None when the channel's type is
/// not a CDFF one, e.g. a ROS 2 message; `schema` then names it).
struct PyMessage {
  std::string channel;
  Timestamp stamp = 0;
  py::object value;
  std::string type;    // the CDFF type's name, "" when none
  std::string schema;  // the MCAP schema's name
};

/// Iterates a Replay; decoding and reading run without the GIL.
class Reader {
 public:
  Reader(const std::vector<std::string>& paths, const std::vector<std::string>& channels,
         std::optional<Timestamp> start, std::optional<Timestamp> end) {
    io::ReplayOptions options;
    options.channels = channels;
    options.start = start;
    options.end = end;
    check(replay_.open(paths, options));
  }

  PyMessage next() {
    bool more = false;
    Result<Value> value = Status::ok();
    {
      py::gil_scoped_release release;
      more = replay_.next();
      if (more && replay_.message().type().valid()) value = replay_.message().decode();
    }
    if (!more) {
      check(replay_.status());  // a truncated file: every message before the damage came first
      throw py::stop_iteration();
    }
    const io::ReplayMessage& m = replay_.message();
    PyMessage out{m.channel(), m.logTime(), py::none(),
                  m.type().valid() ? std::string(m.type().name()) : std::string(),
                  std::string(m.schemaName())};
    if (m.type().valid()) out.value = toPython(take(std::move(value)));
    return out;
  }

  py::list channels() const {
    py::list out;
    for (const io::ReplayChannel& c : replay_.channels()) {
      py::dict d;
      d["channel"] = c.topic;
      d["type"] = c.type.valid() ? std::string(c.type.name()) : std::string();
      d["schema"] = c.schema_name;
      d["message_count"] = c.message_count;
      out.append(d);
    }
    return out;
  }

  std::pair<Timestamp, Timestamp> timeRange() const {
    return {replay_.startTime(), replay_.endTime()};
  }

 private:
  io::Replay replay_;
};

/// Writes an MCAP recording; values take their CDFF type from their Python type (or `type`).
class Writer {
 public:
  explicit Writer(const std::string& path) : path_(path) { check(recorder_.open(path)); }

  void write(const std::string& channel, py::handle value, std::optional<Timestamp> stamp,
             const std::string& type) {
    if (!recorder_.isOpen())
      raise(Status(StatusCode::kInvalidInput,
                   fmt::format("cdff.io.Writer('{}'): write on channel '{}' after close(); "
                               "expected an open writer",
                               path_, channel)));
    Value v = valueOf(value, type, fmt::format("cdff.io.Writer.write('{}')", channel));
    // A value without a stamp of its own is written at `stamp`; one with a stamp ignores it.
    Status s;
    {
      py::gil_scoped_release release;
      s = recorder_.write(channel, v, stamp.value_or(0));
    }
    check(s);
  }

  void close() {
    if (!recorder_.isOpen()) return;
    Status s;
    {
      py::gil_scoped_release release;
      s = recorder_.close();
    }
    check(s);
  }

 private:
  std::string path_;
  io::Recorder recorder_;
};

std::vector<std::string> pathsOf(py::handle paths) {
  if (py::isinstance<py::str>(paths) || py::hasattr(paths, "__fspath__")) return {pathOf(paths)};
  std::vector<std::string> out;
  for (py::handle p : paths) out.push_back(pathOf(p));
  return out;
}

}  // namespace

void bindIo(py::module_& root) {
  py::module_ m = root.def_submodule("_io", "Recordings (see cdff.io).");
  py::class_<PyMessage>(m, "Message", "One recorded message.")
      .def(py::init([](std::string channel, Timestamp stamp, py::object value) {
             return PyMessage{std::move(channel), stamp, std::move(value), "", ""};
           }),
           py::arg("channel"), py::arg("stamp"), py::arg("value"))
      .def_readonly("channel", &PyMessage::channel)
      .def_readonly("stamp", &PyMessage::stamp, "log time, µs")
      .def_readonly("value", &PyMessage::value,
                    "the CDFF value, or None when the channel's type is not a CDFF one")
      .def_readonly("type", &PyMessage::type, "the CDFF type's name ('' when none)")
      .def_readonly("schema", &PyMessage::schema, "the MCAP schema's name")
      .def("__repr__", [](const PyMessage& m) {
        return fmt::format("<cdff.io.Message {} at {} µs: {}>", m.channel, m.stamp,
                           m.type.empty() ? m.schema : m.type);
      });
  py::class_<Reader>(m, "Reader",
                     "Messages of one or several MCAP files, merged in log-time order.")
      .def(py::init([](py::handle paths, std::vector<std::string> channels,
                       std::optional<Timestamp> start, std::optional<Timestamp> end) {
             return std::make_unique<Reader>(pathsOf(paths), channels, start, end);
           }),
           py::arg("paths"), py::arg("channels") = std::vector<std::string>{},
           py::arg("start") = py::none(), py::arg("end") = py::none())
      .def("__iter__", [](Reader& r) -> Reader& { return r; })
      .def("__next__", &Reader::next)
      .def_property_readonly("channels", &Reader::channels)
      .def_property_readonly("time_range", &Reader::timeRange, "(first, last) log time, µs");
  py::class_<Writer>(m, "Writer", "An MCAP recording being written; a context manager.")
      .def(py::init([](py::handle path) { return std::make_unique<Writer>(pathOf(path)); }),
           py::arg("path"))
      .def("write", &Writer::write, py::arg("channel"), py::arg("value"),
           py::arg("stamp") = py::none(), py::arg("type") = "",
           "Writes a value on a channel. Its log time is its own stamp (an image's, a cloud's, "
           "a pose's), else `stamp` (µs). `type` names the CDFF type when the Python type "
           "does not decide it (an int as 'Timestamp' rather than 'Int').")
      .def("close", &Writer::close)
      .def("__enter__", [](Writer& w) -> Writer& { return w; })
      .def("__exit__", [](Writer& w, py::args) { w.close(); });
}

}  // namespace cdff::python
