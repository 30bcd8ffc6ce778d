#pragma once
// Shared, immutable storage for the large arrays that flow between DFNs.
//
// A Buffer never copies on assignment: copies share one allocation through a reference count,
// so passing an image or a point cloud through a port costs an atomic increment. The elements
// are const once wrapped; producers fill a std::vector (or any owner) and hand it over.

#include <cstddef>
#include <memory>
#include <span>
#include <vector>

namespace cdff {

template <typename T>
class Buffer {
 public:
  Buffer() = default;

  /// Takes ownership of a vector without copying its elements.
  static Buffer fromVector(std::vector<T>&& values) {
    auto owner = std::make_shared<std::vector<T>>(std::move(values));
    const T* data = owner->data();
    const std::size_t size = owner->size();
    return Buffer(std::shared_ptr<const T>(std::move(owner), data), size);
  }

  /// Copies `values` into a new buffer.
  static Buffer copyOf(std::span<const T> values) {
    return fromVector(std::vector<T>(values.begin(), values.end()));
  }

  /// Views memory that `owner` keeps alive (e.g. a cv::Mat or a pcl::PointCloud), no copy.
  template <typename Owner>
  static Buffer view(std::shared_ptr<Owner> owner, const T* data, std::size_t size) {
    return Buffer(std::shared_ptr<const T>(std::move(owner), data), size);
  }

  const T* data() const { return data_.get(); }
  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  const T& operator[](std::size_t i) const { return data_.get()[i]; }
  const T* begin() const { return data(); }
  const T* end() const { return data() + size_; }
  std::span<const T> span() const { return {data(), size_}; }

  /// The reference-counted owner, for views that must keep this buffer's memory alive.
  const std::shared_ptr<const T>& owner() const { return data_; }
  /// True when both buffers point at the same memory (a cheap test for "was this copied?").
  bool sharesMemoryWith(const Buffer& other) const { return data_.get() == other.data_.get(); }

 private:
  Buffer(std::shared_ptr<const T> data, std::size_t size) : data_(std::move(data)), size_(size) {}

  std::shared_ptr<const T> data_;
  std::size_t size_ = 0;
};

}  // namespace cdff
