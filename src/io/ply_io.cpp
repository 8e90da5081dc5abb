#include "mm4mm/io/ply_io.hpp"

#include <pcl/PCLPointCloud2.h>
#include <pcl/exceptions.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>

#include <algorithm>
#include <charconv>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "mm4mm/io/input_error.hpp"
#include "pcd_blob.hpp"
#include "text_io.hpp"

namespace mm4mm {
namespace {

namespace fs = std::filesystem;

bool hostIsLittleEndian() {
  const std::uint16_t probe = 1;
  std::uint8_t first = 0;
  std::memcpy(&first, &probe, 1);
  return first == 1;
}

std::optional<unsigned long long> countIn(std::string_view token) {
  unsigned long long value = 0;
  const auto result = std::from_chars(token.data(), token.data() + token.size(), value);
  if (result.ec != std::errc() || result.ptr != token.data() + token.size()) return std::nullopt;
  return value;
}

// PCL's PLY reader sizes its cloud from the header and zero-fills it before it reads a single
// value: from the vertex count, or from `obj_info num_cols` times `num_rows` where given (read
// with atoi, so -1 is 4 billion). A 200-byte file declaring 400 million vertices, or a 20000 x
// 20000 grid, costs 4.8 GB; the grid one even reads back as 400 million points at the origin.
// So the header's counts are checked against the file's size first: every item of an element
// takes at least one byte per property, every grid cell one byte of its range_grid list. The rest
// (syntax, types, values, a truncated body) is PCL's to check.
void checkDeclaredCounts(const fs::path& file) {
  const std::string name = file.string();
  if (!fs::exists(file)) throw InputError(name, 0, "file not found");
  if (fs::is_directory(file)) throw InputError(name, 0, "is a directory");
  std::ifstream stream(file, std::ios::binary);
  if (!stream) throw InputError(name, 0, "cannot be opened");
  struct Element {
    std::string name;
    unsigned long long count = 0;
    unsigned long long properties = 0;
    int line = 0;
  };
  std::vector<Element> elements;
  std::optional<unsigned long long> columns, rows;
  std::string text;
  int line = 0;
  while (true) {
    if (!std::getline(stream, text))
      throw InputError(name, line, line <= 1 ? "not a PLY file" : "header has no end_header");
    ++line;
    const std::vector<std::string_view> words = io_detail::splitWhitespace(text);
    if (line == 1 && (words.size() != 1 || words[0] != "ply"))
      throw InputError(name, 1, "not a PLY file (first line is not 'ply')");
    if (words.empty()) continue;
    if (words[0] == "end_header") break;
    const auto count = [&](std::size_t index, const char* what) {
      const std::optional<unsigned long long> value =
          words.size() > index ? countIn(words[index]) : std::nullopt;
      if (!value) throw InputError(name, line, std::string(what) + " is not a count");
      return *value;
    };
    if (words[0] == "element") {
      elements.push_back(
          {std::string(words.size() > 1 ? words[1] : ""), count(2, "element count"), 0, line});
    } else if (words[0] == "property" && !elements.empty()) {
      ++elements.back().properties;
    } else if (words[0] == "obj_info" && words.size() > 1 && words[1] == "num_cols") {
      columns = count(2, "obj_info num_cols");
    } else if (words[0] == "obj_info" && words.size() > 1 && words[1] == "num_rows") {
      rows = count(2, "obj_info num_rows");
    }
  }
  const long long header_bytes = static_cast<long long>(stream.tellg());
  const unsigned long long file_bytes = fs::file_size(file);
  const unsigned long long body_bytes =
      header_bytes < 0 || static_cast<unsigned long long>(header_bytes) > file_bytes
          ? 0
          : file_bytes - static_cast<unsigned long long>(header_bytes);
  unsigned long long remaining = body_bytes;
  for (const Element& element : elements) {
    const unsigned long long per_item = std::max<unsigned long long>(element.properties, 1);
    if (element.count > remaining / per_item)
      throw InputError(name, element.line,
                       "is truncated or corrupt: element '" + element.name + "' declares " +
                           std::to_string(element.count) + " items in " +
                           std::to_string(body_bytes) + " bytes");
    remaining -= element.count * per_item;
  }
  // PCL takes the grid only when both are given and neither is 0.
  if (columns && rows && *columns > 0 && *rows > body_bytes / *columns)
    throw InputError(name, 0,
                     "is truncated or corrupt: obj_info declares a grid of " +
                         std::to_string(*columns) + " x " + std::to_string(*rows) + " points in " +
                         std::to_string(body_bytes) + " bytes");
}

}  // namespace

void writePly(const fs::path& file, const PointCloud& points) {
  for (std::size_t i = 0; i < points.size(); ++i)
    if (!points[i].allFinite())
      throw std::invalid_argument("writePly: point " + std::to_string(i) + " is not finite");
  std::string content =
      "ply\nformat binary_little_endian 1.0\ncomment mm4mm point cloud, metres\nelement vertex " +
      std::to_string(points.size()) +
      "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
  const std::size_t header = content.size();
  content.resize(header + 12 * points.size());
  const bool swap = !hostIsLittleEndian();
  for (std::size_t i = 0; i < points.size(); ++i) {
    char* out = content.data() + header + 12 * i;
    std::memcpy(out, points[i].data(), 12);
    if (swap)
      for (int k = 0; k < 3; ++k) std::reverse(out + 4 * k, out + 4 * k + 4);
  }
  io_detail::writeFileAtomically(file, content);
}

PointCloud readPly(const fs::path& file) {
  checkDeclaredCounts(file);
  const std::string name = file.string();
  pcl::PCLPointCloud2 blob;
  Eigen::Vector4f origin;
  Eigen::Quaternionf orientation;
  int version = 0;
  int status = -1;
  // PCL reports what it refuses with a negative status (and a console message); exceptions
  // escape from the allocations and conversions it does not guard.
  try {
    status = pcl::PLYReader().read(name, blob, origin, orientation, version, 0);
  } catch (const pcl::PCLException& e) {
    throw InputError(name, 0, std::string("not a readable PLY file: ") + e.detailedMessage());
  } catch (const std::exception& e) {
    throw InputError(name, 0, std::string("not a readable PLY file: ") + e.what());
  }
  // Past checkDeclaredCounts, PCL fails on a header it does not parse or a body that ends before
  // the values the header declares.
  if (status < 0)
    throw InputError(name, 0,
                     "is truncated or malformed: PCL's PLY reader cannot read it (its console "
                     "message names the line)");
  return io_detail::blobPoints(blob, file);
}

void writeMergedCloudPcd(const fs::path& file, const MergedCloud& cloud) {
  const std::size_t n = cloud.points.size();
  if (cloud.covariances.size() != n || cloud.session.size() != n ||
      cloud.session_count.size() != n || cloud.return_count.size() != n)
    throw std::invalid_argument(
        "writeMergedCloudPcd: the cloud's per-point vectors differ in "
        "length (" +
        std::to_string(n) + " points)");
  pcl::PCLPointCloud2 blob =
      io_detail::floatBlob({"x", "y", "z", "variance", "session", "sessions", "returns"}, n);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3f& p = cloud.points[i];
    if (!p.allFinite() || !cloud.covariances[i].allFinite())
      throw std::invalid_argument("writeMergedCloudPcd: point " + std::to_string(i) +
                                  " is not finite");
    io_detail::putFloats(
        &blob, i,
        {p.x(), p.y(), p.z(), cloud.covariances[i].trace() / 3.0f,
         static_cast<float>(cloud.session[i]), static_cast<float>(cloud.session_count[i]),
         static_cast<float>(cloud.return_count[i])});
  }
  // Uncompressed binary: LZF in PCL's writer would take seconds for millions of points.
  std::string content = pcl::PCDWriter().generateHeaderBinary(blob, Eigen::Vector4f::Zero(),
                                                              Eigen::Quaternionf::Identity());
  content.insert(content.find('\n') + 1, "# mm4mm_merged_cloud points=" + std::to_string(n) + "\n");
  content += "DATA binary\n";
  content.append(reinterpret_cast<const char*>(blob.data.data()), blob.data.size());
  io_detail::writeFileAtomically(file, content);
}

}  // namespace mm4mm
