#pragma once
// Expected failures on bad input (the file, the line and what is wrong) and of writing output (the
// file and the system's reason: a full disk, a file size limit). Only the CLI catches them.

#include <stdexcept>
#include <string>

namespace mm4mm {

class InputError : public std::runtime_error {
 public:
  /// `line` is 1-based; 0 means the problem concerns the file as a whole.
  InputError(std::string file, int line, const std::string& problem);

  const std::string& file() const { return file_; }
  int line() const { return line_; }
  const std::string& problem() const { return problem_; }

 private:
  std::string file_;
  int line_;
  std::string problem_;
};

/// A file that could not be written: not a bug, and not bad input, but the place written to.
class OutputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace mm4mm
