#pragma once
// A magnetometer log from a logger that is not ROS: a delimited text table (comma, semicolon, tab
// or blanks, found from the first line) with a header row naming its columns, or none when every
// column is given by its 0-based index.

#include <filesystem>
#include <string>

#include "mm4mm/import/recording.hpp"

namespace mm4mm {

struct MagnetometerTableOptions {
  /// Column names in the header, or 0-based indices ("0", "3").
  std::string time_column = "t";
  std::string x_column = "x";
  std::string y_column = "y";
  std::string z_column = "z";
  FieldUnit unit = FieldUnit::kMicroTesla;
  /// Seconds per unit of the time column (1e-3 for milliseconds, 1e-9 for nanoseconds).
  double seconds_per_time_unit = 1.0;
};

/// Parses "t=time,x=mx,y=my,z=mz" (any subset, in any order) into `options`; std::invalid_argument
/// on another key or a malformed pair.
void parseColumnMap(const std::string& text, MagnetometerTableOptions* options);

/// Reads the table. InputError naming the file and line on a missing column (listing the header),
/// a row with too few cells, a value that is no number, or times that go backwards.
MagnetometerRecording readMagnetometerTable(const std::filesystem::path& file,
                                            const MagnetometerTableOptions& options);

}  // namespace mm4mm
