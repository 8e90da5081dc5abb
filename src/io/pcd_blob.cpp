#include "pcd_blob.hpp"

#include <pcl/exceptions.h>
#include <pcl/io/pcd_io.h>

#include <cstring>
#include <sstream>
#include <stdexcept>

namespace mm4mm::io_detail {

namespace fs = std::filesystem;

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
