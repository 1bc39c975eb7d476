// Large buffers on transparent huge pages. Filling fresh memory costs a page fault per 4 KB page;
// loading a 2 M-triangle mesh for planning spent a third of its time in those faults (perf,
// bench/README.md "Load"). madvise(MADV_HUGEPAGE) asks for 2 MB pages, one fault where there were
// 512. Advice only: where the kernel has transparent huge pages off, or the range holds no
// aligned 2 MB, nothing changes.
#pragma once

#include <sys/mman.h>

#include <cstddef>
#include <cstdint>

namespace dsmplan::detail {

/// Capacity for `n` elements, with the advice given before any of it is touched: call it before
/// the container is filled (resize(), assign() and push_back() within the capacity keep it).
template <class Container>
void reserve_on_huge_pages(Container& c, size_t n) {
  c.reserve(n);
  constexpr uintptr_t small_page = 4096, huge_page = uintptr_t(2) << 20;
  const size_t bytes = c.capacity() * sizeof(*c.data());
  if (bytes < huge_page) return;
  const auto begin = reinterpret_cast<uintptr_t>(c.data());
  const uintptr_t first = (begin + small_page - 1) & ~(small_page - 1), last = (begin + bytes) & ~(small_page - 1);
  if (last > first) ::madvise(reinterpret_cast<void*>(first), last - first, MADV_HUGEPAGE);
}

}  // namespace dsmplan::detail
