#pragma once
// The median that the robust scales and the model spacing use: the upper middle element, found
// by a partial sort of `values` in place (no copy, no average of the two middle ones).

#include <algorithm>
#include <cstddef>
#include <vector>

namespace cdff::registration {

inline double median(std::vector<float>& values) {
  if (values.empty()) return 0.0;
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

}  // namespace cdff::registration
