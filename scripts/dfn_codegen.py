#!/usr/bin/env python3
"""Generates a DFN type's C++ interface from its YAML description.

    dfn_codegen.py DESCRIPTION.yaml --area AREA --source-root ROOT --out DIR

Writes DIR/<Name>.gen.hpp and DIR/<Name>.gen.cpp: the DFN base class with typed input and output
ports, one parameter struct and one base class per implementation (DFI) with YAML parsing and
range checks, and the DfnDescription that the registry, `cdff dfn info` and the tests read.
Loading (load_description) is separate from emitting (emit_*), so further emitters, such as the
pybind11 bindings, read the same checked description. A malformed description fails the build
with "file:line: what, expected what".
"""

import argparse
import pathlib
import re
import sys

import yaml

# Port types: YAML name -> C++ type. Must match the CDFF_PORT_TYPE list in src/cdff/dfn/port.hpp.
PORT_TYPES = {
    "Image": "::cdff::Image",
    "StereoImagePair": "::cdff::StereoImagePair",
    "DepthMap": "::cdff::DepthMap",
    "CameraModel": "::cdff::CameraModel",
    "PointCloud": "::cdff::PointCloud",
    "Transform": "::cdff::Transform",
    "PoseWithCovariance": "::cdff::PoseWithCovariance",
    "RigidBodyState": "::cdff::RigidBodyState",
    "ImuSample": "::cdff::ImuSample",
    "Wrench": "::cdff::Wrench",
    "JointState": "::cdff::JointState",
    "Features2D": "::cdff::Features2D",
    "Features3D": "::cdff::Features3D",
    "Matches": "::cdff::Matches",
    "Correspondences2D": "::cdff::Correspondences2D",
    "Correspondences3D": "::cdff::Correspondences3D",
    "Correspondences2D3D": "::cdff::Correspondences2D3D",
    "TriangleMesh": "::cdff::TriangleMesh",
    "PolygonModel": "::cdff::PolygonModel",
    "ModelContours": "::cdff::ModelContours",
    "ContourSamples": "::cdff::ContourSamples",
    "Timestamp": "::cdff::Timestamp",
    "Double": "double",
    "Bool": "bool",
    "Int": "int",
    "String": "std::string",
}

# Parameter types: YAML name -> (C++ type, ParameterType enumerator).
PARAMETER_TYPES = {
    "bool": ("bool", "kBool"),
    "int": ("int", "kInt"),
    "double": ("double", "kDouble"),
    "string": ("std::string", "kString"),
    "double[]": ("std::vector<double>", "kDoubleList"),
}

IDENTIFIER = re.compile(r"^[a-z][a-z0-9_]*$")
TYPE_NAME = re.compile(r"^[A-Z][A-Za-z0-9]*$")
CPP_KEYWORDS = {"in", "out", "default", "class", "new", "delete", "template", "operator",
                "register", "int", "double", "bool", "float", "char", "auto", "const", "static"}


class DescriptionError(Exception):
    pass


class LineLoader(yaml.SafeLoader):
    """Keeps the line of every mapping so that errors can point at it."""


def _construct_mapping(loader, node):
    mapping = loader.construct_mapping(node, deep=True)
    mapping["__line__"] = node.start_mark.line + 1
    return mapping


LineLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)


class Checker:
    def __init__(self, path):
        self.path = path

    def fail(self, node, message):
        line = node.get("__line__", 1) if isinstance(node, dict) else 1
        raise DescriptionError(f"{self.path}:{line}: {message}")

    def keys(self, node, where, required, optional=()):
        if not isinstance(node, dict):
            raise DescriptionError(f"{self.path}: {where} must be a map")
        for key in required:
            if key not in node:
                self.fail(node, f"{where} lacks the key '{key}'; expected keys {sorted(required)}")
        allowed = set(required) | set(optional) | {"__line__"}
        for key in node:
            if key not in allowed:
                self.fail(node, f"{where} has an unknown key '{key}'; expected one of "
                                f"{sorted(allowed - {'__line__'})}")

    def identifier(self, node, value, where):
        if not isinstance(value, str) or not IDENTIFIER.match(value) or value in CPP_KEYWORDS:
            self.fail(node, f"{where} '{value}' is not a valid name; expected snake_case "
                            f"([a-z][a-z0-9_]*, not a C++ keyword)")


