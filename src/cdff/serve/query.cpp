#include "cdff/serve/query.hpp"

#include <algorithm>
#include <charconv>

#include <fmt/format.h>
#include <fmt/ranges.h>

namespace cdff::serve {

// Unknown or repeated parameters: an error naming them and the expected ones.
Status expectParameters(const Query& query, std::initializer_list<std::string_view> keys,
                        std::string_view repeatable) {
  for (auto it = query.begin(); it != query.end(); it = query.upper_bound(it->first)) {
    if (std::find(keys.begin(), keys.end(), it->first) == keys.end())
      return invalidInput(
          "query parameter '{}' is unknown here; expected {}", it->first,
          keys.size() ? fmt::format("one of {{{}}}", fmt::join(keys, ", ")) : std::string("none"));
    if (query.count(it->first) > 1 && it->first != repeatable)
      return invalidInput("query parameter '{}' is given {} times; expected it once", it->first,
                          query.count(it->first));
  }
  return Status::ok();
}

Result<std::string> requiredText(const Query& query, const std::string& key, const char* what) {
  auto it = query.find(key);
  if (it == query.end() || it->second.empty())
    return invalidInput("query parameter '{}' is missing; expected {}", key, what);
  return it->second;
}

Result<double> number(const Query& query, const std::string& key, double fallback, double lo,
                      double hi, const char* what) {
  auto it = query.find(key);
  if (it == query.end()) return fallback;
  double v = 0;
  const std::string& s = it->second;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || end != s.data() + s.size() || !(v >= lo && v <= hi))
    return invalidInput("{} = '{}': expected {} in [{}, {}]", key, s, what, lo, hi);
  return v;
}

}  // namespace cdff::serve
