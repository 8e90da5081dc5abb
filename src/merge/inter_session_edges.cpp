#include "mm4mm/merge/inter_session_edges.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>

namespace mm4mm {
namespace {

struct KeyframePair {
  int a = 0;
  int b = 0;
};

// For every keyframe of b the nearest keyframe of a under T_a_b, within the radius; then one pair
// every `spacing_m` along a's trajectory, thinned evenly to at most `max_pairs`.
std::vector<KeyframePair> chooseKeyframePairs(const Session& a, const Session& b,
                                              const Eigen::Isometry3d& T_a_b,
                                              const InterSessionEdgeConfig& config) {
  std::vector<std::optional<std::pair<int, double>>> best_b_for_a(a.keyframes.size());
  for (std::size_t j = 0; j < b.keyframes.size(); ++j) {
    const Eigen::Vector3d p = T_a_b * b.keyframes[j].T_frame_body.translation();
    int nearest = -1;
    double nearest_distance = config.pair_radius_m;
    for (std::size_t i = 0; i < a.keyframes.size(); ++i) {
      const double d = (a.keyframes[i].T_frame_body.translation() - p).norm();
      if (d < nearest_distance) nearest_distance = d, nearest = static_cast<int>(i);
    }
    if (nearest < 0) continue;
    auto& slot = best_b_for_a[nearest];
    if (!slot || nearest_distance < slot->second) slot = {{static_cast<int>(j), nearest_distance}};
  }
  std::vector<KeyframePair> pairs;
  double since_last = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < a.keyframes.size(); ++i) {
    if (i > 0)
      since_last += (a.keyframes[i].T_frame_body.translation() -
                     a.keyframes[i - 1].T_frame_body.translation())
                        .norm();
    if (!best_b_for_a[i] || since_last < config.spacing_m) continue;
    pairs.push_back({static_cast<int>(i), best_b_for_a[i]->first});
    since_last = 0.0;
  }
  if (static_cast<int>(pairs.size()) > config.max_edges_per_pair) {
    std::vector<KeyframePair> thinned;
    for (int k = 0; k < config.max_edges_per_pair; ++k)
      thinned.push_back(pairs[k * pairs.size() / config.max_edges_per_pair]);
    pairs = thinned;
  }
  return pairs;
}

Eigen::Isometry3d keyframeSeed(const Session& a, const Session& b, const KeyframePair& pair,
                               const Eigen::Isometry3d& T_a_b) {
  return a.keyframes[pair.a].T_frame_body.inverse() * T_a_b * b.keyframes[pair.b].T_frame_body;
}

}  // namespace

bool InterSessionEdgeConfig::IsValid(std::string* error) const {
  const auto fail = [&](const std::string& message) {
    if (error) *error = message;
    return false;
  };
  if (!(pair_radius_m > 0.0)) return fail("pair_radius_m must be > 0");
  if (!(spacing_m >= 0.0)) return fail("spacing_m must be >= 0");
  if (max_edges_per_pair < 1) return fail("max_edges_per_pair must be >= 1");
  if (submap_half_width < 0) return fail("submap_half_width must be >= 0");
  if (!(max_range_m > 0.0)) return fail("max_range_m must be > 0");
  if (!(min_inlier_ratio >= 0.0 && min_inlier_ratio <= 1.0))
    return fail("min_inlier_ratio must be in [0, 1]");
  if (!(information_deflation >= 1.0)) return fail("information_deflation must be >= 1");
  std::string inner;
  if (!icp.IsValid(&inner)) return fail("icp." + inner);
  return true;
}

PointCloud keyframeSubmap(const Session& session, int keyframe, int half_width,
                          double max_range_m) {
  if (!session.hasScans())
    throw std::invalid_argument("keyframeSubmap: session " + session.id + " has no scans");
  const int first = std::max(0, keyframe - half_width);
  const int last = std::min(static_cast<int>(session.keyframes.size()) - 1, keyframe + half_width);
  const Eigen::Isometry3d T_centre_inverse = session.keyframes[keyframe].T_frame_body.inverse();
  const Eigen::Vector3d lidar_in_body = session.rig.T_body_lidar.translation();
  const double max_range_squared = max_range_m * max_range_m;
  PointCloud submap;
  for (int k = first; k <= last; ++k) {
    const Eigen::Isometry3f T_centre_k =
        (T_centre_inverse * session.keyframes[k].T_frame_body).cast<float>();
    for (const Eigen::Vector3f& p : session.scans[k]) {
      if ((p.cast<double>() - lidar_in_body).squaredNorm() > max_range_squared) continue;
      submap.push_back(T_centre_k * p);
    }
  }
  return submap;
}

std::vector<InterSessionEdge> interSessionEdges(const Session& a, int index_a, const Session& b,
                                                int index_b, const Eigen::Isometry3d& T_a_b,
                                                const InterSessionEdgeConfig& config) {
  std::string error;
  if (!config.IsValid(&error)) throw std::invalid_argument("interSessionEdges: " + error);
  if (!a.hasScans() || !b.hasScans())
    throw std::invalid_argument("interSessionEdges: sessions " + a.id + " and " + b.id +
                                " both need scans");
  const std::vector<KeyframePair> pairs = chooseKeyframePairs(a, b, T_a_b, config);
  std::vector<std::optional<InterSessionEdge>> refined(pairs.size());
  tbb::parallel_for(std::size_t{0}, pairs.size(), [&](std::size_t k) {
    const KeyframePair& pair = pairs[k];
    const PointCloud target =
        keyframeSubmap(a, pair.a, config.submap_half_width, config.max_range_m);
    const PointCloud source =
        keyframeSubmap(b, pair.b, config.submap_half_width, config.max_range_m);
    const IcpEmResult result =
        refineIcpEm(target, source, keyframeSeed(a, b, pair, T_a_b), config.icp);
    if (!result.converged || result.inlier_ratio < config.min_inlier_ratio) return;
    InterSessionEdge edge;
    edge.session_a = index_a;
    edge.keyframe_a = pair.a;
    edge.session_b = index_b;
    edge.keyframe_b = pair.b;
    edge.T_a_b = result.T_a_b;
    edge.information = result.information / config.information_deflation;
    // The geometric information is singular along what the geometry leaves open (a corridor's
    // axis); a whisker keeps it positive definite for the edge's Cholesky factor, and the
    // magnetic residuals hold that direction instead.
    edge.information += Eigen::Matrix<double, 6, 6>::Identity() * 1e-6;
    refined[k] = edge;
  });
  std::vector<InterSessionEdge> edges;
  for (const auto& edge : refined)
    if (edge) edges.push_back(*edge);
  return edges;
}

std::vector<InterSessionEdge> magneticOnlyEdges(const Session& a, int index_a, const Session& b,
                                                int index_b, const Eigen::Isometry3d& T_a_b,
                                                const InterSessionEdgeConfig& config,
                                                double sigma_m, double sigma_deg) {
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Identity();
  information.topLeftCorner<3, 3>() /= sigma_m * sigma_m;
  information.bottomRightCorner<3, 3>() /= std::pow(sigma_deg * M_PI / 180.0, 2);
  std::vector<InterSessionEdge> edges;
  for (const KeyframePair& pair : chooseKeyframePairs(a, b, T_a_b, config))
    edges.push_back(
        {index_a, pair.a, index_b, pair.b, keyframeSeed(a, b, pair, T_a_b), information});
  return edges;
}

}  // namespace mm4mm
