#pragma once
// Error types shared by every library and tool.
//
// InputError: the input was wrong (a file, a field, a value, a sample). Tools
// exit with status 2 and print the message; services log it, count it and go
// on with the next frame. Messages name what was wrong: file, field, value.
#include <stdexcept>
#include <string>

namespace sg {

class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A Params field out of range. Derives from InputError: a bad parameter is bad input.
class ParamError : public InputError {
 public:
  using InputError::InputError;
};

}  // namespace sg
