#include "memory.hpp"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace cdff {

bool keepFreedBuffersForReuse() {
#if defined(__GLIBC__)
  // Blocks below the mmap threshold come from the heap; 32 MB is glibc's largest accepted value
  // on 64-bit systems and holds a 1624x1234 float image with room to spare. The trim threshold
  // keeps that much freed memory at the heap's top instead of returning it.
  constexpr int kMmapThreshold = 32 * 1024 * 1024;
  constexpr int kTrimThreshold = 256 * 1024 * 1024;
  return mallopt(M_MMAP_THRESHOLD, kMmapThreshold) == 1 &&
         mallopt(M_TRIM_THRESHOLD, kTrimThreshold) == 1;
#else
  return false;
#endif
}

}  // namespace cdff