def load_description(path):
    check = Checker(path)
    try:
        with open(path, encoding="utf-8") as f:
            root = yaml.load(f, Loader=LineLoader)
    except OSError as e:
        raise DescriptionError(f"{path}: cannot read: {e.strerror}")
    except yaml.YAMLError as e:
        raise DescriptionError(f"{path}: YAML syntax error: {e}")
    check.keys(root, "the description", ["name", "doc", "inputs", "outputs", "implementations"],
               ["parameters"])
    if not isinstance(root["name"], str) or not TYPE_NAME.match(root["name"]):
        check.fail(root, f"name '{root['name']}' must be CamelCase ([A-Z][A-Za-z0-9]*)")
    if pathlib.Path(path).stem != root["name"]:
        check.fail(root, f"name '{root['name']}' differs from the file name "
                         f"'{pathlib.Path(path).name}'; expected {root['name']}.yaml")

    def ports(key):
        items = root[key] or []
        if not isinstance(items, list):
            check.fail(root, f"'{key}' must be a list of ports")
        seen = set()
        out = []
        for port in items:
            check.keys(port, f"{key} entry", ["name", "type", "doc"],
                       ["optional"] if key == "inputs" else [])
            check.identifier(port, port["name"], "port name")
            if port["name"] in seen:
                check.fail(port, f"port '{port['name']}' appears twice in {key}")
            seen.add(port["name"])
            if port["type"] not in PORT_TYPES:
                check.fail(port, f"port '{port['name']}' has type '{port['type']}'; expected one "
                                 f"of {sorted(PORT_TYPES)}")
            optional = port.get("optional", False)
            if not isinstance(optional, bool):
                check.fail(port, f"port '{port['name']}' optional: expected true or false")
            out.append({"name": port["name"], "type": port["type"], "doc": str(port["doc"]).strip(),
                        "optional": optional})
        return out

    def parameters(items, where):
        items = items or []
        if not isinstance(items, list):
            check.fail(root, f"{where} must be a list of parameters")
        out = []
        for p in items:
            check.keys(p, f"{where} entry", ["name", "type", "default", "doc"],
                       ["unit", "range", "values", "size"])
            check.identifier(p, p["name"], "parameter name")
            if p["type"] not in PARAMETER_TYPES:
                check.fail(p, f"parameter '{p['name']}' has type '{p['type']}'; expected one of "
                              f"{sorted(PARAMETER_TYPES)}")
            spec = {"name": p["name"], "type": p["type"], "default": p["default"],
                    "unit": str(p.get("unit", "")), "doc": str(p["doc"]).strip(),
                    "min": None, "max": None, "values": [], "size": p.get("size")}
            if "range" in p:
                r = p["range"]
                if (not isinstance(r, list) or len(r) != 2 or
                        any(v is not None and not isinstance(v, (int, float)) for v in r)):
                    check.fail(p, f"parameter '{p['name']}' range must be [min, max] (null for "
                                  f"an open end)")
                spec["min"], spec["max"] = r
                if p["type"] not in ("int", "double", "double[]"):
                    check.fail(p, f"parameter '{p['name']}' of type {p['type']} cannot have a range")
            if "values" in p:
                if p["type"] != "string" or not isinstance(p["values"], list):
                    check.fail(p, f"parameter '{p['name']}': 'values' is for string parameters, "
                                  f"as a list")
                spec["values"] = [str(v) for v in p["values"]]
            validate_default(check, p, spec)
            out.append(spec)
        return out

    common = parameters(root.get("parameters"), "parameters")
    impls = root["implementations"]
    if not isinstance(impls, list) or not impls:
        check.fail(root, "implementations must be a non-empty list")
    implementations = []
    for impl in impls:
        check.keys(impl, "implementations entry", ["name", "doc"], ["dependencies", "parameters"])
        if not isinstance(impl["name"], str) or not TYPE_NAME.match(impl["name"]):
            check.fail(impl, f"implementation name '{impl['name']}' must be CamelCase")
        own = parameters(impl.get("parameters"), f"implementation {impl['name']} parameters")
        names = [p["name"] for p in common + own]
        dupes = {n for n in names if names.count(n) > 1}
        if dupes:
            check.fail(impl, f"implementation {impl['name']} repeats parameter(s) {sorted(dupes)}")
        implementations.append({"name": impl["name"], "doc": str(impl["doc"]).strip(),
                                "dependencies": [str(d) for d in impl.get("dependencies", [])],
                                "parameters": common + own})
    inputs, outputs = ports("inputs"), ports("outputs")
    return {"name": root["name"], "doc": str(root["doc"]).strip(), "inputs": inputs,
            "outputs": outputs, "implementations": implementations}


