#include "mm4mm/io/pcd_io.hpp"

#include <pcl/PCLPointCloud2.h>
#include <pcl/common/io.h>
#include <pcl/exceptions.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "mm4mm/io/input_error.hpp"
#include "pcd_blob.hpp"

namespace mm4mm {
namespace {

constexpr double kMaxCoordinate_m = 1e6;

pcl::PointCloud<pcl::PointXYZ> toPcl(const PointCloud& cloud) {
  pcl::PointCloud<pcl::PointXYZ> pcl_cloud;
  pcl_cloud.reserve(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3f& p = cloud[i];
    if (!p.allFinite() || p.cwiseAbs().maxCoeff() > kMaxCoordinate_m)
      throw std::invalid_argument("writePcd: point " + std::to_string(i) +
                                  " is not finite or lies beyond 1e6 m");
    pcl_cloud.push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  }
  pcl_cloud.is_dense = true;
  return pcl_cloud;
}

const char* dataTag(PcdEncoding encoding) {
  switch (encoding) {
    case PcdEncoding::kAscii:
      return "ascii";
    case PcdEncoding::kBinary:
      return "binary";
    case PcdEncoding::kBinaryCompressed:
      return "binary_compressed";
  }
  return "binary_compressed";
}

// PCL refuses (with a console error) to write a cloud without points; an empty scan is valid
// (a LiDAR facing open space), so its header is written here.
void writeEmpty(const std::string& file, PcdEncoding encoding) {
  const pcl::PointCloud<pcl::PointXYZ> empty;
  std::ofstream stream(file, std::ios::binary);
  stream << pcl::PCDWriter::generateHeader(empty, 0) << "DATA " << dataTag(encoding) << "\n";
  // A compressed body starts with its compressed and uncompressed sizes (both 0 here).
  if (encoding == PcdEncoding::kBinaryCompressed) stream.write("\0\0\0\0\0\0\0\0", 8);
  if (!stream.flush()) throw OutputError("cannot write " + file);
}

void writeWithPcl(const std::string& file, const pcl::PointCloud<pcl::PointXYZ>& cloud,
                  PcdEncoding encoding) {
  pcl::PCDWriter writer;
  int status = -1;
  try {
    switch (encoding) {
      case PcdEncoding::kAscii:
        status = writer.writeASCII(file, cloud, 9);
        break;
      case PcdEncoding::kBinary:
        status = writer.writeBinary(file, cloud);
        break;
      case PcdEncoding::kBinaryCompressed:
        status = writer.writeBinaryCompressed(file, cloud);
        break;
    }
  } catch (const pcl::PCLException& e) {
    throw OutputError("cannot write " + file + ": " + std::string(e.detailedMessage()));
  }
  if (status < 0) throw OutputError("cannot write " + file);
}

}  // namespace

PointCloud readPcd(const std::filesystem::path& file) {
  if (!std::filesystem::exists(file)) throw InputError(file.string(), 0, "file not found");
  if (!std::filesystem::is_regular_file(file))
    throw InputError(file.string(), 0, "is not a regular file");
  const io_detail::PcdHeader header = io_detail::readPcdHeader(file);
  io_detail::requireXyz(header.fields, file);
  // An empty scan is normal (open space); skipping PCL for it keeps PCL's warning off the console.
  if (header.points == 0) return {};
  return io_detail::blobPoints(io_detail::readPcdBlob(file), file);
}

std::vector<std::vector<double>> readPcdFields(const std::filesystem::path& file,
                                               const std::vector<std::string>& fields) {
  if (!std::filesystem::exists(file)) throw InputError(file.string(), 0, "file not found");
  if (!std::filesystem::is_regular_file(file))
    throw InputError(file.string(), 0, "is not a regular file");
  const io_detail::PcdHeader header = io_detail::readPcdHeader(file);
  if (header.points == 0) return {};
  return io_detail::blobFields(io_detail::readPcdBlob(file), fields, file);
}

void writePcd(const std::filesystem::path& file, const PointCloud& cloud, PcdEncoding encoding) {
  const pcl::PointCloud<pcl::PointXYZ> pcl_cloud = toPcl(cloud);
  std::filesystem::path tmp = file;
  tmp += ".tmp-" + std::to_string(::getpid());
  try {
    if (pcl_cloud.empty()) {
      writeEmpty(tmp.string(), encoding);
    } else {
      writeWithPcl(tmp.string(), pcl_cloud, encoding);
    }
    std::filesystem::rename(tmp, file);
  } catch (...) {
    std::error_code ignored;
    std::filesystem::remove(tmp, ignored);
    throw;
  }
}

}  // namespace mm4mm
