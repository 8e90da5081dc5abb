#include "mm4mm/io/input_error.hpp"

#include <utility>

namespace mm4mm {
namespace {

std::string formatMessage(const std::string& file, int line, const std::string& problem) {
  if (line > 0) return file + ":" + std::to_string(line) + ": " + problem;
  return file + ": " + problem;
}

}  // namespace

InputError::InputError(std::string file, int line, const std::string& problem)
    : std::runtime_error(formatMessage(file, line, problem)),
      file_(std::move(file)),
      line_(line),
      problem_(problem) {}

}  // namespace mm4mm
