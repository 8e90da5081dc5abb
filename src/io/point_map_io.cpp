#include "mm4mm/io/point_map_io.hpp"

#include <array>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <string>

#include "pcd_blob.hpp"
#include "text_io.hpp"

namespace mm4mm {

namespace fs = std::filesystem;
using io_detail::encodePcd;
using io_detail::floatBlob;
using io_detail::putFloats;

void writePointMapPcd(const fs::path& file, const PointMap& map) {
  if (map.normals.size() != map.points.size())
    throw std::invalid_argument("writePointMapPcd: " + std::to_string(map.normals.size()) +
                                " normals for " + std::to_string(map.points.size()) + " points");
  pcl::PCLPointCloud2 blob =
      floatBlob({"x", "y", "z", "normal_x", "normal_y", "normal_z"}, map.points.size());
  std::optional<double> epsilon;
  for (std::size_t i = 0; i < map.points.size(); ++i) {
    const Eigen::Vector3f& p = map.points[i];
    const Eigen::Vector3f& n = map.normals[i];
    if (!p.allFinite() || !n.allFinite())
      throw std::invalid_argument("writePointMapPcd: point " + std::to_string(i) +
                                  " is not finite");
    putFloats(&blob, i, {p.x(), p.y(), p.z(), n.x(), n.y(), n.z()});
    // n^T C n = eps for C = I - (1 - eps) n n^T: the flatness every covariance of the map shares.
    if (!epsilon && i < map.covariances.size() && n.squaredNorm() > 0.5f)
      epsilon = n.dot(map.covariances[i] * n);
  }
  std::string comment = "mm4mm_point_map session frame, m; covariance = I - (1 - eps) n n^T";
  if (epsilon) {
    // Three digits: the value is a float round trip of a setting such as 1e-3.
    std::array<char, 32> text{};
    std::snprintf(text.data(), text.size(), "%.3g", *epsilon);
    comment += ", eps=" + std::string(text.data());
  }
  io_detail::writeFileAtomically(file, encodePcd(blob, comment, file));
}

}  // namespace mm4mm
