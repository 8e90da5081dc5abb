#include "mm4mm/magnetic/self_calibration.hpp"

#include <ceres/ceres.h>

#include <Eigen/LU>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <stdexcept>
#include <utility>

#include "mm4mm/geometry/pose.hpp"
#include "mm4mm/magnetic/magnetic_map.hpp"

namespace mm4mm {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr int kHeadingSectors = 8;
// The soft iron's six distinct entries, in this order.
enum SoftIronEntry { kXX, kYY, kZZ, kXY, kXZ, kYZ };
// Far stronger than any data term: holds the soft iron's trace at its identity value (the unit
// gauge, see the header) without a constrained solver.
constexpr double kTraceWeight = 1e3;

Eigen::Matrix3d softIronOf(const double* s) {
  Eigen::Matrix3d S;
  S << s[kXX], s[kXY], s[kXZ], s[kXY], s[kYY], s[kYZ], s[kXZ], s[kYZ], s[kZZ];
  return S;
}

// A reading's place on the node grid: the four nodes around it and their bilinear weights.
struct Support {
  std::array<std::size_t, 4> node{};
  std::array<double, 4> weight{};
};

// Nodes at (i, j) · cell, created where a reading needs them, numbered in order of creation so
// that the same readings give the same problem.
class NodeGrid {
 public:
  explicit NodeGrid(double cell_m) : cell_(cell_m) {}

  Support supportOf(const Eigen::Vector2d& p) {
    const Eigen::Vector2d g = p / cell_;
    const long i = static_cast<long>(std::floor(g.x())), j = static_cast<long>(std::floor(g.y()));
    const double fx = g.x() - i, fy = g.y() - j;
    Support s;
    const long di[4] = {0, 1, 0, 1}, dj[4] = {0, 0, 1, 1};
    const double w[4] = {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy};
    for (int k = 0; k < 4; ++k) {
      s.node[k] = nodeAt(i + di[k], j + dj[k]);
      s.weight[k] = w[k];
    }
    return s;
  }
  std::size_t size() const { return keys_.size(); }
  const std::pair<long, long>& key(std::size_t n) const { return keys_[n]; }
  // -1 when the node does not exist.
  long find(long i, long j) const {
    const auto it = index_.find({i, j});
    return it == index_.end() ? -1 : static_cast<long>(it->second);
  }

 private:
  std::size_t nodeAt(long i, long j) {
    const auto [it, inserted] = index_.try_emplace({i, j}, keys_.size());
    if (inserted) keys_.emplace_back(i, j);
    return it->second;
  }

  double cell_;
  std::map<std::pair<long, long>, std::size_t> index_;
  std::vector<std::pair<long, long>> keys_;
};

// A reading kept for the solve.
struct Reading {
  int sensor = 0;
  Eigen::Matrix3d R_frame_body;
  Eigen::Vector3d reading_uT;
  double speed_mps = 0.0;
  Support support;
  double heading_rad = 0.0;
};

// Residual of one reading, in units of the noise scale:
//   r = (S · Rᵀ · Σ_k w_k f_k + h + v · k − m) / σ
// over the blocks [soft iron (6), hard iron (3), speed term (3), f_0 … f_3 (3 each)].
// Jacobians: ∂r/∂h = I/σ, ∂r/∂k = v I/σ, ∂r/∂f_k = w_k S Rᵀ/σ, and with g = Rᵀ f the soft
// iron's entries enter as ∂(S g)/∂S_xx = (g_x, 0, 0), ∂/∂S_xy = (g_y, g_x, 0), and so on.
class ReadingCost : public ceres::SizedCostFunction<3, 6, 3, 3, 3, 3, 3, 3> {
 public:
  ReadingCost(const Reading& reading, double sigma_uT)
      : Rt_(reading.R_frame_body.transpose()),
        m_(reading.reading_uT),
        v_(reading.speed_mps),
        w_(reading.support.weight),
        inv_sigma_(1.0 / sigma_uT) {}

  bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
    const Eigen::Matrix3d S = softIronOf(p[0]);
    const Eigen::Map<const Eigen::Vector3d> h(p[1]), k(p[2]);
    Eigen::Vector3d f = Eigen::Vector3d::Zero();
    for (int n = 0; n < 4; ++n) f += w_[n] * Eigen::Map<const Eigen::Vector3d>(p[3 + n]);
    const Eigen::Vector3d g = Rt_ * f;
    Eigen::Map<Eigen::Vector3d> r(residuals);
    r = inv_sigma_ * (S * g + h + v_ * k - m_);
    if (!jacobians) return true;
    if (jacobians[0]) {
      Eigen::Map<Eigen::Matrix<double, 3, 6, Eigen::RowMajor>> J(jacobians[0]);
      J.setZero();
      J(0, kXX) = g.x();
      J(1, kYY) = g.y();
      J(2, kZZ) = g.z();
      J(0, kXY) = g.y(), J(1, kXY) = g.x();
      J(0, kXZ) = g.z(), J(2, kXZ) = g.x();
      J(1, kYZ) = g.z(), J(2, kYZ) = g.y();
      J *= inv_sigma_;
    }
    using Block = Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>;
    if (jacobians[1]) {
      Block J(jacobians[1]);
      J = inv_sigma_ * Eigen::Matrix3d::Identity();
    }
    if (jacobians[2]) {
      Block J(jacobians[2]);
      J = (inv_sigma_ * v_) * Eigen::Matrix3d::Identity();
    }
    const Eigen::Matrix3d SRt = S * Rt_;
    for (int n = 0; n < 4; ++n)
      if (jacobians[3 + n]) {
        Block J(jacobians[3 + n]);
        J = (inv_sigma_ * w_[n]) * SRt;
      }
    return true;
  }

 private:
  Eigen::Matrix3d Rt_;
  Eigen::Vector3d m_;
  double v_;
  std::array<double, 4> w_;
  double inv_sigma_;
};

// (a − b) / σ: neighbouring field nodes differ by about σ.
class DifferenceCost : public ceres::SizedCostFunction<3, 3, 3> {
 public:
  explicit DifferenceCost(double sigma) : inv_sigma_(1.0 / sigma) {}
  bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
    for (int i = 0; i < 3; ++i) residuals[i] = inv_sigma_ * (p[0][i] - p[1][i]);
    if (!jacobians) return true;
    for (int b = 0; b < 2; ++b)
      if (jacobians[b]) {
        Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> J(jacobians[b]);
        J = (b == 0 ? inv_sigma_ : -inv_sigma_) * Eigen::Matrix3d::Identity();
      }
    return true;
  }

 private:
  double inv_sigma_;
};

// (x − x0) / σ for a block of N values.
template <int N>
class PriorCost : public ceres::SizedCostFunction<N, N> {
 public:
  PriorCost(const Eigen::Matrix<double, N, 1>& x0, double sigma) : x0_(x0), inv_sigma_(1.0 / sigma) {}
  bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
    for (int i = 0; i < N; ++i) residuals[i] = inv_sigma_ * (p[0][i] - x0_[i]);
    if (jacobians && jacobians[0]) {
      Eigen::Map<Eigen::Matrix<double, N, N, Eigen::RowMajor>> J(jacobians[0]);
      J = inv_sigma_ * Eigen::Matrix<double, N, N>::Identity();
    }
    return true;
  }

 private:
  Eigen::Matrix<double, N, 1> x0_;
  double inv_sigma_;
};

// w · (trace of the soft iron's estimated diagonal − its identity value).
class TraceCost : public ceres::SizedCostFunction<1, 6> {
 public:
  explicit TraceCost(bool vertical) : vertical_(vertical) {}
  bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
    const double* s = p[0];
    residuals[0] = kTraceWeight * (s[kXX] + s[kYY] + (vertical_ ? s[kZZ] : 0.0) -
                                   (vertical_ ? 3.0 : 2.0));
    if (jacobians && jacobians[0]) {
      std::fill(jacobians[0], jacobians[0] + 6, 0.0);
      jacobians[0][kXX] = jacobians[0][kYY] = kTraceWeight;
      if (vertical_) jacobians[0][kZZ] = kTraceWeight;
    }
    return true;
  }

 private:
  bool vertical_;
};

// A sensor's unknowns, laid out as Ceres blocks.
struct SensorBlocks {
  std::array<double, 6> soft{1, 1, 1, 0, 0, 0};
  Eigen::Vector3d hard = Eigen::Vector3d::Zero();
  Eigen::Vector3d speed = Eigen::Vector3d::Zero();
};

