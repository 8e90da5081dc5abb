#pragma once
// Internal to io/: checking a PCD header before PCL reads the file; the positions in a blob PCL
// read (PCD or PLY); writing float32 point fields as PCD with an mm4mm header comment.

#include <pcl/PCLPointCloud2.h>

#include <filesystem>
#include <initializer_list>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "mm4mm/session/session.hpp"

namespace mm4mm::io_detail {

/// What the header of a PCD file declares.
struct PcdHeader {
  std::vector<std::string> fields;
  std::optional<long long> points;  ///< POINTS, where given (PCD v0.7)
  long long width = 0;
  long long height = 1;
  /// Comment lines: 1-based line number, text after '#' with surrounding blanks trimmed.
  std::vector<std::pair<int, std::string>> comments;

  /// POINTS, or WIDTH * HEIGHT without it (readPcdHeader has bounded both by the file's size).
  long long declaredPoints() const { return points ? *points : width * height; }
};

/// Reads and checks the header of `file`, line by line, before PCL may read it: PCL 1.13 crashes
/// (SIGSEGV in PCDReader::read) on headers it does not expect (no FIELDS, as in an empty or a
/// non-PCD file; a line that is no header keyword; FIELDS, SIZE, TYPE and COUNT of different
/// lengths: found by fuzz/fuzz_pcd.cpp), and allocates a corrupt POINTS count before reading any
/// point. Throws InputError naming the file, the line and the problem.
PcdHeader readPcdHeader(const std::filesystem::path& file);

/// The file read by PCL into a blob (call readPcdHeader first); every failure of PCL's reader,
/// and data shorter than the header declares, as InputError naming the file.
pcl::PCLPointCloud2 readPcdBlob(const std::filesystem::path& file);

/// Throws InputError naming `file` and its fields unless they hold x, y and z.
void requireXyz(const std::vector<std::string>& fields, const std::filesystem::path& file);

/// The x y z of every point of `blob`, whatever numeric type they are stored in, as float;
/// non-finite points dropped. Throws InputError naming `file` when the blob has no x y z, is
/// shorter than its size says, or holds a point beyond 1e6 m (not a position in metres).
PointCloud blobPoints(const pcl::PCLPointCloud2& blob, const std::filesystem::path& file);

/// The values of the fields `names` of every point of `blob`, as double, one row per point in
/// storage order (non-finite values kept). Throws InputError naming `file` and the fields it has
/// when one is missing, or when the blob is shorter than its size says.
std::vector<std::vector<double>> blobFields(const pcl::PCLPointCloud2& blob,
                                            const std::vector<std::string>& names,
                                            const std::filesystem::path& file);

/// An unorganised cloud of float32 fields, packed in the order given.
pcl::PCLPointCloud2 floatBlob(const std::vector<std::string>& names, std::size_t points);

/// Stores one point's values, in field order.
void putFloats(pcl::PCLPointCloud2* blob, std::size_t point, std::initializer_list<float> values);

/// The PCD file's bytes (binary compressed) with `comment` after PCL's first header line.
std::string encodePcd(const pcl::PCLPointCloud2& blob, const std::string& comment,
                      const std::filesystem::path& file);

}  // namespace mm4mm::io_detail
