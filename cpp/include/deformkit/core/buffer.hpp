#pragma once
// Large scratch and result arrays: left uninitialised (the code that fills them is the first to
// touch them) and backed by transparent huge pages where the kernel allows it, because faulting in
// tens of megabytes 4 KiB at a time costs as much as binding the points.
#include <sys/mman.h>

#include <cstddef>
#include <cstdlib>
#include <new>
#include <vector>

namespace deformkit {

template <class T>
struct BufferAllocator {
  using value_type = T;
  static constexpr std::size_t kHugePage = std::size_t(2) << 20;

  BufferAllocator() = default;
  template <class U>
  BufferAllocator(const BufferAllocator<U>&) {}

  T* allocate(std::size_t n) {
    const std::size_t bytes = n * sizeof(T);
    if (bytes < 2 * kHugePage) {
      if (void* p = std::malloc(bytes ? bytes : 1)) return static_cast<T*>(p);
      throw std::bad_alloc();
    }
    void* p = std::aligned_alloc(kHugePage, (bytes + kHugePage - 1) / kHugePage * kHugePage);
    if (!p) throw std::bad_alloc();
    madvise(p, bytes, MADV_HUGEPAGE);  // advice only: failure leaves ordinary pages
    return static_cast<T*>(p);
  }
  void deallocate(T* p, std::size_t) { std::free(p); }

  // Value-initialise only when asked for a value: resize(n) leaves the elements uninitialised.
  template <class U>
  void construct(U* p) noexcept {
    ::new (static_cast<void*>(p)) U;
  }
  template <class U, class... A>
  void construct(U* p, A&&... a) {
    ::new (static_cast<void*>(p)) U(std::forward<A>(a)...);
  }
  template <class U>
  bool operator==(const BufferAllocator<U>&) const { return true; }
  template <class U>
  bool operator!=(const BufferAllocator<U>&) const { return false; }
};

template <class T>
using Buffer = std::vector<T, BufferAllocator<T>>;

}  // namespace deformkit
