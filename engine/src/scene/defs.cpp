// Names of the enums in defs.hpp, as scene files and summaries spell them.
#include "pliant/defs.hpp"

namespace pliant {

const char* to_string(Precision p) { return p == Precision::float32 ? "float" : "double"; }

const char* to_string(ForceModel m) {
  switch (m) {
    case ForceModel::linear: return "linear";
    case ForceModel::stvk: return "stvk";
    case ForceModel::corotational: return "corotational";
    case ForceModel::springs: return "springs";
  }
  return "?";
}

const char* to_string(Schedule s) { return s == Schedule::naive ? "naive" : "staggered"; }

}  // namespace pliant