def validate_default(check, node, spec):
    value, kind, name = spec["default"], spec["type"], spec["name"]
    ok = {
        "bool": lambda v: isinstance(v, bool),
        "int": lambda v: isinstance(v, int) and not isinstance(v, bool),
        "double": lambda v: isinstance(v, (int, float)) and not isinstance(v, bool),
        "string": lambda v: isinstance(v, str),
        "double[]": lambda v: isinstance(v, list) and all(
            isinstance(x, (int, float)) and not isinstance(x, bool) for x in v),
    }[kind](value)
    if not ok:
        check.fail(node, f"parameter '{name}' default {value!r} is not a {kind}")
    numbers = value if kind == "double[]" else ([value] if kind in ("int", "double") else [])
    for v in numbers:
        if (spec["min"] is not None and v < spec["min"]) or (
                spec["max"] is not None and v > spec["max"]):
            check.fail(node, f"parameter '{name}' default {v} is outside its range "
                             f"[{spec['min']}, {spec['max']}]")
    if kind == "string" and spec["values"] and value not in spec["values"]:
        check.fail(node, f"parameter '{name}' default '{value}' is not one of {spec['values']}")
    if kind == "double[]" and spec["size"] is not None and len(value) != spec["size"]:
        check.fail(node, f"parameter '{name}' default has {len(value)} values; expected "
                         f"{spec['size']}")