// Readings of the sensors to estimate, thinned per sensor: one per `spacing` of travel or
// `turn` of heading (a robot standing still adds nothing new; one turning in place adds the most).
std::vector<Reading> keptReadings(const std::vector<PlacedReading>& placed,
                                  const std::vector<bool>& estimate, const CalibrationConfig& config,
                                  NodeGrid* grid) {
  std::vector<Reading> kept;
  std::vector<const PlacedReading*> last(estimate.size(), nullptr);
  for (const PlacedReading& r : placed) {
    if (!estimate[r.sensor]) continue;
    const PlacedReading* previous = last[r.sensor];
    if (previous) {
      const double travel = (r.position_m - previous->position_m).head<2>().norm();
      const double turn =
          std::abs(wrapAngle(yawOf(r.R_frame_body) - yawOf(previous->R_frame_body)));
      if (travel < config.sample_spacing_m && turn < config.sample_turn_deg * kDeg) continue;
    }
    last[r.sensor] = &r;
    Reading k;
    k.sensor = r.sensor;
    k.R_frame_body = r.R_frame_body;
    k.reading_uT = r.reading_uT;
    k.speed_mps = r.speed_mps;
    k.support = grid->supportOf(r.position_m.head<2>());
    k.heading_rad = yawOf(r.R_frame_body);
    kept.push_back(k);
  }
  return kept;
}

// Per sensor, the nodes that readings of headings at least `apart_rad` apart touch.
std::vector<int> revisitedNodes(const std::vector<Reading>& readings, std::size_t nodes,
                                int sensors, double apart_rad) {
  std::vector<std::vector<std::uint8_t>> sectors(sensors, std::vector<std::uint8_t>(nodes, 0));
  for (const Reading& r : readings) {
    const int sector = static_cast<int>(std::floor((wrapAngle(r.heading_rad) + M_PI) /
                                                   (2.0 * M_PI) * kHeadingSectors)) %
                       kHeadingSectors;
    for (int k = 0; k < 4; ++k)
      if (r.support.weight[k] > 0.1) sectors[r.sensor][r.support.node[k]] |= 1u << sector;
  }
  const int apart = static_cast<int>(std::ceil(apart_rad / (2.0 * M_PI / kHeadingSectors) - 1e-9));
  std::vector<int> count(sensors, 0);
  for (int s = 0; s < sensors; ++s)
    for (std::uint8_t mask : sectors[s]) {
      bool found = false;
      for (int a = 0; a < kHeadingSectors && !found; ++a)
        for (int b = a + 1; b < kHeadingSectors && !found; ++b) {
          const int d = std::min(b - a, kHeadingSectors - (b - a));
          found = d >= apart && (mask >> a & 1u) && (mask >> b & 1u);
        }
      count[s] += found ? 1 : 0;
    }
  return count;
}

double tiltStdDeg(const std::vector<Reading>& readings) {
  if (readings.empty()) return 0.0;
  double sum = 0.0;
  for (const Reading& r : readings) {
    const double tilt = std::acos(std::clamp(r.R_frame_body(2, 2), -1.0, 1.0));
    sum += tilt * tilt;
  }
  return std::sqrt(sum / readings.size()) / kDeg;
}

// Per sensor, the RMS per axis of the readings' residuals (µT) at the current blocks.
std::vector<double> residualRms(const std::vector<Reading>& readings,
                                const std::vector<SensorBlocks>& blocks,
                                const std::vector<Eigen::Vector3d>& field, int sensors) {
  std::vector<double> sum(sensors, 0.0);
  std::vector<int> count(sensors, 0);
  for (const Reading& r : readings) {
    const SensorBlocks& b = blocks[r.sensor];
    Eigen::Vector3d f = Eigen::Vector3d::Zero();
    for (int k = 0; k < 4; ++k) f += r.support.weight[k] * field[r.support.node[k]];
    const Eigen::Vector3d e = softIronOf(b.soft.data()) * r.R_frame_body.transpose() * f + b.hard +
                              r.speed_mps * b.speed - r.reading_uT;
    sum[r.sensor] += e.squaredNorm() / 3.0;
    ++count[r.sensor];
  }
  std::vector<double> rms(sensors, 0.0);
  for (int s = 0; s < sensors; ++s) rms[s] = count[s] ? std::sqrt(sum[s] / count[s]) : 0.0;
  return rms;
}

}  // namespace

