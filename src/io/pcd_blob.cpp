#include "pcd_blob.hpp"

#include <pcl/exceptions.h>
#include <pcl/io/pcd_io.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "mm4mm/io/input_error.hpp"

namespace mm4mm::io_detail {

namespace fs = std::filesystem;

namespace {
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
  PcdHeader header;
  std::vector<std::string> sizes, types, counts;
  bool has_size = false, has_type = false;
  const auto fail = [&](int line, const std::string& problem) {
    throw InputError(file.string(), line, "not a PCD file: " + problem);
  };
  const auto words = [](std::istringstream& in) {
    std::vector<std::string> all;
    for (std::string word; in >> word;) all.push_back(word);
    return all;
  };
  std::string line;
  for (int i = 1; i <= kMaxHeaderLines && std::getline(stream, line); ++i) {
    std::istringstream in(line);
    std::string keyword;
    in >> keyword;
    if (keyword.empty()) continue;
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
      long long points = 0;
      if (!(in >> points) || points < 0) fail(i, "POINTS is not a count");
      header.points = points;
    } else if (keyword == "WIDTH") {
      if (!(in >> header.width) || header.width < 0) fail(i, "WIDTH is not a count");
    } else if (keyword == "HEIGHT") {
      if (!(in >> header.height) || header.height < 0) fail(i, "HEIGHT is not a count");
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
      return header;
    } else {
      fail(i, "'" + keyword.substr(0, 40) + "' is not a PCD header keyword");
    }
  }
  fail(0, "no DATA line in its header");
  return header;  // not reached
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
      throw std::runtime_error("cannot write " + file.string() + ": " + e.detailedMessage());
    }
    if (status < 0) throw std::runtime_error("cannot write " + file.string() + ": PCL failed");
    content = std::move(stream).str();
  }
  const std::size_t first_line_end = content.find('\n') + 1;
  content.insert(first_line_end, "# " + comment + "\n");
  return content;
}

}  // namespace mm4mm::io_detail
