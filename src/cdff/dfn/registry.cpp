#include "cdff/dfn/registry.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

namespace cdff::dfn {

Registry& Registry::instance() {
  static Registry registry;  // constructed on first use, so static registrars may run in any order
  return registry;
}

void Registry::addDescription(const DfnDescription& description) {
  descriptions_[description.name] = &description;
}

void Registry::addImplementation(const std::string& dfn, const std::string& dfi, Factory factory) {
  factories_[{dfn, dfi}] = std::move(factory);
}

std::vector<const DfnDescription*> Registry::descriptions() const {
  std::vector<const DfnDescription*> out;
  for (const auto& [name, d] : descriptions_) out.push_back(d);
  return out;
}

const DfnDescription* Registry::findDescription(const std::string& dfn) const {
  auto it = descriptions_.find(dfn);
  return it == descriptions_.end() ? nullptr : it->second;
}

bool Registry::hasImplementation(const std::string& dfn, const std::string& dfi) const {
  return factories_.count({dfn, dfi}) != 0;
}

std::vector<std::pair<std::string, std::string>> Registry::implementations() const {
  std::vector<std::pair<std::string, std::string>> out;
  for (const auto& [key, factory] : factories_) out.push_back(key);
  return out;
}

Result<std::unique_ptr<Node>> Registry::create(const std::string& dfn, const std::string& dfi) const {
  const DfnDescription* d = findDescription(dfn);
  if (!d) {
    std::vector<std::string> names;
    for (const auto& [name, desc] : descriptions_) names.push_back(name);
    return notFound("unknown DFN '{}'; expected one of {{{}}}", dfn, fmt::join(names, ", "));
  }
  auto it = factories_.find({dfn, dfi});
  if (it == factories_.end()) {
    std::vector<std::string> names;
    for (const auto& impl : d->implementations) names.push_back(impl.name);
    return notFound("DFN '{}' has no implementation '{}'; expected one of {{{}}}", dfn, dfi,
                    fmt::join(names, ", "));
  }
  return it->second();
}

}  // namespace cdff::dfn
