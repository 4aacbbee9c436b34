// Errors that cross module boundaries. InputError is the user's fault (bad config, scene, file):
// the CLI exits 2 on it. Error is everything else that stops a cell or a command: exit 1.
#pragma once

#include <stdexcept>
#include <string>

namespace pb {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The message already names the place, as "file:line:col: key.path: what is wrong".
class InputError : public Error {
 public:
  using Error::Error;
};

}  // namespace pb
