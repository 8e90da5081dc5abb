#pragma once
// Internal to src/io: a session directory's magnetometer.csv, one sample a row after the header
// `t,sensor,bx,by,bz` (seconds, sensor index into session.yaml's magnetometers, field in µT along
// the body axes).

#include <filesystem>
#include <string>
#include <vector>

#include "mm4mm/session/session.hpp"

namespace mm4mm::io_detail {

/// Reads magnetometer.csv for a rig of `sensors` magnetometers; samples come back sorted by time,
/// ties by sensor index. Throws InputError (file, line, problem) on a missing file or header, a
/// malformed row, an unknown sensor index, a field above 1000 µT, times going backwards or a
/// sensor's sample repeated at one time.
std::vector<MagnetometerSample> readMagnetometerCsv(const std::filesystem::path& file, int sensors);

/// magnetometer.csv's text for `samples` (times to 1 µs, fields to 0.1 nT). Throws
/// std::invalid_argument ("writeSession: ...") on samples readMagnetometerCsv would reject.
std::string formatMagnetometerCsv(const std::vector<MagnetometerSample>& samples, int sensors);

}  // namespace mm4mm::io_detail
