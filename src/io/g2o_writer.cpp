// Writing session graphs and an atlas's graphs as g2o text (format: mm4mm/io/g2o_io.hpp).

#include <algorithm>
#include <cmath>
#include <functional>
#include <initializer_list>
#include <map>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "g2o_format.hpp"
#include "mm4mm/core/pose.hpp"
#include "mm4mm/io/g2o_io.hpp"
#include "text_io.hpp"

namespace mm4mm {
namespace {

using namespace io_detail::g2o;
using io_detail::formatNumber;

// Text handed to the file a megabyte at a time: an atlas of high-rate magnetometer logs has
// millions of magnetic nodes, whose text held whole took more memory than their graph.
class ChunkedText {
 public:
  explicit ChunkedText(io_detail::AtomicTextFile* file) : file_(file) {}
  std::string* text() { return &text_; }
  void flushIfLarge() {
    if (text_.size() >= kChunkBytes) flush();
  }
  void flush() {
    file_->write(text_);
    text_.clear();
  }

 private:
  static constexpr std::size_t kChunkBytes = 1 << 20;
  io_detail::AtomicTextFile* file_;
  std::string text_;
};

void appendNumbers(std::initializer_list<double> values, std::string* out) {
  for (double value : values) {
    *out += ' ';
    *out += formatNumber(value);
  }
}

// x y z qx qy qz qw
void appendPose(const Eigen::Isometry3d& T, std::string* out) {
  const Eigen::Quaterniond q(T.linear());
  const Eigen::Vector3d& t = T.translation();
  appendNumbers({t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()}, out);
}

void appendEdge(std::string_view tag, int from, int to, const Eigen::Isometry3d& T_from_to,
                const Information& information, std::string* out) {
  *out += tag;
  *out += ' ' + std::to_string(from) + ' ' + std::to_string(to);
  appendPose(T_from_to, out);
  for (int r = 0; r < 6; ++r) {
    for (int c = r; c < 6; ++c) appendNumbers({information(r, c)}, out);
  }
  *out += '\n';
}

void checkPose(const Eigen::Isometry3d& T, const std::string& what) {
  if (!T.matrix().allFinite())
    throw std::invalid_argument("writeSessionGraphG2o: " + what + " is not finite");
  const Eigen::Matrix3d R = T.linear();
  if (!(R.transpose() * R).isApprox(Eigen::Matrix3d::Identity(), 1e-6) || R.determinant() <= 0.0)
    throw std::invalid_argument("writeSessionGraphG2o: " + what + " is not a rigid motion");
}

// Node kinds by id; throws on what the file could not represent or a reader would reject.
std::map<int, NodeKind> checkGraph(const SessionGraph& graph) {
  const auto fail = [](const std::string& problem) {
    throw std::invalid_argument("writeSessionGraphG2o: " + problem);
  };
  if (graph.session_id.find_first_of("\r\n") != std::string::npos)
    fail("session id contains a line break");
  std::string error;
  if (!graph.noise.IsValid(&error)) fail(error);
  if (graph.scans.empty() && graph.magnetic.empty()) fail("the graph has no nodes");
  std::map<int, NodeKind> kinds;
  for (const ScanNode& node : graph.scans) {
    if (!kinds.emplace(node.id, NodeKind::kScan).second)
      fail("duplicate node id " + std::to_string(node.id));
    if (!std::isfinite(node.time_s)) fail("scan node " + std::to_string(node.id) + " time");
    checkPose(node.T_session_body, "pose of scan node " + std::to_string(node.id));
  }
  for (const MagneticNode& node : graph.magnetic) {
    const std::string name = "magnetic node " + std::to_string(node.id);
    if (!kinds.emplace(node.id, NodeKind::kMagnetic).second)
      fail("duplicate node id " + std::to_string(node.id));
    if (!std::isfinite(node.time_s)) fail(name + " time is not finite");
    checkPose(node.T_session_body, "pose of " + name);
    if (node.readings_body_uT.empty()) fail(name + " has no sensors");
    if (node.readings_body_uT.size() != node.has_reading.size())
      fail(name + " has " + std::to_string(node.readings_body_uT.size()) + " readings but " +
           std::to_string(node.has_reading.size()) + " flags");
    for (const Eigen::Vector3d& b : node.readings_body_uT) {
      if (!b.allFinite()) fail(name + " has a non-finite reading");
    }
  }
  for (std::size_t i = 0; i < graph.odometry.size(); ++i) {
    const OdometryEdge& edge = graph.odometry[i];
    const std::string name = "odometry edge " + std::to_string(i);
    if (!kinds.count(edge.from) || !kinds.count(edge.to)) fail(name + " names an unknown node");
    if (i > 0 && edge.from != graph.odometry[i - 1].to)
      fail(name + " does not start where the previous one ends (odometry is not a chain)");
    checkPose(edge.T_from_to, name);
    if (!edge.information.allFinite()) fail(name + " has a non-finite information matrix");
  }
  return kinds;
}

// Standard edges between consecutive scan nodes: the odometry composed across the magnetic
// nodes between them. Distance and turn add along the chain, which is what the noise model's
// random walk needs (see SessionGraphConfig).
void appendScanChain(const SessionGraph& graph, const std::map<int, NodeKind>& kinds, int offset,
                     ChunkedText* sink) {
  bool open = false;
  int start = 0;
  int segments = 0;
  Eigen::Isometry3d T_start_end = Eigen::Isometry3d::Identity();
  double distance_m = 0.0;
  double turned_rad = 0.0;
  const Information* single = nullptr;
  for (const OdometryEdge& edge : graph.odometry) {
    if (kinds.at(edge.from) == NodeKind::kScan) {
      open = true;
      start = edge.from;
      segments = 0;
      T_start_end.setIdentity();
      distance_m = 0.0;
      turned_rad = 0.0;
    }
    if (!open) continue;  // magnetic nodes before the first scan node
    T_start_end = T_start_end * edge.T_from_to;
    distance_m += edge.T_from_to.translation().norm();
    turned_rad += rotationAngle(edge.T_from_to.linear());
    single = &edge.information;
    ++segments;
    if (kinds.at(edge.to) != NodeKind::kScan) continue;
    // A direct scan-to-scan edge is written as it is, so that it reads back exactly.
    const Information information =
        segments == 1 ? *single : odometryInformation(distance_m, turned_rad, graph.noise);
    appendEdge(kEdgeTag, start + offset, edge.to + offset, T_start_end, information, sink->text());
    sink->flushIfLarge();
    open = false;
  }
}

// The graph's lines with every node id raised by `offset` (its place in an atlas's file).
void writeGraph(const SessionGraph& graph, int offset, ChunkedText* sink) {
  const std::map<int, NodeKind> kinds = checkGraph(graph);
  std::string& out = *sink->text();
  out += std::string(kHeader) + ' ' + graph.session_id + '\n';
  out += kNoiseTag;
  const SessionGraphConfig& noise = graph.noise;
  appendNumbers({noise.translation_sigma_per_sqrt_m, noise.translation_sigma_floor_m,
                 noise.rotation_sigma_per_sqrt_m_deg, noise.rotation_sigma_per_sqrt_rad_deg,
                 noise.rotation_sigma_floor_deg},
                &out);
  out += '\n';
  for (const ScanNode& node : graph.scans) {
    const std::string id = std::to_string(node.id + offset);
    out += std::string(kScanVertexTag) + ' ' + id;
    appendPose(node.T_session_body, &out);
    out += '\n' + std::string(kScanTimeTag) + ' ' + id;
    appendNumbers({node.time_s}, &out);
    out += '\n';
    sink->flushIfLarge();
  }
  for (const MagneticNode& node : graph.magnetic) {
    const std::string id = std::to_string(node.id + offset);
    out += std::string(kMagVertexTag) + ' ' + id;
    appendNumbers({node.time_s}, &out);
    appendPose(node.T_session_body, &out);
    out += ' ' + std::to_string(node.readings_body_uT.size()) + '\n';
    for (std::size_t s = 0; s < node.readings_body_uT.size(); ++s) {
      if (!node.has_reading[s]) continue;
      const Eigen::Vector3d& b = node.readings_body_uT[s];
      out += std::string(kReadingTag) + ' ' + id + ' ' + std::to_string(s);
      appendNumbers({b.x(), b.y(), b.z()}, &out);
      out += '\n';
    }
    sink->flushIfLarge();
  }
  appendScanChain(graph, kinds, offset, sink);
  for (const OdometryEdge& edge : graph.odometry) {
    if (kinds.at(edge.from) == NodeKind::kScan && kinds.at(edge.to) == NodeKind::kScan) continue;
    appendEdge(kMagEdgeTag, edge.from + offset, edge.to + offset, edge.T_from_to, edge.information,
               &out);
    sink->flushIfLarge();
  }
}

}  // namespace

void writeSessionGraphG2o(const SessionGraph& graph, const std::filesystem::path& file) {
  io_detail::AtomicTextFile out(file);
  ChunkedText sink(&out);
  writeGraph(graph, 0, &sink);
  sink.flush();
  out.commit();
}

namespace {

// Writes graph_at(0), graph_at(1), ... one at a time (each may be built on the call and dropped
// after it), then the edges: what writeMultiSessionGraphG2o states, for either source of graphs.
template <typename GraphAt>
void writeGraphs(std::size_t count, GraphAt&& graph_at, const std::vector<InterSessionEdge>& edges,
                 const std::filesystem::path& file) {
  io_detail::AtomicTextFile out(file);
  ChunkedText sink(&out);
  std::vector<std::vector<int>> scan_ids;  // per graph, its scan nodes' ids in the file
  int offset = 0;
  for (std::size_t g = 0; g < count; ++g) {
    const SessionGraph& graph = graph_at(g);
    writeGraph(graph, offset, &sink);
    scan_ids.emplace_back();
    int largest = -1;
    for (const ScanNode& node : graph.scans) {
      largest = std::max(largest, node.id);
      scan_ids.back().push_back(node.id + offset);
    }
    for (const MagneticNode& node : graph.magnetic) largest = std::max(largest, node.id);
    offset += largest + 1;
  }
  *sink.text() += std::string(kInterSessionHeader) + "\n";
  for (std::size_t e = 0; e < edges.size(); ++e) {
    const InterSessionEdge& edge = edges[e];
    const auto scanId = [&](int session, int keyframe) {
      if (session < 0 || session >= static_cast<int>(count) || keyframe < 0 ||
          keyframe >= static_cast<int>(scan_ids[session].size()))
        throw std::invalid_argument("writeMultiSessionGraphG2o: edge " + std::to_string(e) +
                                    " names session " + std::to_string(session) + " keyframe " +
                                    std::to_string(keyframe) + ", which is not in the graphs");
      return scan_ids[session][keyframe];
    };
    appendEdge(kEdgeTag, scanId(edge.session_a, edge.keyframe_a),
               scanId(edge.session_b, edge.keyframe_b), edge.T_a_b, edge.information, sink.text());
    sink.flushIfLarge();
  }
  sink.flush();
  out.commit();
}

}  // namespace

void writeMultiSessionGraphG2o(const std::vector<SessionGraph>& graphs,
                               const std::vector<InterSessionEdge>& edges,
                               const std::filesystem::path& file) {
  writeGraphs(
      graphs.size(), [&](std::size_t g) -> const SessionGraph& { return graphs[g]; }, edges, file);
}

void writeMultiSessionGraphG2o(std::size_t count,
                               const std::function<SessionGraph(std::size_t)>& graph_at,
                               const std::vector<InterSessionEdge>& edges,
                               const std::filesystem::path& file) {
  writeGraphs(count, graph_at, edges, file);
}

}  // namespace mm4mm
