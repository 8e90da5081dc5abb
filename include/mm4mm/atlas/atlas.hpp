#pragma once
// The atlas as the pipeline sees it: its sessions, their poses in the atlas frame, the graph's
// edges and the pairs of the merge that built it. Plain data; io/atlas_io reads and writes it
// (docs/design.md "Atlas directory"), and `add` extends it.

#include <Eigen/Geometry>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "mm4mm/atlas/pipeline_config.hpp"
#include "mm4mm/magnetic/magnetic_map.hpp"
#include "mm4mm/merge/inter_session_edges.hpp"
#include "mm4mm/merge/merge_sessions.hpp"
#include "mm4mm/session/session.hpp"

namespace mm4mm {

struct AtlasSessionEntry {
  std::string id;
  std::filesystem::path source;  ///< the session directory it was read from (absolute)
  bool connected = false;
  Eigen::Isometry3d T_atlas_session = Eigen::Isometry3d::Identity();
};

struct AtlasManifest {
  int version = 3;
  std::vector<AtlasSessionEntry> sessions;
  /// Index into `sessions` of the session whose frame the atlas's is (`frame: ID`; an atlas
  /// written before it was stated took its first session's frame). Always a connected session.
  int frame_session = 0;
  /// The settings the atlas was built with (config.yaml), which `add` runs with by default.
  PipelineConfig config;
  /// False for an atlas written before the settings were stored (version 2): `config` is then
  /// the defaults with the OctoMap resolution its manifest kept.
  bool config_stored = true;
  /// Every other file of the atlas (path relative to it) with its SHA-256, hex.
  std::vector<std::pair<std::string, std::string>> files;
};

/// An atlas read back with its sessions: every session of the manifest read from its source
/// directory, and its keyframe poses in the atlas frame (trajectories/<id>.txt for a connected
/// session; its own odometry for an unconnected one).
struct Atlas {
  AtlasManifest manifest;
  std::vector<Session> sessions;
  std::vector<std::vector<Eigen::Isometry3d>> T_atlas_keyframe;
  std::vector<bool> connected;
  /// The session whose frame the atlas's is (manifest `frame`; session 0 in an atlas written
  /// before it was stated, which always took the first session's frame).
  int frame_session = 0;
  /// The graph's inter-session edges (graph.g2o), session indices into `sessions`.
  std::vector<InterSessionEdge> edges;
  /// The session pairs of report.json: ids, verdict and scores, role, transform, edge counts.
  std::vector<PairResult> pairs;
  /// magnetic_map.pcd: the sessions' fused map in the atlas frame (empty if none was written).
  MagneticMap fused_magnetic_map;
};

}  // namespace mm4mm
