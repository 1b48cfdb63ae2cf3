// A half-open index range [begin, end): the unit of work every kernel takes.
#pragma once
#include <cstddef>

namespace pliant {

struct Range {
  std::size_t begin = 0;
  std::size_t end = 0;
  std::size_t size() const { return end - begin; }
};

}  // namespace pliant
