#include "mm4mm/graph/multi_session_graph.hpp"

#include <ceres/ceres.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <deque>
#include <limits>
#include <stdexcept>
#include <string>

#include "mm4mm/core/pose.hpp"
#include "pose_graph_costs.hpp"

namespace mm4mm {
namespace internal {

std::unique_ptr<InterpolableMagneticMap> makeInterpolable(const MagneticMap& map) {
  auto out = std::make_unique<InterpolableMagneticMap>();
  out->origin_m = map.origin_m;
  out->cell_size_m = map.cell_size_m;
  out->width = map.width;
  out->height = map.height;
  const std::size_t cells = static_cast<std::size_t>(map.width) * map.height;
  out->values.assign(2 * cells, std::numeric_limits<double>::quiet_NaN());
  out->covered.assign(cells, false);
  for (std::size_t i = 0; i < cells; ++i) {
    if (!std::isfinite(map.horizontal_uT[i]) || !std::isfinite(map.vertical_uT[i])) continue;
    out->covered[i] = true;
    out->values[2 * i] = map.horizontal_uT[i];
    out->values[2 * i + 1] = map.vertical_uT[i];
  }
  // Breadth-first fill from the covered cells: each uncovered cell takes the value of the nearest
  // covered one (4-neighbourhood), so the interpolant is continuous across the swath's edge and
  // never sees NaN.
  std::deque<std::size_t> frontier;
  for (std::size_t i = 0; i < cells; ++i)
    if (out->covered[i]) frontier.push_back(i);
  while (!frontier.empty()) {
    const std::size_t i = frontier.front();
    frontier.pop_front();
    const int ix = static_cast<int>(i % map.width), iy = static_cast<int>(i / map.width);
    const int neighbours[4][2] = {{ix - 1, iy}, {ix + 1, iy}, {ix, iy - 1}, {ix, iy + 1}};
    for (const auto& n : neighbours) {
      if (n[0] < 0 || n[1] < 0 || n[0] >= map.width || n[1] >= map.height) continue;
      const std::size_t j = static_cast<std::size_t>(n[1]) * map.width + n[0];
      if (!std::isnan(out->values[2 * j])) continue;
      out->values[2 * j] = out->values[2 * i];
      out->values[2 * j + 1] = out->values[2 * i + 1];
      frontier.push_back(j);
    }
  }
  if (cells > 0 && std::isnan(out->values[0]))
    std::fill(out->values.begin(), out->values.end(), 0.0);
  out->grid =
      std::make_unique<ceres::Grid2D<double, 2>>(out->values.data(), 0, map.height, 0, map.width);
  out->interpolator =
      std::make_unique<ceres::BiCubicInterpolator<ceres::Grid2D<double, 2>>>(*out->grid);
  return out;
}

}  // namespace internal

namespace {

using internal::InterpolableMagneticMap;
using internal::MagneticMapCost;
using internal::RelativePoseCost;

constexpr int kMagneticMapDownsample = 5;  // 5 cm maps solved at 25 cm: smooth gradients
// σ of the prior on each session's field offset (µT): wide enough for any uncalibrated vertical
// hard iron, tight enough to fix the constant common to all offsets.
constexpr double kFieldOffsetPriorUT = 50.0;

struct PoseBlock {
  Eigen::Vector3d p;
  Eigen::Quaterniond q;
};

Eigen::Isometry3d toIsometry(const PoseBlock& block) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = block.q.normalized().toRotationMatrix();
  T.translation() = block.p;
  return T;
}

PoseBlock toBlock(const Eigen::Isometry3d& T) {
  return {T.translation(), Eigen::Quaterniond(T.linear()).normalized()};
}

void checkProblem(const MultiSessionProblem& problem) {
  const std::size_t n = problem.sessions.size();
  if (problem.T_atlas_session.size() != n || problem.connected.size() != n)
    throw std::invalid_argument(
        "solveMultiSessionGraph: T_atlas_session and connected need one entry per session");
  if (!problem.initial_T_atlas_keyframe.empty() && problem.initial_T_atlas_keyframe.size() != n)
    throw std::invalid_argument(
        "solveMultiSessionGraph: initial_T_atlas_keyframe must be empty or hold one entry per "
        "session");
  for (std::size_t s = 0; s < problem.initial_T_atlas_keyframe.size(); ++s)
    if (!problem.initial_T_atlas_keyframe[s].empty() && problem.sessions[s] != nullptr &&
        problem.initial_T_atlas_keyframe[s].size() != problem.sessions[s]->keyframes.size())
      throw std::invalid_argument("solveMultiSessionGraph: initial poses of session " +
                                  std::to_string(s) + " are not one per keyframe");
  if (!problem.magnetic_maps.empty() && problem.magnetic_maps.size() != n)
    throw std::invalid_argument(
        "solveMultiSessionGraph: magnetic_maps must be empty or hold one map per session");
  if (!problem.heights_above_floor_m.empty() && problem.heights_above_floor_m.size() != n)
    throw std::invalid_argument(
        "solveMultiSessionGraph: heights_above_floor_m must be empty or hold one per session");
  for (std::size_t s = 0; s < n; ++s) {
    if (problem.sessions[s] == nullptr || problem.sessions[s]->keyframes.empty())
      throw std::invalid_argument("solveMultiSessionGraph: session " + std::to_string(s) +
                                  " has no keyframes");
  }
  if (problem.gauge_session != -1 &&
      (problem.gauge_session < 0 || problem.gauge_session >= static_cast<int>(n) ||
       !problem.connected[problem.gauge_session]))
    throw std::invalid_argument("solveMultiSessionGraph: gauge session " +
                                std::to_string(problem.gauge_session) +
                                " is missing or unconnected");
  for (std::size_t e = 0; e < problem.edges.size(); ++e) {
    const InterSessionEdge& edge = problem.edges[e];
    const auto check = [&](int session, int keyframe, const char* side) {
      if (session < 0 || session >= static_cast<int>(n) || !problem.connected[session])
        throw std::invalid_argument("solveMultiSessionGraph: edge " + std::to_string(e) +
                                    " names session " + std::to_string(session) + " (" + side +
                                    "), which is missing or unconnected");
      const int keyframes = static_cast<int>(problem.sessions[session]->keyframes.size());
      if (keyframe < 0 || keyframe >= keyframes)
        throw std::invalid_argument("solveMultiSessionGraph: edge " + std::to_string(e) +
                                    " names keyframe " + std::to_string(keyframe) + " (" + side +
                                    ") of a session with " + std::to_string(keyframes));
    };
    check(edge.session_a, edge.keyframe_a, "a");
    check(edge.session_b, edge.keyframe_b, "b");
    if (edge.session_a == edge.session_b)
      throw std::invalid_argument("solveMultiSessionGraph: edge " + std::to_string(e) +
                                  " joins a session to itself");
  }
}

// The gauge session (MultiSessionProblem::gauge_session), -1 where no session is connected.
int gaugeSession(const MultiSessionProblem& problem) {
  if (problem.gauge_session >= 0) return problem.gauge_session;
  for (std::size_t s = 0; s < problem.connected.size(); ++s)
    if (problem.connected[s]) return static_cast<int>(s);
  return -1;
}

// Sessions reachable from the gauge session through kept inter-session edges: only they have a
// place in the atlas.

std::vector<bool> reachableSessions(const MultiSessionProblem& problem,
                                    const std::vector<bool>& edge_kept) {
  const std::size_t n = problem.sessions.size();
  std::vector<bool> reached(n, false);
  const int root = gaugeSession(problem);
  if (root < 0) return reached;
  reached[root] = true;
  for (bool grew = true; grew;) {
    grew = false;
    for (std::size_t e = 0; e < problem.edges.size(); ++e) {
      if (!edge_kept[e]) continue;
      const int a = problem.edges[e].session_a, b = problem.edges[e].session_b;
      if (reached[a] != reached[b]) {
        reached[a] = reached[b] = true;
        grew = true;
      }
    }
  }
  return reached;
}

ceres::LossFunction* makeLoss(RobustLoss loss, double scale) {
  switch (loss) {
    case RobustLoss::kHuber:
      return new ceres::HuberLoss(scale);
    case RobustLoss::kCauchy:
      return new ceres::CauchyLoss(scale);
    case RobustLoss::kNone:
      break;
  }
  return nullptr;
}

// One magnetic reading chosen for the solve: session s's sensor in its keyframe's body frame and
// its heading-free (B_h, B_v).
struct MagneticReading {
  int session = 0;
  int keyframe = 0;
  Eigen::Vector3d sensor_in_keyframe = Eigen::Vector3d::Zero();
  Eigen::Vector2d fingerprint_uT = Eigen::Vector2d::Zero();
};

// Every `stride_m` of travel, the readings of all sensors at that instant, attached to the
// keyframe nearest in time.
std::vector<MagneticReading> selectReadings(const Session& session, int session_index,
                                            double stride_m) {
  std::vector<MagneticReading> readings;
  const std::vector<PlacedFingerprint> placed = placeFingerprints(session);
  const auto& keyframes = session.keyframes;
  std::vector<Eigen::Vector3d> last_position(session.rig.magnetometers_body.size());
  std::vector<bool> seen(last_position.size(), false);
  double travelled_since_chosen = stride_m;
  double instant = std::numeric_limits<double>::quiet_NaN();
  bool instant_chosen = false;
  std::size_t keyframe = 0;
  for (const PlacedFingerprint& sample : placed) {
    if (sample.time_s != instant) {
      // A new instant: travel is measured by the first sensor reporting in it, against that
      // same sensor's previous position.
      instant = sample.time_s;
      if (seen[sample.sensor])
        travelled_since_chosen += (sample.position_m - last_position[sample.sensor]).norm();
      instant_chosen = travelled_since_chosen >= stride_m;
      if (instant_chosen) travelled_since_chosen = 0.0;
      while (keyframe + 1 < keyframes.size() &&
             std::abs(keyframes[keyframe + 1].time_s - sample.time_s) <=
                 std::abs(keyframes[keyframe].time_s - sample.time_s))
        ++keyframe;
    }
    last_position[sample.sensor] = sample.position_m;
    seen[sample.sensor] = true;
    if (!instant_chosen) continue;
    MagneticReading reading;
    reading.session = session_index;
    reading.keyframe = static_cast<int>(keyframe);
    reading.sensor_in_keyframe = keyframes[keyframe].T_frame_body.inverse() * sample.position_m;
    reading.fingerprint_uT = {sample.fingerprint.horizontal_uT, sample.fingerprint.vertical_uT};
    readings.push_back(reading);
  }
  return readings;
}

bool coveredAround(const InterpolableMagneticMap& map, const Eigen::Vector2d& p) {
  const int ix = static_cast<int>(std::floor((p.x() - map.origin_m.x()) / map.cell_size_m));
  const int iy = static_cast<int>(std::floor((p.y() - map.origin_m.y()) / map.cell_size_m));
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      const int x = ix + dx, y = iy + dy;
      if (x < 0 || y < 0 || x >= map.width || y >= map.height) return false;
      if (!map.covered[static_cast<std::size_t>(y) * map.width + x]) return false;
    }
  return true;
}

