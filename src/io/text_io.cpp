#include "text_io.hpp"

#include <unistd.h>

#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <system_error>

#include "mm4mm/io/input_error.hpp"

namespace mm4mm::io_detail {

namespace fs = std::filesystem;

std::string formatNumber(double value) {
  std::array<char, 32> buffer{};
  const auto result = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
  return std::string(buffer.data(), result.ptr);
}

void appendFixed(double value, int precision, std::string* out) {
  std::array<char, 64> buffer{};
  const auto result = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value,
                                    std::chars_format::fixed, precision);
  out->append(buffer.data(), result.ptr);
}

std::string_view trim(std::string_view text) {
  const auto first = text.find_first_not_of(" \t\r\v\f");
  if (first == std::string_view::npos) return {};
  const auto last = text.find_last_not_of(" \t\r\v\f");
  return text.substr(first, last - first + 1);
}

double parseFiniteNumber(std::string_view token, std::string_view name, const std::string& file,
                         int line) {
  // from_chars rejects a leading '+', which some exporters write.
  if (token.size() > 1 && token.front() == '+') token.remove_prefix(1);
  double value = 0.0;
  const auto result = std::from_chars(token.data(), token.data() + token.size(), value);
  if (result.ec != std::errc() || result.ptr != token.data() + token.size())
    throw InputError(file, line,
                     std::string(name) + " '" + std::string(token) + "' is not a number");
  if (!std::isfinite(value))
    throw InputError(file, line, std::string(name) + " is not finite (" + std::string(token) + ")");
  return value;
}

std::string readWholeFile(const fs::path& file, const std::string& why_needed) {
  const bool explain = !why_needed.empty();
  if (!fs::exists(file))
    throw InputError(file.string(), 0,
                     explain ? "file not found; " + why_needed : "file not found");
  if (fs::is_directory(file))
    throw InputError(file.string(), 0, explain ? "is a directory, not a file" : "is a directory");
  std::ifstream stream(file, std::ios::binary);
  if (!stream)
    throw InputError(file.string(), 0, std::string("cannot open: ") + std::strerror(errno));
  std::ostringstream content;
  content << stream.rdbuf();
  return content.str();
}

fs::path siblingPath(const fs::path& target, const std::string& suffix) {
  fs::path sibling = target;
  sibling += suffix + std::to_string(::getpid());
  return sibling;
}

void writeTextFile(const fs::path& file, const std::string& content) {
  std::FILE* stream = std::fopen(file.c_str(), "wb");
  if (!stream) throw OutputError("cannot write " + file.string() + ": " + std::strerror(errno));
  const bool written = std::fwrite(content.data(), 1, content.size(), stream) == content.size();
  if (std::fclose(stream) != 0 || !written)
    throw OutputError("cannot write " + file.string() + ": " + std::strerror(errno));
}

void writeFileAtomically(const fs::path& file, const std::string& content) {
  AtomicTextFile out(file);
  out.write(content);
  out.commit();
}

AtomicTextFile::AtomicTextFile(const fs::path& file)
    : file_(file), temporary_(siblingPath(file, ".tmp-")) {
  stream_ = std::fopen(temporary_.c_str(), "wb");
  if (!stream_)
    throw OutputError("cannot write " + temporary_.string() + ": " + std::strerror(errno));
}

AtomicTextFile::~AtomicTextFile() {
  if (!stream_) return;
  std::fclose(stream_);
  std::error_code ignored;
  fs::remove(temporary_, ignored);
}

void AtomicTextFile::write(std::string_view text) {
  if (!stream_) throw std::logic_error("AtomicTextFile::write after commit");
  if (std::fwrite(text.data(), 1, text.size(), stream_) != text.size())
    throw OutputError("cannot write " + temporary_.string() + ": " + std::strerror(errno));
}

void AtomicTextFile::commit() {
  if (!stream_) throw std::logic_error("AtomicTextFile::commit twice");
  std::FILE* stream = stream_;
  stream_ = nullptr;
  if (std::fclose(stream) != 0) {
    const std::string reason = std::strerror(errno);
    std::error_code ignored;
    fs::remove(temporary_, ignored);
    throw OutputError("cannot write " + temporary_.string() + ": " + reason);
  }
  try {
    fs::rename(temporary_, file_);
  } catch (...) {
    std::error_code ignored;
    fs::remove(temporary_, ignored);
    throw;
  }
}

std::vector<std::string_view> splitWhitespace(std::string_view line) {
  std::vector<std::string_view> tokens;
  std::size_t pos = 0;
  while (true) {
    pos = line.find_first_not_of(" \t\r\v\f", pos);
    if (pos == std::string_view::npos) break;
    const std::size_t end = std::min(line.find_first_of(" \t\r\v\f", pos), line.size());
    tokens.push_back(line.substr(pos, end - pos));
    pos = end;
  }
  return tokens;
}

}  // namespace mm4mm::io_detail
