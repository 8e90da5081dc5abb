#pragma once
// Small helpers the benchmark programs share: option lists and medians.

#include <algorithm>
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

}  // namespace mm4mm::bench
