#include "cdff/dfn/node.hpp"

#include <time.h>

#include <exception>

#include <fmt/format.h>

#include "cdff/schema/field.hpp"

namespace cdff::dfn {

namespace {
constexpr std::size_t kMaxKeptWarnings = 32;

double threadCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

const ImplementationSpec& findOrFirst(const DfnDescription& d, const std::string& impl) {
  // The registry only constructs listed implementations; the fallback keeps the reference valid.
  const ImplementationSpec* spec = d.findImplementation(impl);
  return spec ? *spec : d.implementations.front();
}
}  // namespace

Node::Node(const DfnDescription& description, const std::string& implementation)
    : description_(description),
      implementation_(findOrFirst(description, implementation)),
      name_(description.name + "/" + implementation) {}

Status Node::configureIn(const YAML::Node& parameters, const std::string& source,
                         ParameterUnits units) {
  Status status;
  try {
    status = applyParameters(parameters, source, units);
    if (status) status = onConfigure();
  } catch (const std::exception& e) {
    status = {StatusCode::kInternal, fmt::format("configure() threw: {}", e.what())};
  }
  configured_ = status.isOk();
  if (!status) {
    diagnostics_.last_status = status;
    diagnostics_.last_error = status.message();
  }
  return status;
}

Status Node::configureFromFile(const std::string& path) {
  Result<schema::Document> document =
      schema::Document::loadFile(path, fmt::format("the parameter file of {}", name_));
  if (!document) return document.status();
  return configure(document->root().node(), path);
}

Status Node::process() {
  if (!configured_) {
    Status s = configureDefaults();
    if (!s) return s.withContext(name_);
  }
  for (const InputPortBase* in : inputs_) {
    if (!in->optional() && !in->hasValue()) {
      Status s = invalidInput("{}: required input '{}' ({}) is not set", name_, in->name(),
                              in->type().name());
      diagnostics_.last_status = s;
      diagnostics_.last_error = s.message();
      ++diagnostics_.error_count;
      return s;
    }
  }

  // Outputs are shared pointers: saving them costs a reference count each.
  std::vector<Value> saved_outputs;
  saved_outputs.reserve(outputs_.size());
  for (const OutputPortBase* out : outputs_) saved_outputs.push_back(out->anyValue());

  const auto wall_start = std::chrono::steady_clock::now();
  const double cpu_start = threadCpuSeconds();
  Status status;
  try {
    status = onProcess();
  } catch (const std::exception& e) {
    status = {StatusCode::kInternal, fmt::format("process() threw: {}", e.what())};
  } catch (...) {
    status = {StatusCode::kInternal, "process() threw a non-standard exception"};
  }
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  const double cpu = threadCpuSeconds() - cpu_start;

  Diagnostics& d = diagnostics_;
  ++d.call_count;
  d.last_wall_s = wall;
  d.total_wall_s += wall;
  d.max_wall_s = std::max(d.max_wall_s, wall);
  d.last_cpu_s = cpu;
  d.total_cpu_s += cpu;

  for (InputPortBase* in : inputs_) in->markConsumed();

  if (!status) {
    for (std::size_t i = 0; i < outputs_.size(); ++i)
      (void)outputs_[i]->setAny(std::move(saved_outputs[i]));
    status = status.withContext(name_);
    ++d.error_count;
    d.last_error = status.message();
  }
  d.last_status = status;
  return status;
}

void Node::warn(std::string message) {
  ++diagnostics_.warning_count;
  diagnostics_.warnings.push_back(std::move(message));
  if (diagnostics_.warnings.size() > kMaxKeptWarnings) diagnostics_.warnings.pop_front();
}

InputPortBase* Node::findInput(std::string_view name) const {
  for (InputPortBase* p : inputs_)
    if (p->name() == name) return p;
  return nullptr;
}

OutputPortBase* Node::findOutput(std::string_view name) const {
  for (OutputPortBase* p : outputs_)
    if (p->name() == name) return p;
  return nullptr;
}

}  // namespace cdff::dfn
