// The 12 per-tet corner-force arrays of a Level (corner c, component k: array 3c + k), in one
// allocation. The gather's fast path (kernels/src/node_passes.cpp, CornerTable) needs them equally
// spaced in memory; 12 separate vectors are that only when the heap happens to have no holes of
// their size, so the path taken (and the speed: 0.77-0.86x at 10k tets in docs/performance.md)
// depended on what the process had freed before. Here array q starts at q x stride elements, the
// stride a multiple of 16 elements (64 bytes: every array starts on a cache line).
#pragma once
#include <array>
#include <cstddef>
#include <utility>

#include "pliant/aligned.hpp"

namespace pliant {

template <class T>
class CornerForceArrays {
 public:
  static constexpr int kArrays = 12;

  // One array of the block: what a std::vector of the tets' values offers that the code uses.
  struct Span {
    T* p = nullptr;
    std::size_t n = 0;
    T& operator[](std::size_t i) const { return p[i]; }
    T* data() const { return p; }
    T* begin() const { return p; }
    T* end() const { return p + n; }
    std::size_t size() const { return n; }
    bool empty() const { return n == 0; }
  };

  CornerForceArrays() = default;
  CornerForceArrays(const CornerForceArrays& o) : block_(o.block_), n_(o.n_), stride_(o.stride_) { bind(); }
  CornerForceArrays(CornerForceArrays&& o) noexcept : block_(std::move(o.block_)), n_(o.n_), stride_(o.stride_) {
    bind();
    o.clear_spans();
  }
  CornerForceArrays& operator=(const CornerForceArrays& o) {
    if (this != &o) {
      block_ = o.block_;
      n_ = o.n_;
      stride_ = o.stride_;
      bind();
    }
    return *this;
  }
  CornerForceArrays& operator=(CornerForceArrays&& o) noexcept {
    block_ = std::move(o.block_);
    n_ = o.n_;
    stride_ = o.stride_;
    bind();
    o.clear_spans();
    return *this;
  }

  // Every array n values long, all `value` (N).
  // Regrown (a listed level's block, reused by the next prepare with a list a few tets longer), the
  // block takes an eighth more than it needs: otherwise each longer list allocated it afresh, and
  // the first touch of a new huge page (aligned.hpp) stalled a change of resolution for 6-9 ms.
  void assign(std::size_t n, T value) {
    n_ = n;
    stride_ = (n + 15) / 16 * 16;
    if (block_.capacity() > 0 && block_.capacity() < kArrays * stride_) block_.reserve(kArrays * (stride_ + stride_ / 8));
    block_.assign(kArrays * stride_, value);
    bind();
  }

  // Every array n values long, keeping the values and the stride when n fits in it (true); else
  // the block made again for n with room for an eighth more (its stride changes, every value 0:
  // false). For a listed level whose list a change of resolution edits in place: its gather's
  // entries are offsets that depend on the stride, so the stride must outlive most changes.
  bool resize_keeping_stride(std::size_t n) {
    if (n <= stride_ && !block_.empty()) {
      n_ = n;
      bind();
      return true;
    }
    n_ = n;
    stride_ = (n + n / 8 + 15) / 16 * 16;
    block_.assign(kArrays * stride_, T(0));
    bind();
    return false;
  }

  const Span& operator[](std::size_t q) const { return spans_[q]; }
  const Span* begin() const { return spans_.data(); }
  const Span* end() const { return spans_.data() + kArrays; }
  std::size_t stride() const { return stride_; }  // elements from one array to the next

 private:
  void bind() {
    for (int q = 0; q < kArrays; ++q) spans_[std::size_t(q)] = {block_.data() + std::size_t(q) * stride_, n_};
  }
  void clear_spans() {
    n_ = stride_ = 0;
    spans_.fill(Span{});
  }
  AlignedVector<T> block_;
  std::size_t n_ = 0, stride_ = 0;
  std::array<Span, kArrays> spans_{};
};

}  // namespace pliant
