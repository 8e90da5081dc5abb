#include "mm4mm/magnetic/match_score.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "mm4mm/magnetic/correlation_search.hpp"

namespace mm4mm {

bool MatchScoreConfig::IsValid(std::string* error) const {
  const auto fail = [&](const char* m) {
    if (error) *error = m;
    return false;
  };
  if (const char* problem = sampleCountProblem(min_overlap_m2, area_per_sample_m2))
    return fail(problem);
  if (stride < 1) return fail("stride must be >= 1");
  if (!(association_tolerance_uT > 0.0)) return fail("association_tolerance_uT must be > 0");
  if (!(sigma_B_uT > 0.0)) return fail("sigma_B_uT must be > 0");
  return true;
}

// Bilinear blend of map a at a point (m), when all four surrounding cell centres are covered.
bool MatchScorer::lookUp(const Eigen::Vector2d& p, double* values, double* total) const {
  const Eigen::Vector2d c = (p - a_.origin_m) / a_.cell_size_m - Eigen::Vector2d(0.5, 0.5);
  const int ix = static_cast<int>(std::floor(c.x())), iy = static_cast<int>(std::floor(c.y()));
  if (ix < 0 || iy < 0 || ix + 1 >= a_.width || iy + 1 >= a_.height) return false;
  const Cell* row = a_cells_->data() + a_.index(ix, iy);
  const Cell* corners[4] = {row, row + 1, row + a_.width, row + a_.width + 1};
  for (const Cell* corner : corners)
    if (std::isnan(corner->total)) return false;
  const double fx = c.x() - ix, fy = c.y() - iy;
  const double w[4] = {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy};
  *total = 0.0;
  for (int k = 0; k < 4; ++k) {
    for (int c2 = 0; c2 < channels_; ++c2)
      values[c2] = (k == 0 ? 0.0 : values[c2]) + w[k] * corners[k]->values[c2];
    *total += w[k] * corners[k]->total;
  }
  return true;
}

MatchScorer::MatchScorer(const MagneticMap& a, const MagneticMap& b, const MatchScoreConfig& config)
    : a_(a), b_(b), config_(config) {
  std::string error;
  if (!config.IsValid(&error)) throw std::invalid_argument(error);
  channels_ = channelCount(config.channels);
  double values[kMaxValues];
  auto cells = std::make_shared<std::vector<Cell>>(a.total_uT.size());
  for (std::size_t i = 0; i < cells->size(); ++i) {
    Cell& cell = (*cells)[i];
    cell.total = a.total_uT[i];
    if (std::isnan(cell.total)) continue;
    channelValues(a, i, config.channels, 0.0, values);
    std::copy(values, values + channels_, cell.values);
  }
  a_cells_ = std::move(cells);
  for (int iy = 0; iy < b.height; iy += config.stride)
    for (int ix = 0; ix < b.width; ix += config.stride)
      if (b.covered(ix, iy)) {
        Sample s{b.cellCentre(ix, iy), b.index(ix, iy), {}, b.total_uT[b.index(ix, iy)]};
        channelValues(b, s.index, config.channels, 0.0, values);
        std::copy(values, values + channels_, s.values);
        samples_.push_back(s);
      }
  area_per_sample_m2_ = std::pow(config.stride * b.cell_size_m, 2);
  fingerprints_a_ = a.coveredCells();
  fingerprints_b_ = b.coveredCells();
}

MatchScorer MatchScorer::focusedOn(const PlanarTransform& T_a_b, double margin_m) const {
  // Distance from a's coverage, coarsely: a cell of size margin is near when it or one of its
  // eight neighbours holds a covered fine cell.
  const double coarse = std::max(margin_m, a_.cell_size_m);
  const int factor = std::max(1, static_cast<int>(std::ceil(coarse / a_.cell_size_m)));
  const int w = (a_.width + factor - 1) / factor, h = (a_.height + factor - 1) / factor;
  std::vector<char> near(static_cast<std::size_t>(w) * h, 0);
  for (int iy = 0; iy < a_.height; ++iy)
    for (int ix = 0; ix < a_.width; ++ix) {
      if (!a_.covered(ix, iy)) continue;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int cx = ix / factor + dx, cy = iy / factor + dy;
          if (cx >= 0 && cy >= 0 && cx < w && cy < h)
            near[static_cast<std::size_t>(cy) * w + cx] = 1;
        }
    }
  MatchScorer focused = *this;
  focused.samples_.clear();
  const double cell = a_.cell_size_m * factor;
  for (const Sample& s : samples_) {
    const Eigen::Vector2d c = (T_a_b.apply(s.position) - a_.origin_m) / cell;
    const int cx = static_cast<int>(std::floor(c.x())), cy = static_cast<int>(std::floor(c.y()));
    if (cx >= 0 && cy >= 0 && cx < w && cy < h && near[static_cast<std::size_t>(cy) * w + cx])
      focused.samples_.push_back(s);
  }
  return focused;
}

double MatchScorer::sampleReach() const {
  double reach = 0.0;
  for (const Sample& s : samples_) reach = std::max(reach, s.position.norm());
  return reach;
}

Eigen::Vector2d MatchScorer::overlapCentroid(const PlanarTransform& T_a_b) const {
  return overlapStatistics(T_a_b).centroid;
}

