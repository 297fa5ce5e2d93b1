// Internal: loops the common library spreads over cores. oneTBB natively; a plain loop in the
// WebAssembly build (ARLIGHT_NO_TBB: the page has one thread, and the client only needs these
// for small maps).
#pragma once

#if ARLIGHT_NO_TBB
namespace arlight::detail {
template <class Index, class F>
void parallel_for(Index begin, Index end, const F& f) {
  for (Index i = begin; i < end; ++i) f(i);
}
}  // namespace arlight::detail
#else
#include <tbb/parallel_for.h>
namespace arlight::detail {
using tbb::parallel_for;
}  // namespace arlight::detail
#endif
