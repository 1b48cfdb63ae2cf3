// The corotational elastic energy in vector lanes (element_forces.hpp): over a range and over
// listed tets, with corotational_energy_batch of element_batches.hpp, in a translation unit of
// its own (see there: the inlining budget). The same bits as element_energy_corotational_scalar
// (tests/kernels/test_kernel_batches.cpp). A change of resolution measures the body's energy
// before and after (engine/src/core/simulation.cpp): the scalar loop's rotation refinement,
// one tet at a time, made that the largest part of a change's cost after its apply.
#include "element_batches.hpp"
#include "pliant/kernels/element_forces.hpp"

namespace pliant {

template <class T>
void element_energy_corotational(const ElementContext<T>& c, Range r, double* energy) {
  constexpr int W = simd::Pack<T>::W;
  for (std::size_t t = r.begin; t < r.end; t += W)
    detail::corotational_energy_batch(c, detail::ConsecutiveTets<T>{t, int(std::min<std::size_t>(W, r.end - t))}, energy);
}

template <class T>
void element_energy_corotational_listed(const ElementContext<T>& c, const std::int32_t* tets, Range r, double* energy) {
  constexpr int W = simd::Pack<T>::W;
  for (std::size_t t = r.begin; t < r.end; t += W)
    detail::corotational_energy_batch(c, detail::ListedTets<T>(tets, t, int(std::min<std::size_t>(W, r.end - t))), energy);
}

#define PLIANT_INSTANTIATE(T)                                                                      \
  template void element_energy_corotational<T>(const ElementContext<T>&, Range, double*); \
  template void element_energy_corotational_listed<T>(const ElementContext<T>&, const std::int32_t*, Range, double*);
PLIANT_INSTANTIATE(float)
PLIANT_INSTANTIATE(double)
#undef PLIANT_INSTANTIATE

}  // namespace pliant
