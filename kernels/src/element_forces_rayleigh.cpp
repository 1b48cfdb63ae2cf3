// The force passes of the continuum models with Rayleigh viscosities (ElementContext::rayleigh:
// one Hooke law of eps + beta eps_dot, element_batches.hpp), over ranges and over lists, in a
// translation unit of their own so that the other passes keep their inlining (see there).
#include "element_batches.hpp"

namespace pliant::detail {

template <class Model, class T>
void rayleigh_range_pass(const ElementContext<T>& c, Range r) {
  range_pass<Model, T, Damping::rayleigh>(c, r);
}
template <class Model, class T>
void rayleigh_listed_pass(const ElementContext<T>& c, const std::int32_t* ids, Range r) {
  listed_pass<Model, T, Damping::rayleigh>(c, ids, r);
}

#define PLIANT_INSTANTIATE(Model, T)                                                      \
  template void rayleigh_range_pass<Model, T>(const ElementContext<T>&, Range);          \
  template void rayleigh_listed_pass<Model, T>(const ElementContext<T>&, const std::int32_t*, Range);
PLIANT_INSTANTIATE(Linear, float)
PLIANT_INSTANTIATE(Linear, double)
PLIANT_INSTANTIATE(Stvk, float)
PLIANT_INSTANTIATE(Stvk, double)
PLIANT_INSTANTIATE(Corotational, float)
PLIANT_INSTANTIATE(Corotational, double)
#undef PLIANT_INSTANTIATE

}  // namespace pliant::detail
