#include "mm4mm/io/ply_io.hpp"

#include <pcl/io/pcd_io.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "mm4mm/io/input_error.hpp"
#include "pcd_blob.hpp"
#include "text_io.hpp"

namespace mm4mm {
namespace {

namespace fs = std::filesystem;

constexpr double kMaxCoordinate_m = 1e6;

enum class Format { kAscii, kBinaryLittleEndian, kBinaryBigEndian };

enum class Scalar { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

std::optional<Scalar> scalarNamed(std::string_view name) {
  static const std::array<std::pair<std::string_view, Scalar>, 16> kNames{{
      {"char", Scalar::kInt8},
      {"int8", Scalar::kInt8},
      {"uchar", Scalar::kUint8},
      {"uint8", Scalar::kUint8},
      {"short", Scalar::kInt16},
      {"int16", Scalar::kInt16},
      {"ushort", Scalar::kUint16},
      {"uint16", Scalar::kUint16},
      {"int", Scalar::kInt32},
      {"int32", Scalar::kInt32},
      {"uint", Scalar::kUint32},
      {"uint32", Scalar::kUint32},
      {"float", Scalar::kFloat32},
      {"float32", Scalar::kFloat32},
      {"double", Scalar::kFloat64},
      {"float64", Scalar::kFloat64},
  }};
  for (const auto& [n, s] : kNames)
    if (n == name) return s;
  return std::nullopt;
}

std::size_t sizeOf(Scalar s) {
  switch (s) {
    case Scalar::kInt8:
    case Scalar::kUint8:
      return 1;
    case Scalar::kInt16:
    case Scalar::kUint16:
      return 2;
    case Scalar::kInt32:
    case Scalar::kUint32:
    case Scalar::kFloat32:
      return 4;
    case Scalar::kFloat64:
      return 8;
  }
  return 1;
}

struct Property {
  std::string name;
  Scalar type = Scalar::kFloat32;
  bool is_list = false;
  Scalar count_type = Scalar::kUint8;  // lists only
};

struct Element {
  std::string name;
  std::size_t count = 0;
  std::vector<Property> properties;
  int line = 0;
};

struct Header {
  Format format = Format::kAscii;
  std::vector<Element> elements;
  std::size_t body_offset = 0;
};

bool hostIsLittleEndian() {
  const std::uint16_t probe = 1;
  std::uint8_t first = 0;
  std::memcpy(&first, &probe, 1);
  return first == 1;
}

// ---------------------------------------------------------------------------------------------
// Header

Header parseHeader(const std::string& content, const std::string& name) {
  Header header;
  std::size_t pos = 0;
  bool format_seen = false;
  for (int line = 1;; ++line) {
    const std::size_t end = content.find('\n', pos);
    if (end == std::string::npos)
      throw InputError(name, line, line == 1 ? "not a PLY file" : "header has no end_header");
    const std::string_view text = io_detail::trim(std::string_view(content).substr(pos, end - pos));
    pos = end + 1;
    const auto words = io_detail::splitWhitespace(text);
    if (line == 1) {
      if (text != "ply") throw InputError(name, 1, "not a PLY file (first line is not 'ply')");
      continue;
    }
    if (words.empty() || words[0] == "comment" || words[0] == "obj_info") continue;
    if (words[0] == "end_header") {
      if (!format_seen) throw InputError(name, line, "header has no format line");
      header.body_offset = pos;
      return header;
    }
    if (words[0] == "format") {
      if (words.size() < 2) throw InputError(name, line, "format line without a format");
      if (words[1] == "ascii")
        header.format = Format::kAscii;
      else if (words[1] == "binary_little_endian")
        header.format = Format::kBinaryLittleEndian;
      else if (words[1] == "binary_big_endian")
        header.format = Format::kBinaryBigEndian;
      else
        throw InputError(name, line, "unknown format '" + std::string(words[1]) + "'");
      format_seen = true;
    } else if (words[0] == "element") {
      if (words.size() != 3) throw InputError(name, line, "element line needs a name and a count");
      Element element;
      element.name = std::string(words[1]);
      element.count = static_cast<std::size_t>(
          io_detail::parseFiniteNumber(words[2], "element count", name, line));
      element.line = line;
      header.elements.push_back(element);
    } else if (words[0] == "property") {
      if (header.elements.empty()) throw InputError(name, line, "property before any element");
      Property property;
      std::optional<Scalar> type;
      if (words.size() == 5 && words[1] == "list") {
        property.is_list = true;
        const auto count_type = scalarNamed(words[2]);
        type = scalarNamed(words[3]);
        if (!count_type || !type) throw InputError(name, line, "unknown type in list property");
        property.count_type = *count_type;
        property.name = std::string(words[4]);
      } else if (words.size() == 3) {
        type = scalarNamed(words[1]);
        if (!type) throw InputError(name, line, "unknown type '" + std::string(words[1]) + "'");
        property.name = std::string(words[2]);
      } else {
        throw InputError(name, line, "malformed property line");
      }
      property.type = *type;
      header.elements.back().properties.push_back(property);
    } else {
      throw InputError(name, line, "unknown header keyword '" + std::string(words[0]) + "'");
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Body

// Reads values one after another from the body, in the file's encoding.
class BodyReader {
 public:
  BodyReader(const std::string& content, const Header& header, std::string name)
      : content_(content),
        pos_(header.body_offset),
        format_(header.format),
        name_(std::move(name)) {
    swap_ = (format_ == Format::kBinaryBigEndian) == hostIsLittleEndian();
  }

  double read(Scalar type) { return format_ == Format::kAscii ? readText() : readBinary(type); }

 private:
  template <typename T>
  double load() {
    if (content_.size() - pos_ < sizeof(T))
      throw InputError(name_, 0, "is truncated (body ends inside a value)");
    std::array<char, sizeof(T)> bytes;
    std::memcpy(bytes.data(), content_.data() + pos_, sizeof(T));
    if (swap_) std::reverse(bytes.begin(), bytes.end());
    pos_ += sizeof(T);
    T value;
    std::memcpy(&value, bytes.data(), sizeof(T));
    return static_cast<double>(value);
  }

  double readBinary(Scalar type) {
    switch (type) {
      case Scalar::kInt8:
        return load<std::int8_t>();
      case Scalar::kUint8:
        return load<std::uint8_t>();
      case Scalar::kInt16:
        return load<std::int16_t>();
      case Scalar::kUint16:
        return load<std::uint16_t>();
      case Scalar::kInt32:
        return load<std::int32_t>();
      case Scalar::kUint32:
        return load<std::uint32_t>();
      case Scalar::kFloat32:
        return load<float>();
      case Scalar::kFloat64:
        return load<double>();
    }
    return 0.0;
  }

  double readText() {
    const std::size_t begin = content_.find_first_not_of(" \t\r\n\v\f", pos_);
    if (begin == std::string::npos)
      throw InputError(name_, 0, "is truncated (fewer values than the header declares)");
    std::size_t end = content_.find_first_of(" \t\r\n\v\f", begin);
    if (end == std::string::npos) end = content_.size();
    pos_ = end;
    const std::string_view token(content_.data() + begin, end - begin);
    // Non-finite values (nan) are allowed here and dropped by the caller, as PCD readers do.
    if (token == "nan" || token == "NaN" || token == "-nan") return std::nan("");
    return io_detail::parseFiniteNumber(token, "value", name_, 0);
  }

  const std::string& content_;
  std::size_t pos_;
  Format format_;
  std::string name_;
  bool swap_ = false;
};

// Smallest size (bytes) of one item of `element`: a binary file shorter than count times this
// is truncated, which is checked before anything is allocated for a corrupt count.
std::size_t minimumItemBytes(const Element& element, Format format) {
  std::size_t bytes = 0;
  for (const Property& p : element.properties)
    bytes += format == Format::kAscii ? 2 : sizeOf(p.is_list ? p.count_type : p.type);
  return std::max<std::size_t>(bytes, 1);
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
  const std::string name = file.string();
  const std::string content = io_detail::readWholeFile(file);
  const Header header = parseHeader(content, name);
  BodyReader reader(content, header, name);
  std::size_t remaining = content.size() - header.body_offset;
  for (const Element& element : header.elements) {
    const std::size_t min_bytes = minimumItemBytes(element, header.format);
    if (element.count > remaining / min_bytes)
      throw InputError(name, element.line,
                       "is truncated or corrupt: element '" + element.name + "' declares " +
                           std::to_string(element.count) + " items in " +
                           std::to_string(remaining) + " bytes");
    remaining -= element.count * min_bytes;
  }

  const auto vertex = std::find_if(header.elements.begin(), header.elements.end(),
                                   [](const Element& e) { return e.name == "vertex"; });
  if (vertex == header.elements.end()) throw InputError(name, 0, "has no vertex element");
  std::array<int, 3> xyz{-1, -1, -1};
  for (std::size_t p = 0; p < vertex->properties.size(); ++p) {
    const Property& property = vertex->properties[p];
    for (int a = 0; a < 3; ++a)
      if (!property.is_list && property.name == std::string(1, static_cast<char>('x' + a)))
        xyz[a] = static_cast<int>(p);
  }
  if (std::find(xyz.begin(), xyz.end(), -1) != xyz.end())
    throw InputError(name, vertex->line, "vertex element has no x y z properties");

  PointCloud points;
  for (const Element& element : header.elements) {
    const bool is_vertex = &element == &*vertex;
    if (is_vertex) points.reserve(element.count);
    std::vector<double> values(element.properties.size());
    for (std::size_t item = 0; item < element.count; ++item) {
      for (std::size_t p = 0; p < element.properties.size(); ++p) {
        const Property& property = element.properties[p];
        if (!property.is_list) {
          values[p] = reader.read(property.type);
          continue;
        }
        const double count = reader.read(property.count_type);
        if (!(count >= 0.0) || count > static_cast<double>(content.size()))
          throw InputError(name, element.line,
                           "list property '" + property.name + "' has an invalid length");
        for (std::size_t k = 0; k < static_cast<std::size_t>(count); ++k)
          reader.read(property.type);
      }
      if (!is_vertex) continue;
      const Eigen::Vector3d p(values[xyz[0]], values[xyz[1]], values[xyz[2]]);
      if (!p.allFinite()) continue;
      if (p.cwiseAbs().maxCoeff() > kMaxCoordinate_m)
        throw InputError(name, 0,
                         "vertex " + std::to_string(item) +
                             " lies beyond 1e6 m; not a plausible point in metres");
      points.push_back(p.cast<float>());
    }
    if (is_vertex) break;  // later elements (faces) are not needed
  }
  return points;
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
