// The test programs' main: GoogleTest's, with the allocator set as the `cdff` command sets it
// (cdff/types/memory.hpp) so that a test runs the pipeline as the command does.
#include <gtest/gtest.h>

#include "cdff/types/memory.hpp"

int main(int argc, char** argv) {
  cdff::keepFreedBuffersForReuse();
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
