#pragma once
// Small helpers the benchmark programs share: option lists, medians, resident memory.

#include <algorithm>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace mm4mm::bench {

/// "a,b,c" -> {"a", "b", "c"}.
inline std::vector<std::string> splitList(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  for (std::string item; std::getline(in, item, ',');) out.push_back(item);
  return out;
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
