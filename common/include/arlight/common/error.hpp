#pragma once

#include <stdexcept>
#include <string>

namespace arlight {

// Raised for bad input from outside the program (a file, a recording, a network message);
// the message names the input and what was wrong with it. Programs catch it at their edge and
// report it; it never means a bug.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace arlight