def cpp_string(text):
    escaped = (text.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n"))
    return f'"{escaped}"'


def cpp_literal(spec):
    value, kind = spec["default"], spec["type"]
    if kind == "bool":
        return "true" if value else "false"
    if kind == "int":
        return str(value)
    if kind == "double":
        return repr(float(value))
    if kind == "string":
        return f"std::string({cpp_string(value)})"
    return "std::vector<double>{" + ", ".join(repr(float(v)) for v in value) + "}"


def yaml_text(spec):
    value = spec["default"]
    if spec["type"] == "bool":
        return "true" if value else "false"
    if spec["type"] == "double[]":
        return "[" + ", ".join(str(v) for v in value) + "]"
    return str(value)


def comment(text, indent):
    return "\n".join(f"{indent}/// {line}".rstrip() for line in text.splitlines())


def emit_header(d):
    name = d["name"]
    lines = [
        "// Generated by scripts/dfn_codegen.py from the DFN description. Do not edit.",
        "#pragma once",
        "",
        "#include <string>",
        "#include <vector>",
        "",
        '#include "cdff/dfn/node.hpp"',
        '#include "cdff/dfn/parameters.hpp"',
        '#include "cdff/dfn/registry.hpp"',
        "",
        "namespace cdff::dfn {",
        "",
        comment(d["doc"], ""),
        f"class {name} : public Node {{",
        " public:",
        "  static const DfnDescription& staticDescription();",
        "",
        "  struct Inputs {",
    ]
    for p in d["inputs"]:
        lines.append(comment(p["doc"] + (" (optional)" if p["optional"] else ""), "    "))
        lines.append(f"    InputPort<{PORT_TYPES[p['type']]}> {p['name']}{{\"{p['name']}\", "
                     f"{'true' if p['optional'] else 'false'}}};")
    lines += ["  };", "  struct Outputs {"]
    for p in d["outputs"]:
        lines.append(comment(p["doc"], "    "))
        lines.append(f"    OutputPort<{PORT_TYPES[p['type']]}> {p['name']}{{\"{p['name']}\"}};")
    lines += [
        "  };",
        "",
        "  Inputs in;",
        "  Outputs out;",
        "",
        " protected:",
        f"  explicit {name}(const std::string& implementation)",
        "      : Node(staticDescription(), implementation) {",
    ]
    lines += [f"    registerInput(in.{p['name']});" for p in d["inputs"]]
    lines += [f"    registerOutput(out.{p['name']});" for p in d["outputs"]]
    lines += ["  }", "};", ""]
    for impl in d["implementations"]:
        full = f"{name}{impl['name']}"
        lines += [f"/// Parameters of {name}/{impl['name']}.", f"struct {full}Parameters {{"]
        for p in impl["parameters"]:
            extra = []
            if p["unit"]:
                extra.append(f"unit: {p['unit']}")
            if p["min"] is not None or p["max"] is not None:
                extra.append(f"range: [{p['min']}, {p['max']}]")
            if p["values"]:
                extra.append("values: {" + ", ".join(p["values"]) + "}")
            doc = p["doc"] + (f" ({'; '.join(extra)})" if extra else "")
            lines.append(comment(doc, "  "))
            lines.append(f"  {PARAMETER_TYPES[p['type']][0]} {p['name']} = {cpp_literal(p)};")
        lines += [
            "};",
            "",
            comment(impl["doc"], ""),
            f"class {full}Base : public {name} {{",
            " public:",
            f"  using Parameters = {full}Parameters;",
            f"  static constexpr const char* kImplementation = \"{impl['name']}\";",
            "",
            "  const Parameters& parameters() const { return params_; }",
            "  /// Sets parameters from C++, checked against the description as YAML ones are.",
            "  Status configure(const Parameters& parameters) {",
            "    return Node::configure(toYaml(parameters), \"<C++ parameters>\");",
            "  }",
            "  using Node::configure;",
            "  YAML::Node parametersAsYaml() const override { return toYaml(params_); }",
            "  static YAML::Node toYaml(const Parameters& parameters);",
            "",
            " protected:",
            f"  {full}Base() : {name}(kImplementation) {{}}",
            "  Status applyParameters(const YAML::Node& node, const std::string& source) override;",
            "",
            "  Parameters params_;",
            "};",
            "",
        ]
    lines += ["}  // namespace cdff::dfn", ""]
    return "\n".join(lines)


def emit_source(d, area, source_file):
    name = d["name"]
    lines = [
        "// Generated by scripts/dfn_codegen.py from the DFN description. Do not edit.",
        f'#include "{name}.gen.hpp"',
        "",
        "namespace cdff::dfn {",
        "",
        "namespace {",
        "DfnDescription makeDescription() {",
        "  DfnDescription d;",
        f"  d.name = {cpp_string(name)};",
        f"  d.area = {cpp_string(area)};",
        f"  d.doc = {cpp_string(d['doc'])};",
        f"  d.source_file = {cpp_string(source_file)};",
    ]
    for key in ("inputs", "outputs"):
        for p in d[key]:
            lines.append(f"  d.{key}.push_back({{{cpp_string(p['name'])}, {cpp_string(p['type'])}, "
                         f"{cpp_string(p['doc'])}, {'true' if p['optional'] else 'false'}}});")
    for impl in d["implementations"]:
        lines += ["  {", "    ImplementationSpec impl;",
                  f"    impl.name = {cpp_string(impl['name'])};",
                  f"    impl.doc = {cpp_string(impl['doc'])};"]
        for dep in impl["dependencies"]:
            lines.append(f"    impl.dependencies.push_back({cpp_string(dep)});")
        for p in impl["parameters"]:
            lines += ["    {", "      ParameterSpec p;",
                      f"      p.name = {cpp_string(p['name'])};",
                      f"      p.type = ParameterType::{PARAMETER_TYPES[p['type']][1]};",
                      f"      p.default_text = {cpp_string(yaml_text(p))};",
                      f"      p.unit = {cpp_string(p['unit'])};",
                      f"      p.doc = {cpp_string(p['doc'])};"]
            if p["min"] is not None:
                lines.append(f"      p.min = {float(p['min'])!r};")
            if p["max"] is not None:
                lines.append(f"      p.max = {float(p['max'])!r};")
            for v in p["values"]:
                lines.append(f"      p.allowed.push_back({cpp_string(v)});")
            if p["size"] is not None:
                lines.append(f"      p.list_size = {int(p['size'])};")
            lines += ["      impl.parameters.push_back(std::move(p));", "    }"]
        lines += ["    d.implementations.push_back(std::move(impl));", "  }"]
    lines += [
        "  return d;",
        "}",
        "",
        f"const detail::DescriptionRegistrar kDescriptionRegistrar({name}::staticDescription());",
        "}  // namespace",
        "",
        f"const DfnDescription& {name}::staticDescription() {{",
        "  static const DfnDescription description = makeDescription();",
        "  return description;",
        "}",
        "",
    ]
    for impl in d["implementations"]:
        full = f"{name}{impl['name']}Base"
        lines += [
            f"Status {full}::applyParameters(const YAML::Node& node, const std::string& source) {{",
            "  const auto& specs = implementation().parameters;",
            "  Parameters p;",
            "  ParameterReader reader(node, source, name());",
        ]
        for i, p in enumerate(impl["parameters"]):
            lines.append(f"  reader.read(specs[{i}], p.{p['name']});")
        lines += [
            "  CDFF_RETURN_IF_ERROR(reader.finish(specs));",
            "  params_ = std::move(p);",
            "  return Status::ok();",
            "}",
            "",
            f"YAML::Node {full}::toYaml(const Parameters& parameters) {{",
            "  YAML::Node node(YAML::NodeType::Map);",
        ]
        for p in impl["parameters"]:
            lines.append(f"  node[\"{p['name']}\"] = parameters.{p['name']};")
        lines += ["  return node;", "}", ""]
    lines += ["}  // namespace cdff::dfn", ""]
    return "\n".join(lines)


def write_if_changed(path, text):
    # Unchanged outputs keep their timestamps, so ninja does not recompile their users.
    path = pathlib.Path(path)
    if path.exists() and path.read_text(encoding="utf-8") == text:
        return
    path.write_text(text, encoding="utf-8")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("description")
    parser.add_argument("--area", required=True)
    parser.add_argument("--source-root", required=True)
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    try:
        d = load_description(args.description)
    except DescriptionError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rel = str(pathlib.Path(args.description).resolve().relative_to(
        pathlib.Path(args.source_root).resolve()))
    write_if_changed(out / f"{d['name']}.gen.hpp", emit_header(d))
    write_if_changed(out / f"{d['name']}.gen.cpp", emit_source(d, args.area, rel))
    return 0


if __name__ == "__main__":
    sys.exit(main())
