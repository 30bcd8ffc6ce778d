#pragma once
// Writes the procedural target's .cao for the ViSP test. Declared with standard types only: the
// ViSP test is compiled as C++17 (ViSP 3.5's headers do not compile as C++20) and cannot include
// the CDFF headers.

#include <cstddef>
#include <string>

namespace cdff::egse::testing {

struct CaoFixture {
  std::string error;  // empty on success
  std::size_t polygon_count = 0;
  double aft_face_x = 0;  // x of the bus's -x face (the first polygon)
};

CaoFixture writeTargetCao(const std::string& path);
/// The second procedural target's .cao (the hexagonal satellite), and the first target's with
/// model errors (1 % larger, without its antenna, with a box added, re-triangulated).
CaoFixture writeHexagonalCao(const std::string& path);
CaoFixture writePerturbedCao(const std::string& path);

}  // namespace cdff::egse::testing
