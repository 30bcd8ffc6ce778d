#pragma once

namespace cdff {

/// Sets this process's allocator (glibc's malloc) to keep freed blocks of up to 32 MB in the heap
/// for reuse instead of giving each back to the kernel. A perception pipeline allocates and frees
/// the same image-sized buffers on every frame (OpenCV's scratch images, depth maps, point clouds,
/// received DDS samples); with glibc's defaults each is a fresh mmap whose pages fault in one by
/// one, which costs more than the arithmetic on them: LINEMOD training took twice as long, image
/// tracking 15-35 % longer, a DDS receiver 2.7 times the CPU (docs/dds.md). In exchange the
/// process keeps up to 256 MB of freed heap mapped. Process-wide, so programs call it (every
/// `cdff` command, the test programs, the benchmarks that stream), never the library itself.
/// Returns false where the allocator refused the settings or is not glibc's.
bool keepFreedBuffersForReuse();

}  // namespace cdff
