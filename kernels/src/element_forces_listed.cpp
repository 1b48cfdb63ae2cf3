// The force passes over listed tets (element_forces.hpp): the batch functions of
// element_batches.hpp with ListedTets addressing, in a translation unit of their own (see there).
#include "element_batches.hpp"
#include "pliant/kernels/element_forces.hpp"

namespace pliant {
namespace {

template <class Model, class T>
void forces(const ElementContext<T>& c, const std::int32_t* tets, Range r, detail::Damping d) {
  using detail::Damping;
  switch (d) {
    case Damping::none: return detail::listed_pass<Model, T, Damping::none>(c, tets, r);
    case Damping::viscous: return detail::listed_pass<Model, T, Damping::viscous>(c, tets, r);
    case Damping::rayleigh: return detail::rayleigh_listed_pass<Model, T>(c, tets, r);
  }
}

}  // namespace

template <class T>
void element_forces_linear_listed(const ElementContext<T>& c, const std::int32_t* tets, Range r) {
  forces<detail::Linear>(c, tets, r, detail::damping_of(c));
}
template <class T>
void element_forces_stvk_listed(const ElementContext<T>& c, const std::int32_t* tets, Range r) {
  forces<detail::Stvk>(c, tets, r, detail::damping_of(c));
}
template <class T>
void element_forces_corotational_listed(const ElementContext<T>& c, const std::int32_t* tets, Range r) {
  forces<detail::Corotational>(c, tets, r, detail::damping_of(c));
}
template <class T>
void element_forces_springs_listed(const ElementContext<T>& c, const std::int32_t* tets, Range r) {
  forces<detail::Springs>(c, tets, r, c.spring_damping != T(0) ? detail::Damping::viscous : detail::Damping::none);
}

#define PLIANT_INSTANTIATE(T)                                                                                 \
  template void element_forces_linear_listed<T>(const ElementContext<T>&, const std::int32_t*, Range);       \
  template void element_forces_stvk_listed<T>(const ElementContext<T>&, const std::int32_t*, Range);         \
  template void element_forces_corotational_listed<T>(const ElementContext<T>&, const std::int32_t*, Range); \
  template void element_forces_springs_listed<T>(const ElementContext<T>&, const std::int32_t*, Range);
PLIANT_INSTANTIATE(float)
PLIANT_INSTANTIATE(double)
#undef PLIANT_INSTANTIATE

}  // namespace pliant
