#pragma once
// The peak resident memory of a merge or add, estimated from the sizes of its sessions before
// any is read: a stated bound that the command line compares with the memory the system has left
// (io/resources.hpp), so that inputs too large are refused up front with the figure instead of
// the kernel killing the process part way. The model and its measurements: docs/benchmarks.md
// "Resource bounds".

#include <cstdint>
#include <string>
#include <vector>

namespace mm4mm {

/// A session's size, as io/resources.hpp counts it from a session directory without reading it.
struct SessionSize {
  std::uint64_t scan_points = 0;
  std::uint64_t magnetometer_rows = 0;
};

/// The model's terms: a fixed part, and bytes per scan point and per magnetometer row, fitted
/// above the peaks measured by scripts/memory_bound.sh (every output built, the OctoMap included).
struct MemoryModel {
  double fixed_bytes = 0.0;
  double bytes_per_scan_point = 0.0;
  double bytes_per_magnetometer_row = 0.0;
};

/// The model the command line uses.
MemoryModel defaultMemoryModel();

struct MemoryEstimate {
  std::uint64_t scan_points = 0;
  std::uint64_t magnetometer_rows = 0;
  double peak_bytes = 0.0;
};

/// The estimated peak of merging (or of an add over) sessions of these sizes, all of them held
/// at once as merge and add hold them.
MemoryEstimate estimatePeakMemory(const std::vector<SessionSize>& sessions,
                                  const MemoryModel& model = defaultMemoryModel());

/// "about 4.21 GiB (50000000 scan points, 14587 magnetometer rows)": the figure a refusal states.
std::string describe(const MemoryEstimate& estimate);

}  // namespace mm4mm