// Whether a reading of session s, `z_in_t` high in session t's frame near t's nearest keyframe,
// was taken at another height than t's map: by the two sessions' heights above the floor where
// both are known (an odometry's z drift, which moves the frame's z along a session, does not reach
// them), else by z against the map's mean height.
bool heightsDiffer(const MultiSessionProblem& problem, std::size_t s, std::size_t t,
                   double z_in_t) {
  const auto& above_floor = problem.heights_above_floor_m;
  if (!above_floor.empty() && above_floor[s] && above_floor[t])
    return std::abs(*above_floor[s] - *above_floor[t]) > problem.max_height_difference_m;
  return std::abs(z_in_t - problem.magnetic_maps[t]->height_m) > problem.max_height_difference_m;
}

int nearestKeyframe(const std::vector<PoseBlock>& poses, const Eigen::Vector3d& point) {
  int best = 0;
  double best_distance = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < poses.size(); ++k) {
    const double d = (poses[k].p - point).head<2>().squaredNorm();
    if (d < best_distance) {
      best_distance = d;
      best = static_cast<int>(k);
    }
  }
  return best;
}

double whitenedSquaredError(const InterSessionEdge& edge,
                            const std::vector<std::vector<PoseBlock>>& poses) {
  const PoseBlock& a = poses[edge.session_a][edge.keyframe_a];
  const PoseBlock& b = poses[edge.session_b][edge.keyframe_b];
  const RelativePoseCost cost(edge.T_a_b, edge.information);
  Eigen::Matrix<double, 6, 1> residual;
  cost(a.p.data(), a.q.coeffs().data(), b.p.data(), b.q.coeffs().data(), residual.data());
  return residual.squaredNorm();
}

}  // namespace

