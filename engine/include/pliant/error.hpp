// Errors at the API edge. Kernels never throw; everything a user can get wrong (a file, a
// scene field, a parameter) is reported here with a message that names the file, line or field.
#pragma once
#include <stdexcept>
#include <string>

namespace pliant {

// Invalid input: malformed file or scene, impossible parameter. The command line exits with 2.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The simulation state became non-finite or exploded. The command line exits with 3.
class DivergenceError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace pliant
