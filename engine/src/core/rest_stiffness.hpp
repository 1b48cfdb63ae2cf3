// The stiffness matrix of a level at rest, applied without being assembled: K u from the level's
// own element kernel (the linear one for linear, stvk and corotational, which share their
// linearisation at rest; the springs' exact linearisation for springs) and the gather. Used by
// the stable step (Lanczos on M^-1 K) and by the multiresolution stiffness calibration (CG on
// K u = f). Setup code, not the hot path: it allocates its scratch once.
#pragma once
#include <vector>

#include "simulation.hpp"

namespace pliant::detail {

template <class T>
class RestStiffness {
 public:
  RestStiffness(Executor& exec, Level<T>& level);
  ~RestStiffness();  // leaves the level's corner forces as a fresh level has them (zero)
  // w = K u for u, w interleaved per node (3 n values), in double. Undamped.
  void apply(const std::vector<double>& u, std::vector<double>& w);

 private:
  void forces(std::vector<double>* out);
  Executor& exec_;
  Level<T>& L_;
  ElementContext<T> ec_;
  GatherContext<T> gc_;
  AlignedVector<T> x_[3], f_[3];
  std::vector<double> f0_[3], fa_[3];
  bool springs_;
};

}  // namespace pliant::detail
