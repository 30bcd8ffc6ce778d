#pragma once
// The registry of DFN descriptions and DFI factories. Both register themselves at static
// initialisation (generated code for descriptions, CDFF_REGISTER_DFI for DFIs): adding a DFN or
// a DFI never means editing a central list.

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "cdff/dfn/description.hpp"
#include "cdff/dfn/node.hpp"

namespace cdff::dfn {

class Registry {
 public:
  using Factory = std::function<std::unique_ptr<Node>()>;

  static Registry& instance();

  void addDescription(const DfnDescription& description);
  void addImplementation(const std::string& dfn, const std::string& dfi, Factory factory);

  /// All descriptions, sorted by name.
  std::vector<const DfnDescription*> descriptions() const;
  const DfnDescription* findDescription(const std::string& dfn) const;
  bool hasImplementation(const std::string& dfn, const std::string& dfi) const;
  /// Registered (dfn, dfi) pairs, sorted.
  std::vector<std::pair<std::string, std::string>> implementations() const;

  /// A new, unconfigured instance; an error lists the known DFNs or DFIs when a name is wrong.
  Result<std::unique_ptr<Node>> create(const std::string& dfn, const std::string& dfi) const;

  /// As create(), typed as the DFN's generated class (e.g. EdgeDetection) or a DFI's base, so
  /// that its ports and parameters are reachable; an error if the instance is not a T.
  template <typename T>
  Result<std::unique_ptr<T>> createAs(const std::string& dfn, const std::string& dfi) const {
    Result<std::unique_ptr<Node>> node = create(dfn, dfi);
    if (!node) return node.status();
    T* typed = dynamic_cast<T*>(node.value().get());
    if (!typed)
      return Status(StatusCode::kInvalidInput,
                    fmt::format("{}/{} is not an instance of the requested C++ class; expected "
                                "the generated class of DFN '{}' or one of its DFI bases",
                                dfn, dfi, dfn));
    node.value().release();
    return std::unique_ptr<T>(typed);
  }

 private:
  std::map<std::string, const DfnDescription*> descriptions_;
  std::map<std::pair<std::string, std::string>, Factory> factories_;
};

namespace detail {
struct DescriptionRegistrar {
  explicit DescriptionRegistrar(const DfnDescription& d) { Registry::instance().addDescription(d); }
};
template <typename Dfi>
struct DfiRegistrar {
  DfiRegistrar() {
    Registry::instance().addImplementation(Dfi::staticDescription().name, Dfi::kImplementation,
                                           [] { return std::make_unique<Dfi>(); });
  }
};
}  // namespace detail

}  // namespace cdff::dfn

/// Registers a DFI class (derived from its generated <Dfn><Dfi>Base) with the registry.
#define CDFF_REGISTER_DFI(Class)                                                            \
  static_assert(std::is_base_of_v<::cdff::dfn::Node, Class>, #Class " must be a DFN node"); \
  static const ::cdff::dfn::detail::DfiRegistrar<Class> cdff_dfi_registrar_##Class {}