std::string toString(CalibrationSource source) {
  switch (source) {
    case CalibrationSource::kGiven:
      return "given";
    case CalibrationSource::kEstimated:
      return "estimated";
    case CalibrationSource::kNotObservable:
      return "not observable";
    case CalibrationSource::kDisabled:
      return "disabled";
  }
  return "unknown";
}

bool CalibrationConfig::IsValid(std::string* error) const {
  const auto fail = [&](const char* message) {
    if (error) *error = message;
    return false;
  };
  if (!(field_cell_size_m > 0.0)) return fail("calibration.field_cell_size_m must be > 0");
  if (!(sample_spacing_m >= 0.0) || !(sample_turn_deg >= 0.0))
    return fail("calibration.sample_spacing_m and sample_turn_deg must be >= 0");
  if (!(noise_uT > 0.0) || !(smoothness_uT > 0.0) || !(anomaly_uT > 0.0))
    return fail("calibration.noise_uT, smoothness_uT and anomaly_uT must be > 0");
  if (!(hard_iron_prior_uT > 0.0) || !(soft_iron_prior > 0.0) || !(speed_prior_uT_per_mps > 0.0))
    return fail("calibration priors must be > 0");
  if (!(min_tilt_deg >= 0.0)) return fail("calibration.min_tilt_deg must be >= 0");
  if (!(min_speed_spread_mps >= 0.0))
    return fail("calibration.min_speed_spread_mps must be >= 0");
  if (!(revisit_heading_deg > 0.0 && revisit_heading_deg <= 180.0))
    return fail("calibration.revisit_heading_deg must be in (0, 180]");
  if (min_readings < 10) return fail("calibration.min_readings must be >= 10");
  if (!(max_heading_resultant > 0.0 && max_heading_resultant <= 1.0))
    return fail("calibration.max_heading_resultant must be in (0, 1]");
  if (max_iterations < 1) return fail("calibration.max_iterations must be >= 1");
  return true;
}

std::vector<MagnetometerCalibration> SessionCalibration::calibrations() const {
  std::vector<MagnetometerCalibration> out;
  for (const SensorCalibration& s : sensors) out.push_back(s.calibration);
  return out;
}