OverlapStatistics MatchScorer::overlapStatistics(const PlanarTransform& T_a_b) const {
  OverlapStatistics stats;
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  Eigen::Matrix2d outer = Eigen::Matrix2d::Zero();
  double value_sum[kMaxValues] = {}, value_squares = 0.0;
  double values[kMaxValues], total = 0.0;
  for (const Sample& s : samples_) {
    if (!lookUp(T_a_b.apply(s.position), values, &total)) continue;
    ++stats.cells;
    sum += s.position;
    outer += s.position * s.position.transpose();
    for (int c = 0; c < channels_; ++c) {
      value_sum[c] += s.values[c];
      value_squares += static_cast<double>(s.values[c]) * s.values[c];
    }
  }
  if (stats.cells == 0) return stats;
  const double n = stats.cells;
  stats.centroid = sum / n;
  const Eigen::Matrix2d covariance = outer / n - stats.centroid * stats.centroid.transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(covariance);
  stats.length_m = 4.0 * std::sqrt(std::max(0.0, eigen.eigenvalues()(1)));
  stats.width_m = 4.0 * std::sqrt(std::max(0.0, eigen.eigenvalues()(0)));
  // Each channel about its own mean: the offsets between channels are not field to match.
  double spread = value_squares;
  for (int c = 0; c < channels_; ++c) spread -= value_sum[c] * value_sum[c] / n;
  stats.field_std_uT = std::sqrt(std::max(0.0, spread / (n * std::max(channels_, 1))));
  return stats;
}

MatchScore MatchScorer::evaluate(const PlanarTransform& T_a_b) const {
  const Eigen::Rotation2Dd R(T_a_b.yaw_rad);
  const Eigen::Vector2d t(T_a_b.x_m, T_a_b.y_m);
  double va[kMaxValues], vb[kMaxValues];
  double sum_a[kMaxValues] = {}, sum_b[kMaxValues] = {};
  double sum_aa = 0, sum_bb = 0, sum_ab = 0;
  // Paper terms: distance statistics and the |B| association count.
  double sum_d = 0, sum_dd = 0, sum_log_likelihood = 0;
  int associated = 0, n = 0;
  const int channels = channels_;
  const double sigma2 = config_.sigma_B_uT * config_.sigma_B_uT;
  // As channelValues turns b's session-frame components by the candidate yaw.
  const bool turned = config_.channels == MatchChannels::kRotatedVector;
  const double cos_yaw = std::cos(T_a_b.yaw_rad), sin_yaw = std::sin(T_a_b.yaw_rad);
  for (const Sample& s : samples_) {
    double total_a = 0.0;
    if (!lookUp(R * s.position + t, va, &total_a)) continue;
    for (int c = 0; c < channels; ++c) vb[c] = s.values[c];
    if (turned) {
      vb[0] = cos_yaw * s.values[0] - sin_yaw * s.values[1];
      vb[1] = sin_yaw * s.values[0] + cos_yaw * s.values[1];
    }
    ++n;
    double d2 = 0.0;
    for (int c = 0; c < channels; ++c) {
      sum_a[c] += va[c], sum_b[c] += vb[c];
      sum_aa += va[c] * va[c], sum_bb += vb[c] * vb[c], sum_ab += va[c] * vb[c];
      d2 += (va[c] - vb[c]) * (va[c] - vb[c]);
    }
    const double total_b = s.total;
    d2 += (total_a - total_b) * (total_a - total_b);
    sum_d += std::sqrt(d2), sum_dd += d2;
    sum_log_likelihood += -0.5 * d2 / sigma2;
    if (std::abs(total_a - total_b) <= config_.association_tolerance_uT) ++associated;
  }

  MatchScore score;
  score.pairs = n;
  score.overlap_m2 = n * area_per_sample_m2_;
  constexpr double kWorst = -std::numeric_limits<double>::infinity();
  if (score.overlap_m2 < config_.min_overlap_m2 || n < 2) {
    score.value = kWorst;
    return score;
  }
  double cov = sum_ab, var_a = sum_aa, var_b = sum_bb, mean_difference_squared = 0.0;
  for (int c = 0; c < channels; ++c) {
    cov -= sum_a[c] * sum_b[c] / n;
    var_a -= sum_a[c] * sum_a[c] / n;
    var_b -= sum_b[c] * sum_b[c] / n;
    mean_difference_squared += std::pow((sum_a[c] - sum_b[c]) / n, 2);
  }
  score.r = correlationOf(config_.statistic, cov, var_a, var_b, mean_difference_squared, n);
  score.samples = score.overlap_m2 / config_.area_per_sample_m2;
  score.z = correlationZ(score.r, score.samples);
  switch (config_.kind) {
    case MatchScoreKind::kCorrelation:
      score.value = score.z;
      break;
    case MatchScoreKind::kPaperFitness: {
      // Eq. 4 over the pairs, Eq. 5 over the fingerprints of both maps at the sampled stride.
      const double variance = sum_dd / n - (sum_d / n) * (sum_d / n);
      const double share = associated / (static_cast<double>(fingerprints_a_ + fingerprints_b_) /
                                         (config_.stride * config_.stride));
      score.value = share > 0.0 ? -variance / std::sqrt(share) : kWorst;
      break;
    }
    case MatchScoreKind::kPaperLikelihood:
      score.value = sum_log_likelihood / n - std::log(config_.sigma_B_uT * std::sqrt(2.0 * M_PI));
      break;
  }
  return score;
}

}  // namespace mm4mm
