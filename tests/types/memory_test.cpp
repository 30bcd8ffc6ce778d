// keepFreedBuffersForReuse: an image-sized block comes from the heap, and freeing it keeps it
// there for the next frame's.
#include <malloc.h>

#include <cstdlib>
#include <cstring>

#include <gtest/gtest.h>

#include "cdff/types/memory.hpp"

namespace {

TEST(KeepFreedBuffersForReuse, AnImageSizedBlockIsReusedFromTheHeap) {
#if defined(__GLIBC__)
  ASSERT_TRUE(cdff::keepFreedBuffersForReuse());
  // A 1624x1234 float image: 8 MB, far above glibc's default 128 kB mmap threshold.
  constexpr std::size_t kImageBytes = 1624 * 1234 * 4;
  const std::size_t mapped_before = mallinfo2().hblkhd;
  void* image = std::malloc(kImageBytes);
  ASSERT_NE(image, nullptr);
  std::memset(image, 1, kImageBytes);
  EXPECT_EQ(mallinfo2().hblkhd, mapped_before) << "the block got its own mapping";
  const std::size_t heap_with_image = mallinfo2().arena;
  std::free(image);
  EXPECT_GE(mallinfo2().arena, heap_with_image) << "the freed block was returned to the kernel";
#else
  GTEST_SKIP() << "not glibc's allocator";
#endif
}

}  // namespace
