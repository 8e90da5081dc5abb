#pragma once
// Internal to io/: writing float32 point fields as PCD with an mm4mm header comment.

#include <pcl/PCLPointCloud2.h>

#include <filesystem>
#include <initializer_list>
#include <string>
#include <vector>

namespace mm4mm::io_detail {

/// An unorganised cloud of float32 fields, packed in the order given.
pcl::PCLPointCloud2 floatBlob(const std::vector<std::string>& names, std::size_t points);

/// Stores one point's values, in field order.
void putFloats(pcl::PCLPointCloud2* blob, std::size_t point, std::initializer_list<float> values);

/// The PCD file's bytes (binary compressed) with `comment` after PCL's first header line.
std::string encodePcd(const pcl::PCLPointCloud2& blob, const std::string& comment,
                      const std::filesystem::path& file);

}  // namespace mm4mm::io_detail
