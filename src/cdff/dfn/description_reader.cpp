// Reading DFN description files (description.hpp: loadDescription) with the schema reader.
#include <algorithm>
#include <filesystem>
#include <regex>
#include <set>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "cdff/dfn/description.hpp"
#include "cdff/schema/table.hpp"
#include "cdff/types/type_registry.hpp"

namespace cdff::dfn {

namespace {

using schema::Field;
using schema::Table;

const std::set<std::string> kCppKeywords = {
    "in",  "out",    "default", "class", "new",  "delete", "template", "operator", "register",
    "int", "double", "bool",    "float", "char", "auto",   "const",    "static"};

Status identifier(const Field& f, std::string& out, std::string_view what) {
  CDFF_RETURN_IF_ERROR(f.read(out));
  static const std::regex snake("^[a-z][a-z0-9_]*$");
  if (!std::regex_match(out, snake) || kCppKeywords.count(out))
    return f.fail(fmt::format("a {} in snake_case ([a-z][a-z0-9_]*, not a C++ keyword)", what));
  return Status::ok();
}

Status typeName(const Field& f, std::string& out, std::string_view what) {
  CDFF_RETURN_IF_ERROR(f.read(out));
  static const std::regex camel("^[A-Z][A-Za-z0-9]*$");
  if (!std::regex_match(out, camel)) return f.fail(fmt::format("a {} in CamelCase", what));
  return Status::ok();
}

Status doc(const Field& f, std::string& out) {
  CDFF_RETURN_IF_ERROR(f.read(out));
  while (!out.empty() && std::isspace(static_cast<unsigned char>(out.back()))) out.pop_back();
  return Status::ok();
}

Status dataType(const Field& f, std::string& out) {
  CDFF_RETURN_IF_ERROR(f.read(out));
  if (!findType(out)) {
    std::vector<std::string> names;
    for (TypeId t : allTypes()) names.emplace_back(t.name());
    return f.fail(fmt::format("a data type of the registry, one of {}{}", typeNames(),
                              schema::didYouMean(out, names)));
  }
  return Status::ok();
}

Table<PortSpec> portTable(bool input) {
  Table<PortSpec> t(input ? "an input port" : "an output port");
  t.required(
       "name", [](const Field& f, PortSpec& p) { return identifier(f, p.name, "port name"); },
       "a snake_case port name")
      .required(
          "type", [](const Field& f, PortSpec& p) { return dataType(f, p.type); },
          "a data type name")
      .required(
          "doc", [](const Field& f, PortSpec& p) { return doc(f, p.doc); },
          "what the port carries");
  if (input) t.optional("optional", schema::flag(&PortSpec::optional));
  return t;
}

Status readPorts(const Field& f, std::vector<PortSpec>& out, bool input) {
  static const Table<PortSpec> inputs = portTable(true), outputs = portTable(false);
  if (!f.defined()) return Status::ok();
  if (!f.isList()) return f.fail("a list of ports");
  for (const Field& element : f.elements()) {
    PortSpec port;
    CDFF_RETURN_IF_ERROR((input ? inputs : outputs).read(element, port));
    for (const PortSpec& other : out)
      if (other.name == port.name)
        return element["name"].fail("a port name used once", "given twice");
    out.push_back(std::move(port));
  }
  return Status::ok();
}

// ---- parameters

struct RawParameter {
  ParameterSpec spec;
  Field default_field, range_field, values_field, size_field, unit_field;
};

/// Angles in YAML are degrees (description.hpp, kRadiansPerDegree): a unit in radians is refused,
/// and degrees only hold on a number the reader can convert (double, double[]).
Status checkUnit(const RawParameter& raw) {
  const std::string& unit = raw.spec.unit;
  if (unit == "rad" || unit == "rad/s")
    return raw.unit_field.fail(
        fmt::format("{} (angles in YAML are degrees; the C++ field holds {})",
                    unit == "rad" ? "deg" : "deg/s", unit),
        "a unit in radians");
  const ParameterType t = raw.spec.type;
  if (siPerUnit(unit) != 1.0 && t != ParameterType::kDouble && t != ParameterType::kDoubleList)
    return raw.unit_field.fail(
        "deg and deg/s on double and double[] parameters only (their C++ fields hold radians)",
        fmt::format("degrees on the {} parameter '{}'", toString(t), raw.spec.name));
  return Status::ok();
}

/// The default, typed and checked against the type, range, choices and size.
Status readDefault(RawParameter& raw) {
  ParameterSpec& p = raw.spec;
  const Field& f = raw.default_field;
  p.default_text = f.text();
  const schema::Range range =
      schema::Range::closed(p.min ? *p.min : -HUGE_VAL, p.max ? *p.max : HUGE_VAL);
  switch (p.type) {
    case ParameterType::kBool: {
      bool v = false;
      CDFF_RETURN_IF_ERROR(f.read(v));
      p.default_value = v;
      return Status::ok();
    }
    case ParameterType::kInt: {
      std::int64_t v = 0;
      CDFF_RETURN_IF_ERROR(f.read(v, p.min ? static_cast<std::int64_t>(*p.min) : INT32_MIN,
                                  p.max ? static_cast<std::int64_t>(*p.max) : INT32_MAX));
      p.default_value = static_cast<long long>(v);
      return Status::ok();
    }
    case ParameterType::kDouble: {
      double v = 0;
      CDFF_RETURN_IF_ERROR(f.read(v, range));
      p.default_value = v;
      return Status::ok();
    }
    case ParameterType::kString: {
      std::string v;
      CDFF_RETURN_IF_ERROR(p.allowed.empty() ? f.read(v) : f.choice(v, p.allowed));
      p.default_value = v;
      return Status::ok();
    }
    case ParameterType::kDoubleList: {
      std::vector<double> v;
      const std::size_t n = p.list_size ? *p.list_size : 0;
      CDFF_RETURN_IF_ERROR(f.numbers(v, n, p.list_size ? n : SIZE_MAX, range));
      p.default_value = v;
      return Status::ok();
    }
  }
  return Status::ok();
}

Status readRange(const Field& f, ParameterSpec& p) {
  if (!f.isList() || f.size() != 2) return f.fail("[min, max], with null for an open end");
  for (int k = 0; k < 2; ++k) {
    const Field end = f[static_cast<std::size_t>(k)];
    if (!end.defined()) continue;
    double v = 0;
    CDFF_RETURN_IF_ERROR(end.read(v));
    (k == 0 ? p.min : p.max) = v;
  }
  return Status::ok();
}

const Table<RawParameter>& parameterTable() {
  static const Table<RawParameter> table =
      Table<RawParameter>("a parameter")
          .required(
              "name",
              [](const Field& f, RawParameter& r) {
                return identifier(f, r.spec.name, "parameter name");
              },
              "a snake_case parameter name")
          .required(
              "type",
              [](const Field& f, RawParameter& r) -> Status {
                std::string name;
                CDFF_RETURN_IF_ERROR(
                    f.choice(name, {"bool", "int", "double", "string", "double[]"}));
                r.spec.type = *parameterTypeNamed(name);
                return Status::ok();
              },
              "bool, int, double, string or double[]")
          .required(
              "default",
              [](const Field& f, RawParameter& r) {
                r.default_field = f;
                return Status::ok();
              },
              "the default value")
          .required(
              "doc", [](const Field& f, RawParameter& r) { return doc(f, r.spec.doc); },
              "what the parameter does")
          .optional("unit",
                    [](const Field& f, RawParameter& r) {
                      r.unit_field = f;
                      return f.read(r.spec.unit);
                    })
          .optional("range",
                    [](const Field& f, RawParameter& r) {
                      r.range_field = f;
                      return readRange(f, r.spec);
                    })
          .optional("values",
                    [](const Field& f, RawParameter& r) {
                      r.values_field = f;
                      return f.words(r.spec.allowed, "a list of accepted strings");
                    })
          .optional("size", [](const Field& f, RawParameter& r) -> Status {
            int n = 0;
            CDFF_RETURN_IF_ERROR(f.read(n, 1));
            r.size_field = f;
            r.spec.list_size = static_cast<std::size_t>(n);
            return Status::ok();
          });
  return table;
}

Status readParameters(const Field& f, std::vector<ParameterSpec>& out) {
  if (!f.defined()) return Status::ok();
  if (!f.isList()) return f.fail("a list of parameters");
  for (const Field& element : f.elements()) {
    RawParameter raw;
    CDFF_RETURN_IF_ERROR(parameterTable().read(element, raw));
    const ParameterType t = raw.spec.type;
    const bool numeric =
        t == ParameterType::kInt || t == ParameterType::kDouble || t == ParameterType::kDoubleList;
    if (raw.range_field.defined() && !numeric)
      return raw.range_field.fail("no range for a non-numeric parameter");
    if (raw.values_field.defined() && t != ParameterType::kString)
      return raw.values_field.fail("no 'values' but for a string parameter");
    if (raw.size_field.defined() && t != ParameterType::kDoubleList)
      return raw.size_field.fail("no 'size' but for a double[] parameter");
    CDFF_RETURN_IF_ERROR(checkUnit(raw));
    CDFF_RETURN_IF_ERROR(readDefault(raw));
    out.push_back(std::move(raw.spec));
  }
  return Status::ok();
}

// ---- implementations and the file

struct RawImplementation {
  ImplementationSpec spec;
  Field name_field;
};

const Table<RawImplementation>& implementationTable() {
  static const Table<RawImplementation> table =
      Table<RawImplementation>("an implementation")
          .required(
              "name",
              [](const Field& f, RawImplementation& r) {
                r.name_field = f;
                return typeName(f, r.spec.name, "DFI name");
              },
              "a CamelCase DFI name")
          .required(
              "doc", [](const Field& f, RawImplementation& r) { return doc(f, r.spec.doc); },
              "what the DFI does")
          .optional("dependencies",
                    [](const Field& f, RawImplementation& r) {
                      return f.words(r.spec.dependencies, "a list of library names");
                    })
          .optional("parameters", [](const Field& f, RawImplementation& r) {
            return readParameters(f, r.spec.parameters);
          });
  return table;
}

struct RawDescription {
  DfnDescription d;
  std::vector<ParameterSpec> common;
};

const Table<RawDescription>& descriptionTable() {
  static const Table<RawDescription> table =
      Table<RawDescription>("a DFN description")
          .required(
              "name",
              [](const Field& f, RawDescription& r) { return typeName(f, r.d.name, "DFN name"); },
              "the DFN's CamelCase name")
          .required(
              "doc", [](const Field& f, RawDescription& r) { return doc(f, r.d.doc); },
              "what the DFN does")
          .required(
              "inputs",
              [](const Field& f, RawDescription& r) { return readPorts(f, r.d.inputs, true); },
              "a list of input ports")
          .required(
              "outputs",
              [](const Field& f, RawDescription& r) { return readPorts(f, r.d.outputs, false); },
              "a list of output ports")
          .required(
              "implementations",
              [](const Field&, RawDescription&) { return Status::ok(); },  // read below
              "a non-empty list of implementations")
          .optional("parameters",
                    [](const Field& f, RawDescription& r) { return readParameters(f, r.common); });
  return table;
}

Status readImplementations(const Field& f, RawDescription& raw) {
  if (!f.isList() || f.size() == 0) return f.fail("a non-empty list of implementations");
  for (const Field& element : f.elements()) {
    RawImplementation impl;
    CDFF_RETURN_IF_ERROR(implementationTable().read(element, impl));
    std::vector<ParameterSpec> all = raw.common;
    for (ParameterSpec& p : impl.spec.parameters) {
      for (const ParameterSpec& q : all)
        if (q.name == p.name)
          return element["parameters"].fail(
              fmt::format("each parameter once (the DFN's common parameters included)"),
              fmt::format("parameter '{}' is given twice", p.name));
      all.push_back(std::move(p));
    }
    impl.spec.parameters = std::move(all);
    for (const ImplementationSpec& other : raw.d.implementations)
      if (other.name == impl.spec.name)
        return impl.name_field.fail("a DFI name used once", "given twice");
    raw.d.implementations.push_back(std::move(impl.spec));
  }
  return Status::ok();
}

}  // namespace

Result<DfnDescription> loadDescription(const std::string& path, const std::string& area,
                                       const std::string& source_file) {
  Result<schema::Document> document = schema::Document::loadFile(path, "DFN description");
  if (!document) return document.status();
  const Field root = document->root();
  RawDescription raw;
  CDFF_RETURN_IF_ERROR(descriptionTable().read(root, raw));
  const std::string stem = std::filesystem::path(path).stem().string();
  if (raw.d.name != stem)
    return root["name"].fail(fmt::format("the file's name, {} (the file is {}.yaml)", stem, stem),
                             "differs from the file name");
  CDFF_RETURN_IF_ERROR(readImplementations(root["implementations"], raw));
  raw.d.area = area;
  raw.d.source_file = source_file;
  return std::move(raw.d);
}

}  // namespace cdff::dfn