bool MultiSessionGraphConfig::IsValid(std::string* error) const {
  const auto fail = [&](const std::string& message) {
    if (error) *error = message;
    return false;
  };
  std::string inner;
  if (!odometry_noise.IsValid(&inner)) return fail("odometry_noise." + inner);
  if (!(inter_session_loss_scale > 0.0)) return fail("inter_session_loss_scale must be > 0");
  if (!(max_inter_session_chi2 > 0.0)) return fail("max_inter_session_chi2 must be > 0");
  if (max_outlier_rounds < 0) return fail("max_outlier_rounds must be >= 0");
  if (!(magnetic_stride_m > 0.0)) return fail("magnetic_stride_m must be > 0");
  if (!(magnetic_sigma_uT > 0.0)) return fail("magnetic_sigma_uT must be > 0");
  if (!(magnetic_loss_scale > 0.0)) return fail("magnetic_loss_scale must be > 0");
  if (max_iterations < 1) return fail("max_iterations must be >= 1");
  if (threads < 1) return fail("threads must be >= 1");
  return true;
}

MultiSessionSolution solveMultiSessionGraph(const MultiSessionProblem& problem,
                                            const MultiSessionGraphConfig& config) {
  std::string error;
  if (!config.IsValid(&error)) throw std::invalid_argument("solveMultiSessionGraph: " + error);
  checkProblem(problem);
  const auto start = std::chrono::steady_clock::now();
  const std::size_t n = problem.sessions.size();

  std::vector<std::vector<PoseBlock>> poses(n);
  for (std::size_t s = 0; s < n; ++s) {
    const Eigen::Isometry3d T =
        problem.connected[s] ? problem.T_atlas_session[s] : Eigen::Isometry3d::Identity();
    const bool warm = problem.connected[s] && s < problem.initial_T_atlas_keyframe.size() &&
                      !problem.initial_T_atlas_keyframe[s].empty();
    const auto& keyframes = problem.sessions[s]->keyframes;
    for (std::size_t k = 0; k < keyframes.size(); ++k)
      poses[s].push_back(
          toBlock(warm ? problem.initial_T_atlas_keyframe[s][k] : T * keyframes[k].T_frame_body));
  }

  std::vector<std::unique_ptr<InterpolableMagneticMap>> maps(n);
  std::vector<std::vector<MagneticReading>> readings(n);
  if (config.use_magnetic_residuals && !problem.magnetic_maps.empty()) {
    for (std::size_t s = 0; s < n; ++s) {
      // A session placed by geometry alone may have no magnetic map at all.
      if (!problem.connected[s] || problem.magnetic_maps[s] == nullptr ||
          problem.magnetic_maps[s]->coveredCells() == 0)
        continue;
      maps[s] =
          internal::makeInterpolable(downsample(*problem.magnetic_maps[s], kMagneticMapDownsample));
      readings[s] =
          selectReadings(*problem.sessions[s], static_cast<int>(s), config.magnetic_stride_m);
    }
  }

  // Each session's field offset (MagneticMapCost), kept across the outlier rounds; a weak prior
  // fixes the common constant the residuals leave free.
  std::vector<Eigen::Vector2d> field_offsets(n, Eigen::Vector2d::Zero());

  MultiSessionSolution solution;
  solution.edge_kept.assign(problem.edges.size(), true);
  solution.edge_chi2.assign(problem.edges.size(), 0.0);
  std::vector<bool> in_solve = reachableSessions(problem, solution.edge_kept);

  for (int round = 0; round <= config.max_outlier_rounds; ++round) {
    ceres::Problem::Options problem_options;
    problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem ceres_problem(problem_options);
    ceres::EigenQuaternionManifold quaternion_manifold;
    const int gauge = gaugeSession(problem);
    for (std::size_t s = 0; s < n; ++s) {
      if (!in_solve[s]) continue;
      const auto& keyframes = problem.sessions[s]->keyframes;
      for (std::size_t k = 0; k + 1 < keyframes.size(); ++k) {
        const Eigen::Isometry3d T_k_next =
            keyframes[k].T_frame_body.inverse() * keyframes[k + 1].T_frame_body;
        const auto information = odometryInformation(
            T_k_next.translation().norm(), rotationAngle(T_k_next.linear()), config.odometry_noise);
        ceres_problem.AddResidualBlock(RelativePoseCost::Create(T_k_next, information), nullptr,
                                       poses[s][k].p.data(), poses[s][k].q.coeffs().data(),
                                       poses[s][k + 1].p.data(), poses[s][k + 1].q.coeffs().data());
      }
      for (PoseBlock& block : poses[s])
        if (ceres_problem.HasParameterBlock(block.q.coeffs().data()))
          ceres_problem.SetManifold(block.q.coeffs().data(), &quaternion_manifold);
    }
    if (gauge < 0) break;
    for (std::size_t e = 0; e < problem.edges.size(); ++e) {
      if (!solution.edge_kept[e]) continue;
      const InterSessionEdge& edge = problem.edges[e];
      if (!in_solve[edge.session_a] || !in_solve[edge.session_b]) continue;
      PoseBlock& a = poses[edge.session_a][edge.keyframe_a];
      PoseBlock& b = poses[edge.session_b][edge.keyframe_b];
      for (PoseBlock* block : {&a, &b}) {
        if (!ceres_problem.HasParameterBlock(block->q.coeffs().data())) {
          ceres_problem.AddParameterBlock(block->p.data(), 3);
          ceres_problem.AddParameterBlock(block->q.coeffs().data(), 4, &quaternion_manifold);
        }
      }
      ceres_problem.AddResidualBlock(
          RelativePoseCost::Create(edge.T_a_b, edge.information),
          makeLoss(config.inter_session_loss, config.inter_session_loss_scale), a.p.data(),
          a.q.coeffs().data(), b.p.data(), b.q.coeffs().data());
    }
    // Magnetic residuals against every other session in the solve whose map covers the reading
    // at the current estimate; the association is fixed for this round.
    int magnetic_residuals = 0;
    for (std::size_t s = 0; s < n; ++s) {
      if (!in_solve[s]) continue;
      for (const MagneticReading& reading : readings[s]) {
        PoseBlock& own = poses[s][reading.keyframe];
        const Eigen::Vector3d in_atlas = own.q * reading.sensor_in_keyframe + own.p;
        for (std::size_t t = 0; t < n; ++t) {
          if (t == s || !in_solve[t] || !maps[t]) continue;
          const int anchor = nearestKeyframe(poses[t], in_atlas);
          const Eigen::Isometry3d T_odometry_anchor =
              problem.sessions[t]->keyframes[anchor].T_frame_body;
          const Eigen::Vector3d in_odometry_t =
              T_odometry_anchor * (toIsometry(poses[t][anchor]).inverse() * in_atlas);
          if (!coveredAround(*maps[t], in_odometry_t.head<2>()) ||
              heightsDiffer(problem, s, t, in_odometry_t.z()))
            continue;
          PoseBlock& other = poses[t][anchor];
          if (!ceres_problem.HasParameterBlock(other.q.coeffs().data())) continue;
          ceres_problem.AddResidualBlock(
              MagneticMapCost::Create(*maps[t], reading.sensor_in_keyframe, T_odometry_anchor,
                                      reading.fingerprint_uT, config.magnetic_sigma_uT),
              new ceres::HuberLoss(config.magnetic_loss_scale), own.p.data(), own.q.coeffs().data(),
              other.p.data(), other.q.coeffs().data(), field_offsets[s].data(),
              field_offsets[t].data());
          ++magnetic_residuals;
        }
      }
    }
    for (std::size_t s = 0; s < n; ++s)
      if (ceres_problem.HasParameterBlock(field_offsets[s].data()))
        ceres_problem.AddResidualBlock(
            new ceres::AutoDiffCostFunction<internal::OffsetPriorCost, 2, 2>(
                new internal::OffsetPriorCost(kFieldOffsetPriorUT)),
            nullptr, field_offsets[s].data());
    // A root session of one keyframe and no edges has no residual on its first pose yet.
    if (!ceres_problem.HasParameterBlock(poses[gauge][0].p.data())) {
      ceres_problem.AddParameterBlock(poses[gauge][0].p.data(), 3);
      ceres_problem.AddParameterBlock(poses[gauge][0].q.coeffs().data(), 4, &quaternion_manifold);
    }
    ceres_problem.SetParameterBlockConstant(poses[gauge][0].p.data());
    ceres_problem.SetParameterBlockConstant(poses[gauge][0].q.coeffs().data());

    ceres::Solver::Options options;
    options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
    options.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
    options.max_num_iterations = config.max_iterations;
    options.num_threads = config.threads;
    ceres::Solver::Summary summary;
    ceres::Solve(options, &ceres_problem, &summary);
    if (summary.termination_type == ceres::FAILURE)
      throw std::runtime_error("solveMultiSessionGraph: the solver failed: " + summary.message);
    if (round == 0) solution.initial_cost = summary.initial_cost;
    solution.final_cost = summary.final_cost;
    solution.iterations += static_cast<int>(summary.iterations.size());
    solution.converged = summary.termination_type == ceres::CONVERGENCE;
    solution.magnetic_residuals = magnetic_residuals;

    bool dropped = false;
    for (std::size_t e = 0; e < problem.edges.size(); ++e) {
      const InterSessionEdge& edge = problem.edges[e];
      if (!solution.edge_kept[e] || !in_solve[edge.session_a] || !in_solve[edge.session_b])
        continue;
      solution.edge_chi2[e] = whitenedSquaredError(edge, poses);
      if (solution.edge_chi2[e] > config.max_inter_session_chi2 &&
          round < config.max_outlier_rounds) {
        solution.edge_kept[e] = false;
        dropped = true;
      }
    }
    if (!dropped) break;
    in_solve = reachableSessions(problem, solution.edge_kept);
  }

  // Edges with an end outside the final solve took no part in it.
  for (std::size_t e = 0; e < problem.edges.size(); ++e)
    if (!in_solve[problem.edges[e].session_a] || !in_solve[problem.edges[e].session_b])
      solution.edge_kept[e] = false;
  solution.T_atlas_keyframe.resize(n);
  solution.T_atlas_session.assign(n, Eigen::Isometry3d::Identity());
  solution.connected = in_solve;
  for (std::size_t s = 0; s < n; ++s) {
    const auto& keyframes = problem.sessions[s]->keyframes;
    for (std::size_t k = 0; k < keyframes.size(); ++k)
      solution.T_atlas_keyframe[s].push_back(in_solve[s] ? toIsometry(poses[s][k])
                                                         : keyframes[k].T_frame_body);
    if (in_solve[s])
      solution.T_atlas_session[s] =
          solution.T_atlas_keyframe[s].front() * keyframes.front().T_frame_body.inverse();
  }
  solution.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return solution;
}

}  // namespace mm4mm
