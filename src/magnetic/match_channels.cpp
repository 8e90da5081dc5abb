#include "mm4mm/magnetic/match_channels.hpp"

#include <cmath>

namespace mm4mm {

int channelCount(MatchChannels channels) {
  switch (channels) {
    case MatchChannels::kVertical:
      return 1;
    case MatchChannels::kRotatedVector:
      return 3;
    default:
      return 2;
  }
}

int channelValues(const MagneticMap& map, std::size_t index, MatchChannels channels, double yaw_rad,
                  double* values) {
  if (channels == MatchChannels::kLevelled) {
    values[0] = map.horizontal_uT[index];
    values[1] = map.vertical_uT[index];
    return 2;
  }
  if (channels == MatchChannels::kVertical) {
    values[0] = map.vertical_uT[index];
    return 1;
  }
  if (channels == MatchChannels::kVerticalTotal) {
    values[0] = map.vertical_uT[index];
    values[1] = map.total_uT[index];
    return 2;
  }
  const double c = std::cos(yaw_rad), s = std::sin(yaw_rad);
  const double x = map.session_x_uT[index], y = map.session_y_uT[index];
  values[0] = c * x - s * y;
  values[1] = s * x + c * y;
  values[2] = map.vertical_uT[index];
  return 3;
}

double correlationOf(CorrelationStatistic statistic, double cov, double var_a, double var_b,
                     double mean_difference_squared, double n) {
  if (!(var_a > 0.0) || !(var_b > 0.0)) return 0.0;
  if (statistic == CorrelationStatistic::kPearson) return cov / std::sqrt(var_a * var_b);
  return 2.0 * cov / (var_a + var_b + n * mean_difference_squared);
}

}  // namespace mm4mm
