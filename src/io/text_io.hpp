#pragma once
// Internal to src/io: the text helpers the file-format readers and writers share (number
// formatting and parsing, whole-file reads, line iteration, file writes). Not installed.

#include <algorithm>
#include <cstddef>
#include <cstdio>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace mm4mm::io_detail {

/// Shortest text that reads back to exactly `value`.
std::string formatNumber(double value);

/// Appends `value` with `precision` digits after the point.
void appendFixed(double value, int precision, std::string* out);

/// `text` without leading and trailing blanks (space, tab, CR, VT, FF).
std::string_view trim(std::string_view text);

/// Parses `token` as a whole, finite number (a leading '+' allowed). Throws InputError(file,
/// line, ...) naming the value as `name` otherwise.
double parseFiniteNumber(std::string_view token, std::string_view name, const std::string& file,
                         int line);

/// Reads `file` whole. Throws InputError(file, 0, ...) when it is missing, a directory or cannot
/// be opened. A non-empty `why_needed` is appended to the "file not found" message to tell what
/// the file is for; such files also get the longer "is a directory, not a file".
std::string readWholeFile(const std::filesystem::path& file, const std::string& why_needed = {});

/// Calls `visit(line_number, trimmed_text)` for every line of `content`, numbering from 1.
template <typename Visitor>
void forEachLine(const std::string& content, Visitor&& visit) {
  std::size_t begin = 0;
  for (int line = 1; begin < content.size(); ++line) {
    const std::size_t end = std::min(content.find('\n', begin), content.size());
    visit(line, trim(std::string_view(content).substr(begin, end - begin)));
    begin = end + 1;
  }
}

/// `target` with `suffix` and this process's id appended: a scratch name next to `target`.
std::filesystem::path siblingPath(const std::filesystem::path& target, const std::string& suffix);

/// Writes `content` to `file`, replacing it. Throws std::runtime_error when that fails.
void writeTextFile(const std::filesystem::path& file, const std::string& content);

/// Writes `content` under a sibling temporary name and renames it to `file`, so `file` is never
/// half-written. Throws std::runtime_error or std::filesystem::filesystem_error on failure.
void writeFileAtomically(const std::filesystem::path& file, const std::string& content);

/// A file written piece by piece under a sibling temporary name and renamed to `file` by commit(),
/// so `file` is never half-written and a large text need not be held whole. Destroyed without
/// commit() (a failure part way), it removes the temporary. Throws OutputError naming the
/// temporary when it cannot be created or written, as writeFileAtomically does.
class AtomicTextFile {
 public:
  explicit AtomicTextFile(const std::filesystem::path& file);
  ~AtomicTextFile();
  AtomicTextFile(const AtomicTextFile&) = delete;
  AtomicTextFile& operator=(const AtomicTextFile&) = delete;

  void write(std::string_view text);
  void commit();

 private:
  std::filesystem::path file_;
  std::filesystem::path temporary_;
  std::FILE* stream_ = nullptr;
};

/// The whitespace-separated tokens of a line.
std::vector<std::string_view> splitWhitespace(std::string_view line);

}  // namespace mm4mm::io_detail