SessionCalibration calibrateMagnetometers(const Session& session, const CalibrationConfig& config) {
  std::string error;
  if (!config.IsValid(&error)) throw std::invalid_argument("calibrateMagnetometers: " + error);
  const auto start = std::chrono::steady_clock::now();
  const int sensors = static_cast<int>(session.rig.magnetometers_body.size());
  SessionCalibration result;
  result.sensors.resize(sensors);
  std::vector<bool> estimate(sensors, false);
  for (int s = 0; s < sensors; ++s) {
    SensorCalibration& out = result.sensors[s];
    if (static_cast<std::size_t>(s) < session.rig.calibrations.size() &&
        session.rig.calibrations[s]) {
      out.calibration = *session.rig.calibrations[s];
      out.source = CalibrationSource::kGiven;
      out.note = "stated in session.yaml";
    } else if (!config.enabled) {
      out.source = CalibrationSource::kDisabled;
      out.note = "estimation disabled; uncalibrated";
    } else {
      estimate[s] = true;
    }
  }
  const auto finish = [&] {
    result.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return result;
  };
  if (std::none_of(estimate.begin(), estimate.end(), [](bool e) { return e; })) return finish();

  NodeGrid grid(config.field_cell_size_m);
  std::vector<Reading> readings =
      keptReadings(placeReadings(session), estimate, config, &grid);
  const std::vector<int> revisited =
      revisitedNodes(readings, grid.size(), sensors, config.revisit_heading_deg * kDeg);
  // A hard iron turns with the body: it shows only against readings at other headings. A sensor
  // whose headings hardly vary (a straight drive) cannot be calibrated from its own data.
  std::vector<Eigen::Vector2d> heading_sum(sensors, Eigen::Vector2d::Zero());
  std::vector<int> heading_count(sensors, 0);
  for (const Reading& r : readings) {
    heading_sum[r.sensor] += Eigen::Vector2d(std::cos(r.heading_rad), std::sin(r.heading_rad));
    ++heading_count[r.sensor];
  }
  for (int s = 0; s < sensors; ++s) {
    if (!estimate[s]) continue;
    result.sensors[s].revisited_nodes = revisited[s];
    const double resultant =
        heading_count[s] ? heading_sum[s].norm() / heading_count[s] : 1.0;
    if (heading_count[s] < config.min_readings || resultant > config.max_heading_resultant) {
      estimate[s] = false;
      result.sensors[s].source = CalibrationSource::kNotObservable;
      char text[160];
      std::snprintf(text, sizeof text,
                    "%d readings whose headings hardly vary (mean resultant length %.2f > %.2f); "
                    "uncalibrated",
                    heading_count[s], resultant, config.max_heading_resultant);
      result.sensors[s].note = text;
    }
  }
  // The solve uses only the sensors it can calibrate: the others would add field nodes whose
  // values their unknown offsets could bend.
  std::vector<Reading> used;
  for (const Reading& r : readings)
    if (estimate[r.sensor]) used.push_back(r);
  if (used.empty()) return finish();
  const bool vertical = tiltStdDeg(used) >= config.min_tilt_deg;
  double speed_sum = 0.0, speed_squares = 0.0;
  for (const Reading& r : used) speed_sum += r.speed_mps, speed_squares += r.speed_mps * r.speed_mps;
  const double speed_mean = speed_sum / used.size();
  const bool with_speed =
      config.estimate_speed_term &&
      std::sqrt(std::max(0.0, speed_squares / used.size() - speed_mean * speed_mean)) >=
          config.min_speed_spread_mps;

  // Field nodes start at the mean of the readings turned into the session frame.
  std::vector<Eigen::Vector3d> field(grid.size(), Eigen::Vector3d::Zero());
  std::vector<double> weight(grid.size(), 0.0);
  for (const Reading& r : used)
    for (int k = 0; k < 4; ++k) {
      field[r.support.node[k]] += r.support.weight[k] * (r.R_frame_body * r.reading_uT);
      weight[r.support.node[k]] += r.support.weight[k];
    }
  for (std::size_t n = 0; n < field.size(); ++n)
    if (weight[n] > 0.0) field[n] /= weight[n];
  std::vector<SensorBlocks> blocks(sensors);

  ceres::Problem::Options problem_options;
  problem_options.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  problem_options.loss_function_ownership = ceres::TAKE_OWNERSHIP;
  problem_options.manifold_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  for (const Reading& r : used) {
    SensorBlocks& b = blocks[r.sensor];
    problem.AddResidualBlock(new ReadingCost(r, config.noise_uT), new ceres::HuberLoss(1.0),
                             {b.soft.data(), b.hard.data(), b.speed.data(),
                              field[r.support.node[0]].data(), field[r.support.node[1]].data(),
                              field[r.support.node[2]].data(), field[r.support.node[3]].data()});
  }
  // The field is the Earth's, common to the whole route, plus anomalies of a few µT: each node is
  // drawn towards the route's mean field. This is what makes the mean over a long route the
  // Earth's, and what lets readings at many headings along the route fix the hard iron even where
  // the route never passes one place twice.
  Eigen::Vector3d mean_field = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& f : field) mean_field += f;
  mean_field /= static_cast<double>(field.size());
  for (std::size_t n = 0; n < grid.size(); ++n)
    problem.AddResidualBlock(new DifferenceCost(config.anomaly_uT), nullptr, field[n].data(),
                             mean_field.data());
  for (std::size_t n = 0; n < grid.size(); ++n) {
    const auto [i, j] = grid.key(n);
    for (const auto& [di, dj] : {std::pair<long, long>{1, 0}, {0, 1}}) {
      const long m = grid.find(i + di, j + dj);
      if (m >= 0)
        problem.AddResidualBlock(new DifferenceCost(config.smoothness_uT), nullptr,
                                 field[n].data(), field[static_cast<std::size_t>(m)].data());
    }
  }
  Eigen::Matrix<double, 6, 1> identity_soft;
  identity_soft << 1, 1, 1, 0, 0, 0;
  for (int s = 0; s < sensors; ++s) {
    if (!estimate[s]) continue;
    SensorBlocks& b = blocks[s];
    problem.AddResidualBlock(new PriorCost<6>(identity_soft, config.soft_iron_prior), nullptr,
                             b.soft.data());
    problem.AddResidualBlock(new PriorCost<3>(Eigen::Vector3d::Zero(), config.hard_iron_prior_uT),
                             nullptr, b.hard.data());
    problem.AddResidualBlock(
        new PriorCost<3>(Eigen::Vector3d::Zero(), config.speed_prior_uT_per_mps), nullptr,
        b.speed.data());
    problem.AddResidualBlock(new TraceCost(vertical), nullptr, b.soft.data());
  }

  ceres::Solver::Options options;
  options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  options.max_num_iterations = config.max_iterations;
  options.num_threads = 1;  // the same answer whatever the machine
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;

  // First the field alone, uncalibrated: the readings' disagreement with themselves before.
  for (int s = 0; s < sensors; ++s) {
    if (!estimate[s]) continue;
    problem.SetParameterBlockConstant(blocks[s].soft.data());
    problem.SetParameterBlockConstant(blocks[s].hard.data());
    problem.SetParameterBlockConstant(blocks[s].speed.data());
  }
  ceres::Solver::Options field_only = options;
  field_only.max_num_iterations = std::min(options.max_num_iterations, 5);  // nearly linear
  ceres::Solve(field_only, &problem, &summary);
  const std::vector<double> before = residualRms(used, blocks, field, sensors);

  // A level body's vertical offset and gain look like the field's own B_z: one sensor (the
  // first estimated) holds them; the others' are fixed relative to it by the places they share.
  int reference = -1;
  for (int s = 0; s < sensors && reference < 0; ++s)
    if (estimate[s]) reference = s;
  for (int s = 0; s < sensors; ++s) {
    if (!estimate[s]) continue;
    SensorBlocks& b = blocks[s];
    problem.SetParameterBlockVariable(b.soft.data());
    problem.SetParameterBlockVariable(b.hard.data());
    if (with_speed) problem.SetParameterBlockVariable(b.speed.data());
    if (!vertical) {
      if (s == reference) {
        problem.SetManifold(b.soft.data(), new ceres::SubsetManifold(6, {kZZ}));
        problem.SetManifold(b.hard.data(), new ceres::SubsetManifold(3, {2}));
        if (with_speed) problem.SetManifold(b.speed.data(), new ceres::SubsetManifold(3, {2}));
      } else {
        problem.SetManifold(b.soft.data(), new ceres::SubsetManifold(6, {kZZ}));
      }
    }
  }
  ceres::Solve(options, &problem, &summary);
  if (std::getenv("MM4MM_DEBUG_CALIBRATION")) std::fprintf(stderr, "%s\n", summary.FullReport().c_str());
  const std::vector<double> after = residualRms(used, blocks, field, sensors);

  // The unit: the route's mean horizontal field against the site's Earth field, where known.
  double scale = 1.0;
  const std::optional<double> earth = session.rig.earth_field_horizontal_uT;
  if (earth) {
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (const Reading& r : used) {
      Eigen::Vector3d f = Eigen::Vector3d::Zero();
      for (int k = 0; k < 4; ++k) f += r.support.weight[k] * field[r.support.node[k]];
      mean += f.head<2>();
    }
    mean /= static_cast<double>(used.size());
    if (mean.norm() > 1e-6) scale = mean.norm() / *earth;
  }

  for (int s = 0; s < sensors; ++s) {
    if (!estimate[s]) continue;
    SensorCalibration& out = result.sensors[s];
    const SensorBlocks& b = blocks[s];
    out.source = CalibrationSource::kEstimated;
    out.vertical_estimated = vertical;
    out.scaled_to_earth_field = earth.has_value();
    out.calibration.soft_iron = scale * softIronOf(b.soft.data());
    out.calibration.hard_iron_uT = b.hard;
    out.calibration.speed_uT_per_mps = b.speed;
    out.residual_before_uT = before[s];
    out.residual_after_uT = after[s];
    out.readings = static_cast<int>(std::count_if(
        used.begin(), used.end(), [&](const Reading& r) { return r.sensor == s; }));
    out.speed_estimated = with_speed;
    std::vector<std::string> notes;
    if (!vertical)
      notes.push_back(s == reference ? "level body: vertical offset and gain held at 0 and 1"
                                     : "level body: vertical gain held at 1, offset relative to "
                                       "magnetometer " + std::to_string(reference));
    if (!with_speed) notes.push_back("speed hardly varies: speed term folded into the hard iron");
    if (!earth)
      notes.push_back(std::string("no earth_field given: soft iron's unit kept at trace ") +
                      (vertical ? "3" : "2 (horizontal)"));
    for (const std::string& n : notes) out.note += (out.note.empty() ? "" : "; ") + n;
  }
  return finish();
}

}  // namespace mm4mm
