#include "pcd_blob.hpp"

#include <pcl/common/io.h>
#include <pcl/exceptions.h>
#include <pcl/io/pcd_io.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "mm4mm/io/input_error.hpp"

namespace mm4mm::io_detail {

namespace fs = std::filesystem;

namespace {

constexpr double kMaxCoordinate_m = 1e6;

const pcl::PCLPointField* findField(const pcl::PCLPointCloud2& blob, const std::string& name) {
  for (const auto& field : blob.fields) {
    if (field.name == name && field.count >= 1) return &field;
  }
  return nullptr;
}

template <typename T>
double load(const std::uint8_t* bytes) {
  T value;
  std::memcpy(&value, bytes, sizeof(T));
  return static_cast<double>(value);
}

// PCD and PLY allow any numeric type for a field; real exporters use float or double for x y z.
double loadAs(std::uint8_t datatype, const std::uint8_t* bytes) {
  using Types = pcl::PCLPointField::PointFieldTypes;
  switch (datatype) {
    case Types::INT8:
      return load<std::int8_t>(bytes);
    case Types::UINT8:
      return load<std::uint8_t>(bytes);
    case Types::INT16:
      return load<std::int16_t>(bytes);
    case Types::UINT16:
      return load<std::uint16_t>(bytes);
    case Types::INT32:
      return load<std::int32_t>(bytes);
    case Types::UINT32:
      return load<std::uint32_t>(bytes);
    case Types::INT64:
      return load<std::int64_t>(bytes);
    case Types::UINT64:
      return load<std::uint64_t>(bytes);
    case Types::FLOAT32:
      return load<float>(bytes);
    case Types::FLOAT64:
      return load<double>(bytes);
    default:
      return std::nan("");
  }
}

// PCL allocates the declared number of points before it reads any, so a corrupt count (a
// billion points in a 1 kB file) would exhaust memory. LZF expands at most about 100-fold; in the
// other encodings every point takes at least one byte.
void checkDeclaredSize(const PcdHeader& header, const std::string& type, std::uintmax_t body_bytes,
                       const fs::path& file, int data_line) {
  // In double: a corrupt WIDTH times HEIGHT may not fit in an integer.
  const double declared = std::max(static_cast<double>(header.points.value_or(0)),
                                   static_cast<double>(header.width) * header.height);
  const double max_points =
      static_cast<double>(body_bytes) * (type == "binary_compressed" ? 100 : 1);
  if (declared <= max_points) return;
  std::array<char, 64> count{};
  std::snprintf(count.data(), count.size(), "%.0f", declared);
  throw InputError(file.string(), data_line,
                   "is truncated or corrupt: declares " + std::string(count.data()) +
                       " points in " + std::to_string(body_bytes) + " bytes of data");
}

}  // namespace

PcdHeader readPcdHeader(const fs::path& file) {
  constexpr int kMaxHeaderLines = 1000;
  std::ifstream stream(file, std::ios::binary);
  if (!stream) throw InputError(file.string(), 0, "cannot be opened");
  PcdHeader header;
  std::vector<std::string> sizes, types, counts;
  bool has_size = false, has_type = false;
  const auto fail = [&](int line, const std::string& problem) {
    throw InputError(file.string(), line, "not a PCD file: " + problem);
  };
  // One whole non-negative integer and nothing else ("WIDTH 4POINTS 4" is no width).
  const auto count = [&](std::istringstream& in, int line, const char* keyword) {
    std::string token, rest;
    in >> token >> rest;
    if (token.empty() || token.size() > 15 || !rest.empty() ||
        !std::all_of(token.begin(), token.end(), [](unsigned char c) { return std::isdigit(c); }))
      fail(line, std::string(keyword) + " is not a count");
    return std::stoll(token);
  };
  const auto words = [](std::istringstream& in) {
    std::vector<std::string> all;
    for (std::string word; in >> word;) all.push_back(word);
    return all;
  };
  std::string line;
  for (int i = 1; i <= kMaxHeaderLines && std::getline(stream, line); ++i) {
    if (line.empty()) continue;
    // PCL splits header lines at ' ', '\t' and '\r' only, where this parser splits at every blank:
    // "DATA\fbinary" is two words here and one to PCL, whose parser then reads past the end of
    // its word list and throws std::out_of_range (found by fuzz/fuzz_pcd.cpp).
    if (std::any_of(line.begin(), line.end(),
                    [](unsigned char c) { return c != '\t' && c != '\r' && std::iscntrl(c); }))
      fail(i, "a header line holds a control character");
    // PCL splits a line at blanks and takes its first word, empty for a line that starts with a
    // blank: its header ends there, before the fields (a crash, found by fuzz/fuzz_pcd.cpp).
    if (line[0] == ' ' || line[0] == '\t' || line[0] == '\r')
      fail(i, "a header line starts with a blank");
    std::istringstream in(line);
    std::string keyword;
    in >> keyword;
    if (keyword[0] == '#') {
      const std::size_t text = line.find_first_not_of(" \t", line.find('#') + 1);
      std::string comment = text == std::string::npos ? std::string() : line.substr(text);
      comment.erase(comment.find_last_not_of(" \t\r") + 1);
      header.comments.emplace_back(i, comment);
      continue;
    }
    if (keyword == "VERSION" || keyword == "VIEWPOINT") {
      continue;
    } else if (keyword == "FIELDS" || keyword == "COLUMNS") {
      header.fields = words(in);
    } else if (keyword == "SIZE") {
      sizes = words(in), has_size = true;
      for (const std::string& size : sizes)
        if (size != "1" && size != "2" && size != "4" && size != "8")
          fail(i, "SIZE '" + size + "' is not 1, 2, 4 or 8");
    } else if (keyword == "TYPE") {
      types = words(in), has_type = true;
      for (const std::string& type : types)
        if (type != "I" && type != "U" && type != "F")
          fail(i, "TYPE '" + type + "' is not I, U or F");
    } else if (keyword == "COUNT") {
      counts = words(in);
      for (const std::string& count : counts)
        if (count.empty() || count.size() > 6 ||
            !std::all_of(count.begin(), count.end(),
                         [](unsigned char c) { return std::isdigit(c); }) ||
            std::stoi(count) < 1)
          fail(i, "COUNT '" + count + "' is not a positive integer");
    } else if (keyword == "POINTS") {
      header.points = count(in, i, "POINTS");
    } else if (keyword == "WIDTH") {
      header.width = count(in, i, "WIDTH");
    } else if (keyword == "HEIGHT") {
      header.height = count(in, i, "HEIGHT");
    } else if (keyword == "DATA") {
      std::string type;
      in >> type;
      if (header.fields.empty()) fail(i, "no FIELDS in its header");
      if (!has_size || !has_type) fail(i, "no SIZE or TYPE in its header");
      if (sizes.size() != header.fields.size() || types.size() != header.fields.size() ||
          (!counts.empty() && counts.size() != header.fields.size()))
        fail(i, std::to_string(header.fields.size()) + " FIELDS but " +
                    std::to_string(sizes.size()) + " SIZE, " + std::to_string(types.size()) +
                    " TYPE" +
                    (counts.empty() ? "" : ", " + std::to_string(counts.size()) + " COUNT"));
      if (type != "ascii" && type != "binary" && type != "binary_compressed")
        fail(i, "unknown DATA type '" + type + "'");
      const auto header_bytes = static_cast<std::uintmax_t>(stream.tellg());
      const std::uintmax_t file_bytes = fs::file_size(file);
      checkDeclaredSize(header, type, file_bytes - std::min(header_bytes, file_bytes), file, i);
      // PCL's header parser does not stop at DATA: it goes on reading lines, skipping empty ones
      // and comments, and takes the first other line whose first word starts with a keyword for
      // one more header line. Point data whose bytes spell one ("COUNT", "SIZE", ...) crashes it
      // (found by fuzz/fuzz_pcd.cpp); refused here.
      int data_line = i;
      for (std::string next; std::getline(stream, next);) {
        ++data_line;
        if (next.empty()) continue;
        if (next[0] == ' ' || next[0] == '\t' || next[0] == '\r') break;  // PCL stops there
        std::istringstream next_words(next);
        std::string first;
        next_words >> first;
        if (first[0] == '#') continue;
        for (const char* keyword : {"VERSION", "FIELDS", "COLUMNS", "SIZE", "TYPE", "COUNT",
                                    "WIDTH", "HEIGHT", "VIEWPOINT", "POINTS", "DATA"})
          if (first.compare(0, std::strlen(keyword), keyword) == 0)
            fail(data_line, "its data starts with '" + std::string(keyword) +
                                "', which PCL's reader would take for a header line");
        break;
      }
      return header;
    } else {
      fail(i, "'" + keyword.substr(0, 40) + "' is not a PCD header keyword");
    }
  }
  fail(0, "no DATA line in its header");
  return header;  // not reached
}

void requireXyz(const std::vector<std::string>& fields, const fs::path& file) {
  const auto has = [&](const char* name) {
    return std::find(fields.begin(), fields.end(), name) != fields.end();
  };
  if (has("x") && has("y") && has("z")) return;
  std::string names;
  for (const std::string& name : fields) names += (names.empty() ? "" : " ") + name;
  throw InputError(file.string(), 0, "has no x y z fields (fields: " + names + ")");
}

PointCloud blobPoints(const pcl::PCLPointCloud2& blob, const fs::path& file) {
  std::array<const pcl::PCLPointField*, 3> xyz = {findField(blob, "x"), findField(blob, "y"),
                                                  findField(blob, "z")};
  if (!xyz[0] || !xyz[1] || !xyz[2]) {
    std::vector<std::string> names;
    for (const auto& field : blob.fields) names.push_back(field.name);
    requireXyz(names, file);
  }
  const std::size_t needed = blob.height == 0 ? 0 : std::size_t{blob.row_step} * blob.height;
  if (blob.data.size() < needed) throw InputError(file.string(), 0, "is truncated");
  for (const auto* field : xyz) {
    if (field->offset + static_cast<std::uint32_t>(pcl::getFieldSize(field->datatype)) >
        blob.point_step)
      throw InputError(file.string(), 0, "has a field '" + field->name + "' beyond its point size");
  }
  PointCloud points;
  points.reserve(static_cast<std::size_t>(blob.width) * blob.height);
  for (std::uint32_t row = 0; row < blob.height; ++row) {
    for (std::uint32_t col = 0; col < blob.width; ++col) {
      const std::size_t base =
          row * std::size_t{blob.row_step} + col * std::size_t{blob.point_step};
      Eigen::Vector3d p;
      for (int k = 0; k < 3; ++k)
        p[k] = loadAs(xyz[k]->datatype, &blob.data[base + xyz[k]->offset]);
      if (!p.allFinite()) continue;
      if (p.cwiseAbs().maxCoeff() > kMaxCoordinate_m)
        throw InputError(file.string(), 0,
                         "point " + std::to_string(row * blob.width + col) +
                             " lies beyond 1e6 m; not a plausible position in metres");
      points.push_back(p.cast<float>());
    }
  }
  return points;
}

std::vector<std::vector<double>> blobFields(const pcl::PCLPointCloud2& blob,
                                            const std::vector<std::string>& names,
                                            const fs::path& file) {
  std::vector<const pcl::PCLPointField*> fields;
  for (const std::string& name : names) {
    const pcl::PCLPointField* field = findField(blob, name);
    if (!field) {
      std::string present;
      for (const auto& f : blob.fields) present += (present.empty() ? "" : " ") + f.name;
      throw InputError(file.string(), 0,
                       "has no field '" + name + "' (its fields: " + present + ")");
    }
    if (field->offset + static_cast<std::uint32_t>(pcl::getFieldSize(field->datatype)) >
        blob.point_step)
      throw InputError(file.string(), 0, "has a field '" + name + "' beyond its point size");
    fields.push_back(field);
  }
  const std::size_t needed = blob.height == 0 ? 0 : std::size_t{blob.row_step} * blob.height;
  if (blob.data.size() < needed) throw InputError(file.string(), 0, "is truncated");
  std::vector<std::vector<double>> rows;
  rows.reserve(static_cast<std::size_t>(blob.width) * blob.height);
  for (std::uint32_t row = 0; row < blob.height; ++row) {
    for (std::uint32_t col = 0; col < blob.width; ++col) {
      const std::size_t base =
          row * std::size_t{blob.row_step} + col * std::size_t{blob.point_step};
      std::vector<double> values;
      values.reserve(fields.size());
      for (const auto* field : fields)
        values.push_back(loadAs(field->datatype, &blob.data[base + field->offset]));
      rows.push_back(std::move(values));
    }
  }
  return rows;
}

pcl::PCLPointCloud2 readPcdBlob(const fs::path& file) {
  pcl::PCLPointCloud2 blob;
  pcl::PCDReader reader;
  int status = -1;
  // PCL's reader throws PCLException for what it checks and lets std::out_of_range and
  // boost::bad_lexical_cast (both std::exception) escape from what it does not.
  try {
    status = reader.read(file.string(), blob);
  } catch (const pcl::PCLException& e) {
    throw InputError(file.string(), 0,
                     std::string("not a readable PCD file: ") + e.detailedMessage());
  } catch (const std::exception& e) {
    throw InputError(file.string(), 0, std::string("not a readable PCD file: ") + e.what());
  }
  if (status < 0) throw InputError(file.string(), 0, "not a readable PCD file");
  if (blob.data.size() < std::size_t{blob.row_step} * blob.height)
    throw InputError(file.string(), 0, "is truncated");
  return blob;
}

// An unorganised cloud of float32 fields, packed in the order given.
pcl::PCLPointCloud2 floatBlob(const std::vector<std::string>& names, std::size_t points) {
  pcl::PCLPointCloud2 blob;
  for (std::size_t i = 0; i < names.size(); ++i) {
    pcl::PCLPointField field;
    field.name = names[i];
    field.offset = static_cast<std::uint32_t>(4 * i);
    field.datatype = pcl::PCLPointField::FLOAT32;
    field.count = 1;
    blob.fields.push_back(field);
  }
  blob.height = 1;
  blob.width = static_cast<std::uint32_t>(points);
  blob.point_step = static_cast<std::uint32_t>(4 * names.size());
  blob.row_step = blob.point_step * blob.width;
  blob.is_dense = false;
  blob.data.resize(std::size_t{blob.row_step});
  return blob;
}

void putFloats(pcl::PCLPointCloud2* blob, std::size_t point, std::initializer_list<float> values) {
  std::memcpy(&blob->data[point * blob->point_step], values.begin(), 4 * values.size());
}

// PCL writes the file; the comment goes in right after PCL's own first line ("# .PCD v0.7 ...").
// PCL refuses to write a cloud without points, which is a valid (uncovered) map, so that header is
// completed here.
std::string encodePcd(const pcl::PCLPointCloud2& blob, const std::string& comment,
                      const fs::path& file) {
  pcl::PCDWriter writer;
  std::string content;
  if (blob.width == 0) {
    content =
        writer.generateHeaderBinary(blob, Eigen::Vector4f::Zero(), Eigen::Quaternionf::Identity()) +
        "DATA binary\n";
  } else {
    std::ostringstream stream;
    int status = -1;
    try {
      status = writer.writeBinaryCompressed(stream, blob);
    } catch (const pcl::PCLException& e) {
      throw OutputError("cannot write " + file.string() + ": " + e.detailedMessage());
    }
    if (status < 0) throw OutputError("cannot write " + file.string() + ": PCL failed");
    content = std::move(stream).str();
  }
  const std::size_t first_line_end = content.find('\n') + 1;
  content.insert(first_line_end, "# " + comment + "\n");
  return content;
}

}  // namespace mm4mm::io_detail
