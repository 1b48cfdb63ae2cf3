// Bitwise equality of two arrays of numbers: what the kernel tests ask of code paths that must
// give the same bits (lanes against scalar code, one layout against another, any range split).
// (== would call -0 and +0 equal and NaN unequal to itself.)
#pragma once
#include <cstring>
#include <vector>

namespace pliant::test {

template <class T>
bool same_bits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

}  // namespace pliant::test
