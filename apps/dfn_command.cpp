// cdff dfn list | info NAME
#include <algorithm>
#include <iostream>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "cdff/dfn/registry.hpp"
#include "commands.hpp"

namespace cdff::app {

namespace {

void printList() {
  const auto& registry = dfn::Registry::instance();
  std::size_t name_width = 0, area_width = 0;
  for (const dfn::DfnDescription* d : registry.descriptions()) {
    name_width = std::max(name_width, d->name.size());
    area_width = std::max(area_width, d->area.size());
  }
  for (const dfn::DfnDescription* d : registry.descriptions()) {
    std::vector<std::string> dfis;
    for (const auto& impl : d->implementations) dfis.push_back(impl.name);
    fmt::print("{:<{}} {:<{}} {}\n", d->name, name_width, d->area, area_width,
               fmt::join(dfis, " "));
  }
}

void printPorts(const char* title, const std::vector<dfn::PortSpec>& ports) {
  fmt::print("{}:\n", title);
  if (ports.empty()) fmt::print("  (none)\n");
  for (const auto& p : ports)
    fmt::print("  {:<20} {:<20} {}{}\n", p.name, p.type, p.optional ? "(optional) " : "", p.doc);
}

int printInfo(const std::string& name) {
  const dfn::DfnDescription* d = dfn::Registry::instance().findDescription(name);
  if (!d) {
    std::vector<std::string> names;
    for (const auto* desc : dfn::Registry::instance().descriptions()) names.push_back(desc->name);
    fmt::print(stderr, "error: unknown DFN '{}'; expected one of {{{}}}\n", name,
               fmt::join(names, ", "));
    return 1;
  }
  fmt::print("{} ({})\n{}\n\ndescription: {}\n\n", d->name, d->area, d->doc, d->source_file);
  printPorts("inputs", d->inputs);
  printPorts("outputs", d->outputs);
  for (const auto& impl : d->implementations) {
    fmt::print("\nimplementation {}{}\n  {}\n", impl.name,
               impl.dependencies.empty()
                   ? ""
                   : fmt::format(" (uses {})", fmt::join(impl.dependencies, ", ")),
               impl.doc);
    if (impl.parameters.empty()) fmt::print("  parameters: none\n");
    std::size_t name_width = 0, default_width = 0, unit_width = 1;
    for (const auto& p : impl.parameters) {
      name_width = std::max(name_width, p.name.size());
      default_width = std::max(default_width, p.default_text.size());
      unit_width = std::max(unit_width, p.unit.size());
    }
    for (const auto& p : impl.parameters) {
      fmt::print("  {:<{}} {:<8} default {:<{}} {:<{}} accepts {}\n      {}\n", p.name, name_width,
                 dfn::toString(p.type), p.default_text, default_width,
                 p.unit.empty() ? "-" : p.unit, unit_width, p.acceptedText(), p.doc);
    }
  }
  return 0;
}

}  // namespace

void addDfnCommands(CLI::App& root, int& exit_code) {
  CLI::App* dfn = root.add_subcommand("dfn", "Inspect the DFN types and their implementations");
  dfn->require_subcommand(1);

  CLI::App* list = dfn->add_subcommand("list", "Print every DFN type and its DFIs, one per line");
  list->callback([&exit_code] {
    printList();
    exit_code = 0;
  });

  CLI::App* info = dfn->add_subcommand("info", "Print a DFN's ports, parameters, defaults, ranges");
  auto name = std::make_shared<std::string>();
  info->add_option("NAME", *name, "DFN type name, as printed by `cdff dfn list`")->required();
  info->callback([name, &exit_code] { exit_code = printInfo(*name); });
}

}  // namespace cdff::app
