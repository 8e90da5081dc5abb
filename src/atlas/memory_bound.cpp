#include "mm4mm/atlas/memory_bound.hpp"

#include <cstdio>

namespace mm4mm {

MemoryModel defaultMemoryModel() {
  // Fitted on the peaks of three merges of two large-warehouse sessions (scripts/memory_bound.sh,
  // 12-24 M scan points, 15-100 k magnetometer rows, every output): about 470 MB fixed, 69 bytes
  // per scan point (the scans as read, their voxel maps and covariances, the merged cloud, the
  // OctoMap's grid) and 765 per magnetometer row (the readings, fingerprints and maps of an array's
  // seven sensors), each rounded up. An add of the same 24 M points peaked 0.27-0.35 GiB above
  // their merge (2.27-2.33 GiB over two runs), 2 % under an 80-byte point term and 8 % under a
  // 90-byte one; peaks vary by a few per cent between runs, so 100, which leaves the add 15 %
  // under its estimate and every merge more. The row term was checked at 0.4 and 1.5 M rows of
  // one sensor (a session logged at 1 and 4 kHz): about 670 bytes a row between them, once the
  // session graphs were built one at a time with their arrays reserved (before, about 2.5 KB a
  // row).
  MemoryModel model;
  model.fixed_bytes = 512.0 * 1024 * 1024;
  model.bytes_per_scan_point = 100.0;
  model.bytes_per_magnetometer_row = 1000.0;
  return model;
}

MemoryEstimate estimatePeakMemory(const std::vector<SessionSize>& sessions,
                                  const MemoryModel& model) {
  MemoryEstimate estimate;
  for (const SessionSize& s : sessions) {
    estimate.scan_points += s.scan_points;
    estimate.magnetometer_rows += s.magnetometer_rows;
  }
  estimate.peak_bytes =
      model.fixed_bytes + model.bytes_per_scan_point * static_cast<double>(estimate.scan_points) +
      model.bytes_per_magnetometer_row * static_cast<double>(estimate.magnetometer_rows);
  return estimate;
}

std::string describe(const MemoryEstimate& estimate) {
  char text[160];
  std::snprintf(text, sizeof(text), "about %.2f GiB (%llu scan points, %llu magnetometer rows)",
                estimate.peak_bytes / (1024.0 * 1024 * 1024),
                static_cast<unsigned long long>(estimate.scan_points),
                static_cast<unsigned long long>(estimate.magnetometer_rows));
  return text;
}

}  // namespace mm4mm
