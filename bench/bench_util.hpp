#pragma once
// Small helpers the benchmark programs share: option lists, medians, resident memory.

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace mm4mm::bench {

/// "a,b,c" -> {"a", "b", "c"}.
inline std::vector<std::string> splitList(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  for (std::string item; std::getline(in, item, ',');) out.push_back(item);
  return out;
}

/// The rows a CSV at `path` already holds, each as its first three fields joined by commas (a
/// benchmark's case key), so that a cut run resumes where it stopped; none when it does not exist.
inline std::set<std::string> casesDone(const std::string& path) {
  std::set<std::string> done;
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    const std::vector<std::string> fields = splitList(line);
    if (fields.size() > 3) done.insert(fields[0] + "," + fields[1] + "," + fields[2]);
  }
  return done;
}

/// The command line as (--flag, value) pairs. A flag not in `known`, or one without a value,
/// ends the program with `usage` (exit 2): `--help` or a typo must not start an hour-long run
/// with the defaults.
inline std::vector<std::pair<std::string, std::string>> parseFlags(
    int argc, char** argv, const std::vector<std::string>& known, const char* usage) {
  std::vector<std::pair<std::string, std::string>> flags;
  for (int i = 1; i < argc; i += 2) {
    const std::string flag = argv[i];
    const bool is_known = std::find(known.begin(), known.end(), flag) != known.end();
    if (!is_known || i + 1 == argc) {
      std::fprintf(stderr, "%s: %s %s\nusage: %s\n", argv[0], flag.c_str(),
                   is_known ? "needs a value" : "is not an option", usage);
      std::exit(2);
    }
    flags.emplace_back(flag, argv[i + 1]);
  }
  return flags;
}

/// The upper median (the element at size / 2 once sorted); 0 for an empty vector.
inline double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

/// Resets this process's peak resident memory (VmHWM): Linux does so when "5" is written to
/// /proc/self/clear_refs.
inline void resetPeakRss() { std::ofstream("/proc/self/clear_refs") << "5"; }

/// A memory field of /proc/self/status in MB: "VmRSS:" (now) or "VmHWM:" (peak since the last
/// reset); 0 when absent.
inline double residentMb(const std::string& field) {
  std::ifstream status("/proc/self/status");
  for (std::string line; std::getline(status, line);)
    if (line.rfind(field, 0) == 0) return std::stod(line.substr(field.size())) / 1024.0;
  return 0.0;
}

}  // namespace mm4mm::bench
