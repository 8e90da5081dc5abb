#pragma once
// A session graph as g2o text. The standard part is a graph any g2o reader (g2o, Ceres'
// pose_graph_3d) loads on its own; everything else is in tags such readers skip:
//
//   # mm4mm session graph <id>
//   MM4MM_ODOMETRY_NOISE t_per_sqrt_m t_floor_m r_per_sqrt_m_deg r_per_sqrt_rad_deg r_floor_deg
//   VERTEX_SE3:QUAT id x y z qx qy qz qw                   scan node (standard)
//   SCAN_TIME id t                                         its time (s)
//   VERTEX_MAG:SE3:QUAT id t x y z qx qy qz qw n           magnetic node, n = sensors of the rig
//   MAG_READING id sensor bx by bz                         one per sensor with a reading (µT)
//   EDGE_SE3:QUAT i j x y z qx qy qz qw I11 I12 … I66      scan node to next scan node (standard)
//   EDGE_MAG:SE3:QUAT i j x y z qx qy qz qw I11 I12 … I66  odometry edge touching a magnetic node
//
// Poses are T_session_body, edges T_i_j; the 21 numbers are the upper triangle of the 6x6
// information matrix, row by row, ordered [translation xyz, rotation xyz]. The standard edges
// chain consecutive scan nodes: where magnetic nodes lie between two scan nodes, the edge is the
// composition of the odometry edges across them, with the information the graph's noise model
// gives the summed distance and turn; otherwise it is the odometry edge itself. Scan nodes are
// numbered as keyframes in the order of their VERTEX_SE3:QUAT lines.

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "mm4mm/graph/multi_session_graph.hpp"
#include "mm4mm/graph/session_graph.hpp"

namespace mm4mm {

/// Writes `graph` to `file` atomically (temporary name, then rename), every number in the
/// shortest text that reads back to the same double. Throws std::invalid_argument for a graph
/// that cannot be written consistently (no nodes, duplicate ids, an edge to an unknown node,
/// odometry not a chain, readings not one per sensor), std::runtime_error or
/// std::filesystem::filesystem_error on I/O failure.
void writeSessionGraphG2o(const SessionGraph& graph, const std::filesystem::path& file);

/// Reads a file written by writeSessionGraphG2o. Tags it does not know are skipped, as g2o does.
/// Throws InputError(file, line, problem) on a malformed line (wrong number of fields, a
/// non-number, a non-finite value), a quaternion whose norm is more than 1e-3 off 1, a duplicate
/// vertex id, an edge, reading or time naming an unknown vertex (or one of the wrong kind), an
/// information matrix that is not positive definite, a scan vertex without a time, or no
/// vertices at all (line 0). Odometry edges come back in chain order.
SessionGraph readSessionGraphG2o(const std::filesystem::path& file);

/// Several sessions' graphs in one file (an atlas's graph.g2o): each graph as
/// writeSessionGraphG2o writes it, its node ids shifted past the previous graph's so that every
/// id is unique, then the inter-session edges as standard EDGE_SE3:QUAT lines between scan nodes
/// (`session_a`/`session_b` index `graphs`, `keyframe_a`/`keyframe_b` their scan nodes).
/// Throws as writeSessionGraphG2o, and std::invalid_argument for an edge naming a missing
/// graph or scan node.
void writeMultiSessionGraphG2o(const std::vector<SessionGraph>& graphs,
                               const std::vector<InterSessionEdge>& edges,
                               const std::filesystem::path& file);

/// The same, with graph g made by `graph_at(g)` for g < count as the file is written and dropped
/// after: one session's graph held at a time (a graph costs hundreds of bytes a magnetometer
/// sample time, and an atlas of high-rate logs has millions).
void writeMultiSessionGraphG2o(std::size_t count,
                               const std::function<SessionGraph(std::size_t)>& graph_at,
                               const std::vector<InterSessionEdge>& edges,
                               const std::filesystem::path& file);

/// What `mm4mm add` needs back from an atlas's graph.g2o: the sessions in file order and the
/// inter-session edges between their keyframes (`session_a`/`session_b` index `session_ids`).
struct StoredInterSessionEdges {
  std::vector<std::string> session_ids;
  std::vector<InterSessionEdge> edges;
};

/// Reads the inter-session edges of a file written by writeMultiSessionGraphG2o; the sessions'
/// own nodes and edges are only counted. Throws InputError(file, line, problem) on a malformed
/// edge line, an edge between nodes that are not scan nodes of two different sessions, or a file
/// without session graphs.
StoredInterSessionEdges readInterSessionEdgesG2o(const std::filesystem::path& file);

}  // namespace mm4mm
