#include "mm4mm/io/resources.hpp"

#include <algorithm>
#include <array>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include "mm4mm/io/input_error.hpp"

namespace mm4mm {
namespace {

namespace fs = std::filesystem;

// PCD's header ends at its DATA line; POINTS precedes it (the format's field order).
std::uint64_t pcdPoints(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw InputError(file.string(), 0, "cannot be read");
  std::string line;
  for (int number = 1; number <= 64 && std::getline(in, line); ++number) {
    if (line.rfind("POINTS", 0) == 0) {
      std::istringstream fields(line.substr(6));
      long long points = -1;
      if (!(fields >> points) || points < 0)
        throw InputError(file.string(), number, "POINTS is not a count: '" + line + "'");
      return static_cast<std::uint64_t>(points);
    }
    if (line.rfind("DATA", 0) == 0) break;
  }
  throw InputError(file.string(), 0, "a PCD header without a POINTS line");
}

std::uint64_t linesOf(const fs::path& file) {
  std::FILE* stream = std::fopen(file.c_str(), "rb");
  if (!stream) throw InputError(file.string(), 0, "cannot be read");
  std::array<char, 1 << 16> buffer;
  std::uint64_t lines = 0;
  std::size_t read = 0;
  char last = '\n';
  while ((read = std::fread(buffer.data(), 1, buffer.size(), stream)) > 0) {
    lines += static_cast<std::uint64_t>(std::count(buffer.begin(), buffer.begin() + read, '\n'));
    last = buffer[read - 1];
  }
  std::fclose(stream);
  return lines + (last != '\n');  // a last line without its newline
}

std::optional<std::uint64_t> readNumber(const fs::path& file) {
  std::ifstream in(file);
  std::string text;
  if (!(in >> text)) return std::nullopt;
  try {
    return std::stoull(text);
  } catch (...) {
    return std::nullopt;  // "max": no limit
  }
}

}  // namespace

SessionSize countSession(const fs::path& dir) {
  SessionSize size;
  if (fs::is_directory(dir / "scans"))
    for (const auto& entry : fs::directory_iterator(dir / "scans"))
      if (entry.path().extension() == ".pcd") size.scan_points += pcdPoints(entry.path());
  if (fs::exists(dir / "magnetometer.csv")) {
    const std::uint64_t lines = linesOf(dir / "magnetometer.csv");
    size.magnetometer_rows = lines > 0 ? lines - 1 : 0;
  }
  return size;
}

std::optional<std::uint64_t> availableMemoryBytes() {
  std::optional<std::uint64_t> available;
  std::ifstream meminfo("/proc/meminfo");
  std::string key;
  std::uint64_t kib = 0;
  std::string unit;
  while (meminfo >> key >> kib >> unit)
    if (key == "MemAvailable:") {
      available = kib * 1024;
      break;
    }
  // cgroup v2: the process's group is the path after "0::" in /proc/self/cgroup.
  std::ifstream cgroup("/proc/self/cgroup");
  std::string line;
  while (std::getline(cgroup, line)) {
    if (line.rfind("0::", 0) != 0) continue;
    const fs::path group = fs::path("/sys/fs/cgroup") / fs::path(line.substr(3)).relative_path();
    const std::optional<std::uint64_t> max = readNumber(group / "memory.max");
    const std::optional<std::uint64_t> current = readNumber(group / "memory.current");
    if (max && current) {
      const std::uint64_t left = *max > *current ? *max - *current : 0;
      available = available ? std::min(*available, left) : left;
    }
  }
  return available;
}

}  // namespace mm4mm
