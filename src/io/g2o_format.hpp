#pragma once
// Internal to io/: the tags of mm4mm's g2o text (include/mm4mm/io/g2o_io.hpp), shared by its
// writer (g2o_writer.cpp) and its readers (g2o_reader.cpp), so that the two cannot disagree.

#include <Eigen/Core>
#include <string_view>

namespace mm4mm::io_detail::g2o {

using Information = Eigen::Matrix<double, 6, 6>;

constexpr std::string_view kHeader = "# mm4mm session graph";
constexpr std::string_view kInterSessionHeader = "# inter-session edges";
constexpr std::string_view kNoiseTag = "MM4MM_ODOMETRY_NOISE";
constexpr std::string_view kScanVertexTag = "VERTEX_SE3:QUAT";
constexpr std::string_view kScanTimeTag = "SCAN_TIME";
constexpr std::string_view kMagVertexTag = "VERTEX_MAG:SE3:QUAT";
constexpr std::string_view kReadingTag = "MAG_READING";
constexpr std::string_view kEdgeTag = "EDGE_SE3:QUAT";
constexpr std::string_view kMagEdgeTag = "EDGE_MAG:SE3:QUAT";

enum class NodeKind { kScan, kMagnetic };

}  // namespace mm4mm::io_detail::g2o
