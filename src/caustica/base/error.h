// Errors for people: one line naming what was wrong and what was expected.
#pragma once
#include <stdexcept>
#include <string>

namespace caustica {

// Bad user input (scene file, option, value). Front ends print the message
// alone and exit with status 2.
struct InputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace caustica
