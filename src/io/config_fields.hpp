#pragma once
// Internal to src/io: the fields of every config struct reachable from PipelineConfig, listed
// once for the YAML reader and the YAML writer alike (config_io.cpp), so that the file format is
// the structs' own: a key is a member's C++ name and nesting is the structs' nesting. A member
// added to a struct and not here is neither read nor written (ConfigIo.EveryFieldIsListed
// catches a struct whose dump lacks a field).
//
// A visitor has `field(const char* key, T& value)`; it recurses into structs by calling
// visitFields itself, and reads or writes enums by the names of `enumNames`.

#include <utility>
#include <vector>

#include "mm4mm/atlas/pipeline_config.hpp"

namespace mm4mm::io_detail {

template <typename Enum>
using EnumNames = std::vector<std::pair<const char*, Enum>>;

inline const EnumNames<SingleSensorInterpolation>& enumNames(SingleSensorInterpolation) {
  static const EnumNames<SingleSensorInterpolation> names{
      {"footprint", SingleSensorInterpolation::kFootprint},
      {"gaussian_process", SingleSensorInterpolation::kGaussianProcess}};
  return names;
}
inline const EnumNames<GlobalSearchMethod>& enumNames(GlobalSearchMethod) {
  static const EnumNames<GlobalSearchMethod> names{
      {"correlation", GlobalSearchMethod::kCorrelation},
      {"paper_pso", GlobalSearchMethod::kPaperPso}};
  return names;
}
inline const EnumNames<RefinementMethod>& enumNames(RefinementMethod) {
  static const EnumNames<RefinementMethod> names{{"pso", RefinementMethod::kPso},
                                                 {"local_grid", RefinementMethod::kLocalGrid},
                                                 {"none", RefinementMethod::kNone}};
  return names;
}
inline const EnumNames<MatchScoreKind>& enumNames(MatchScoreKind) {
  static const EnumNames<MatchScoreKind> names{
      {"correlation", MatchScoreKind::kCorrelation},
      {"paper_fitness", MatchScoreKind::kPaperFitness},
      {"paper_likelihood", MatchScoreKind::kPaperLikelihood}};
  return names;
}
inline const EnumNames<MatchChannels>& enumNames(MatchChannels) {
  static const EnumNames<MatchChannels> names{{"levelled", MatchChannels::kLevelled},
                                              {"rotated_vector", MatchChannels::kRotatedVector},
                                              {"vertical_total", MatchChannels::kVerticalTotal},
                                              {"vertical", MatchChannels::kVertical}};
  return names;
}
inline const EnumNames<CorrelationStatistic>& enumNames(CorrelationStatistic) {
  static const EnumNames<CorrelationStatistic> names{
      {"pearson", CorrelationStatistic::kPearson},
      {"concordance", CorrelationStatistic::kConcordance}};
  return names;
}
inline const EnumNames<RobustLoss>& enumNames(RobustLoss) {
  static const EnumNames<RobustLoss> names{
      {"none", RobustLoss::kNone}, {"huber", RobustLoss::kHuber}, {"cauchy", RobustLoss::kCauchy}};
  return names;
}
// The words of merge's --pair-matching.
inline const EnumNames<PairMatching>& enumNames(PairMatching) {
  static const EnumNames<PairMatching> names{{"all", PairMatching::kAllPairs},
                                             {"growing", PairMatching::kGrowingMap}};
  return names;
}

template <class V>
void visitFields(V& v, CalibrationConfig& c) {
  v.field("enabled", c.enabled);
  v.field("sample_spacing_m", c.sample_spacing_m);
  v.field("sample_turn_deg", c.sample_turn_deg);
  v.field("noise_uT", c.noise_uT);
  v.field("pair_radius_m", c.pair_radius_m);
  v.field("min_pair_heading_deg", c.min_pair_heading_deg);
  v.field("min_pair_separation_s", c.min_pair_separation_s);
  v.field("max_pairs_per_reading", c.max_pairs_per_reading);
  v.field("hard_iron_prior_uT", c.hard_iron_prior_uT);
  v.field("soft_iron_prior", c.soft_iron_prior);
  v.field("speed_prior_uT_per_mps", c.speed_prior_uT_per_mps);
  v.field("estimate_speed_term", c.estimate_speed_term);
  v.field("min_speed_spread_mps", c.min_speed_spread_mps);
  v.field("min_tilt_deg", c.min_tilt_deg);
  v.field("min_readings", c.min_readings);
  v.field("max_heading_resultant", c.max_heading_resultant);
  v.field("robust_iterations", c.robust_iterations);
}

template <class V>
void visitFields(V& v, GaussianProcessMapConfig& c) {
  v.field("length_scale_m", c.length_scale_m);
  v.field("noise_ratio", c.noise_ratio);
  v.field("max_std_ratio", c.max_std_ratio);
  v.field("tile_size_m", c.tile_size_m);
  v.field("sample_spacing_m", c.sample_spacing_m);
  v.field("max_samples_per_tile", c.max_samples_per_tile);
}

template <class V>
void visitFields(V& v, MagneticMapConfig& c) {
  v.field("cell_size_m", c.cell_size_m);
  v.field("max_triangle_side_m", c.max_triangle_side_m);
  v.field("single_sensor_footprint_m", c.single_sensor_footprint_m);
  v.field("single_sensor_interpolation", c.single_sensor_interpolation);
  v.field("gaussian_process", c.gaussian_process);
  v.field("max_sensor_gap_m", c.max_sensor_gap_m);
}

template <class V>
void visitFields(V& v, CorrelationSearchConfig& c) {
  v.field("channels", c.channels);
  v.field("statistic", c.statistic);
  v.field("yaw_step_deg", c.yaw_step_deg);
  v.field("min_overlap_m2", c.min_overlap_m2);
  v.field("area_per_sample_m2", c.area_per_sample_m2);
  v.field("yaw_centre_deg", c.yaw_centre_deg);
  v.field("yaw_window_deg", c.yaw_window_deg);
  v.field("max_modes", c.max_modes);
  v.field("credible_r", c.credible_r);
  v.field("credible_min_overlap_m2", c.credible_min_overlap_m2);
  v.field("mode_separation_m", c.mode_separation_m);
  v.field("mode_separation_deg", c.mode_separation_deg);
  v.field("pyramid_factor", c.pyramid_factor);
  v.field("pyramid_candidates", c.pyramid_candidates);
  v.field("pyramid_yaws", c.pyramid_yaws);
}

template <class V>
void visitFields(V& v, PsoConfig& c) {
  v.field("particles", c.particles);
  v.field("iterations", c.iterations);
  v.field("inertia", c.inertia);
  v.field("cognitive", c.cognitive);
  v.field("social", c.social);
  v.field("max_velocity_fraction", c.max_velocity_fraction);
  v.field("tolerance", c.tolerance);
  v.field("stall_iterations", c.stall_iterations);
  v.field("seed", c.seed);
}

template <class V>
void visitFields(V& v, MatchScoreConfig& c) {
  v.field("kind", c.kind);
  v.field("channels", c.channels);
  v.field("statistic", c.statistic);
  v.field("min_overlap_m2", c.min_overlap_m2);
  v.field("area_per_sample_m2", c.area_per_sample_m2);
  v.field("stride", c.stride);
  v.field("association_tolerance_uT", c.association_tolerance_uT);
  v.field("sigma_B_uT", c.sigma_B_uT);
}

template <class V>
void visitFields(V& v, MagneticMatcherConfig::SingleTrack& c) {
  v.field("coarse_cell_size_m", c.coarse_cell_size_m);
  v.field("min_overlap_m2", c.min_overlap_m2);
  v.field("area_per_sample_m2", c.area_per_sample_m2);
  v.field("stride", c.stride);
  v.field("mode_separation_m", c.mode_separation_m);
  v.field("refine_window_m", c.refine_window_m);
  v.field("refine_window_deg", c.refine_window_deg);
  v.field("min_z", c.min_z);
  v.field("min_r", c.min_r);
}

template <class V>
void visitFields(V& v, MatchConfidenceConfig& c) {
  v.field("intercept", c.intercept);
  v.field("atanh_r", c.atanh_r);
  v.field("log_overlap_m2", c.log_overlap_m2);
  v.field("second_mode_ratio", c.second_mode_ratio);
  v.field("log_aspect", c.log_aspect);
  v.field("log_field_std", c.log_field_std);
  v.field("log_yaw_uncertainty", c.log_yaw_uncertainty);
  v.field("single_track", c.single_track);
  v.field("min_probability", c.min_probability);
  v.field("decides", c.decides);
}

template <class V>
void visitFields(V& v, MagneticMatcherConfig& c) {
  v.field("calibration", c.calibration);
  v.field("map", c.map);
  v.field("coarse_cell_size_m", c.coarse_cell_size_m);
  v.field("global", c.global);
  v.field("search", c.search);
  v.field("use_compass_prior", c.use_compass_prior);
  v.field("compass_window_deg", c.compass_window_deg);
  v.field("compass_min_resultant", c.compass_min_resultant);
  v.field("refinement", c.refinement);
  v.field("refine_modes", c.refine_modes);
  v.field("refine_window_m", c.refine_window_m);
  v.field("refine_window_deg", c.refine_window_deg);
  v.field("pso", c.pso);
  v.field("grid_step_m", c.grid_step_m);
  v.field("grid_step_deg", c.grid_step_deg);
  v.field("score", c.score);
  v.field("paper_pso", c.paper_pso);
  v.field("paper_confidence_rule", c.paper_confidence_rule);
  v.field("min_z", c.min_z);
  v.field("min_r", c.min_r);
  v.field("max_second_ratio", c.max_second_ratio);
  v.field("credible_r_gap", c.credible_r_gap);
  v.field("max_yaw_uncertainty_deg", c.max_yaw_uncertainty_deg);
  v.field("yaw_uncertainty_range_deg", c.yaw_uncertainty_range_deg);
  v.field("yaw_uncertainty_step_deg", c.yaw_uncertainty_step_deg);
  v.field("single_track", c.single_track);
  v.field("confidence_model", c.confidence_model);
}

template <class V>
void visitFields(V& v, GrowingMapConfig& c) {
  v.field("max_passes", c.max_passes);
  v.field("max_pairs_per_session", c.max_pairs_per_session);
  v.field("min_pair_overlap_m2", c.min_pair_overlap_m2);
  v.field("offsets", c.offsets);
}

template <class V>
void visitFields(V& v, PointMapConfig& c) {
  v.field("voxel_size_m", c.voxel_size_m);
  v.field("covariance_neighbours", c.covariance_neighbours);
  v.field("covariance_epsilon", c.covariance_epsilon);
  v.field("min_range_m", c.min_range_m);
  v.field("max_range_m", c.max_range_m);
}

template <class V>
void visitFields(V& v, IcpEmConfig& c) {
  v.field("voxel_sizes_m", c.voxel_sizes_m);
  v.field("max_iterations_per_level", c.max_iterations_per_level);
  v.field("m_step_iterations", c.m_step_iterations);
  v.field("max_correspondence_voxels", c.max_correspondence_voxels);
  v.field("association_sigma_voxels", c.association_sigma_voxels);
  v.field("surface_sigma_m", c.surface_sigma_m);
  v.field("prior_sigma_horizontal_m", c.prior_sigma_horizontal_m);
  v.field("prior_sigma_vertical_m", c.prior_sigma_vertical_m);
  v.field("prior_sigma_yaw_deg", c.prior_sigma_yaw_deg);
  v.field("prior_sigma_tilt_deg", c.prior_sigma_tilt_deg);
  v.field("translation_tolerance_m", c.translation_tolerance_m);
  v.field("rotation_tolerance_deg", c.rotation_tolerance_deg);
  v.field("covariance_neighbours", c.covariance_neighbours);
  v.field("covariance_epsilon", c.covariance_epsilon);
  v.field("degeneracy_eigenvalue_ratio", c.degeneracy_eigenvalue_ratio);
  v.field("hold_seed_along_degenerate_directions", c.hold_seed_along_degenerate_directions);
  v.field("source_crop_margin_m", c.source_crop_margin_m);
}

template <class V>
void visitFields(V& v, InterSessionEdgeConfig& c) {
  v.field("pair_radius_m", c.pair_radius_m);
  v.field("spacing_m", c.spacing_m);
  v.field("max_edges_per_pair", c.max_edges_per_pair);
  v.field("submap_half_width", c.submap_half_width);
  v.field("max_range_m", c.max_range_m);
  v.field("icp", c.icp);
  v.field("min_inlier_ratio", c.min_inlier_ratio);
  v.field("information_deflation", c.information_deflation);
}

template <class V>
void visitFields(V& v, StructureMapConfig& c) {
  v.field("cell_size_m", c.cell_size_m);
  v.field("band_below_lidar_m", c.band_below_lidar_m);
  v.field("band_above_lidar_m", c.band_above_lidar_m);
  v.field("max_range_m", c.max_range_m);
  v.field("keyframe_spacing_m", c.keyframe_spacing_m);
}

template <class V>
void visitFields(V& v, JointMatchConfig::SingleTrack& c) {
  v.field("min_overlap_m2", c.min_overlap_m2);
  v.field("area_per_sample_m2", c.area_per_sample_m2);
  v.field("min_z", c.min_z);
  v.field("min_r", c.min_r);
}

template <class V>
void visitFields(V& v, JointMatchConfig& c) {
  v.field("enabled", c.enabled);
  v.field("max_candidates", c.max_candidates);
  v.field("structure_pyramid_factor", c.structure_pyramid_factor);
  v.field("window_m", c.window_m);
  v.field("step_m", c.step_m);
  v.field("window_deg", c.window_deg);
  v.field("step_deg", c.step_deg);
  v.field("min_z", c.min_z);
  v.field("min_r", c.min_r);
  v.field("max_second_ratio", c.max_second_ratio);
  v.field("single_track", c.single_track);
}

template <class V>
void visitFields(V& v, SessionGraphConfig& c) {
  v.field("translation_sigma_per_sqrt_m", c.translation_sigma_per_sqrt_m);
  v.field("translation_sigma_floor_m", c.translation_sigma_floor_m);
  v.field("rotation_sigma_per_sqrt_m_deg", c.rotation_sigma_per_sqrt_m_deg);
  v.field("rotation_sigma_per_sqrt_rad_deg", c.rotation_sigma_per_sqrt_rad_deg);
  v.field("rotation_sigma_floor_deg", c.rotation_sigma_floor_deg);
}

template <class V>
void visitFields(V& v, MultiSessionGraphConfig& c) {
  v.field("odometry_noise", c.odometry_noise);
  v.field("inter_session_loss", c.inter_session_loss);
  v.field("inter_session_loss_scale", c.inter_session_loss_scale);
  v.field("max_inter_session_chi2", c.max_inter_session_chi2);
  v.field("max_outlier_rounds", c.max_outlier_rounds);
  v.field("use_magnetic_residuals", c.use_magnetic_residuals);
  v.field("magnetic_stride_m", c.magnetic_stride_m);
  v.field("magnetic_sigma_uT", c.magnetic_sigma_uT);
  v.field("magnetic_loss_scale", c.magnetic_loss_scale);
  v.field("max_iterations", c.max_iterations);
  v.field("threads", c.threads);
}

template <class V>
void visitFields(V& v, MergeConfig& c) {
  v.field("matcher", c.matcher);
  v.field("pair_matching", c.pair_matching);
  v.field("growing_map", c.growing_map);
  v.field("point_map", c.point_map);
  v.field("pair_icp", c.pair_icp);
  v.field("overlap_margin_m", c.overlap_margin_m);
  v.field("edges", c.edges);
  v.field("magnetic_edge_sigma_m", c.magnetic_edge_sigma_m);
  v.field("magnetic_edge_sigma_deg", c.magnetic_edge_sigma_deg);
  v.field("consistency_translation_m", c.consistency_translation_m);
  v.field("consistency_rotation_deg", c.consistency_rotation_deg);
  v.field("verify_ambiguous_with_geometry", c.verify_ambiguous_with_geometry);
  v.field("max_modes_verified", c.max_modes_verified);
  v.field("min_geometric_inlier_ratio", c.min_geometric_inlier_ratio);
  v.field("geometric_inlier_margin", c.geometric_inlier_margin);
  v.field("geometry_fallback", c.geometry_fallback);
  v.field("max_height_difference_m", c.max_height_difference_m);
  v.field("structure_map", c.structure_map);
  v.field("geometry_matcher", c.geometry_matcher);
  v.field("joint", c.joint);
  v.field("graph", c.graph);
}

template <class V>
void visitFields(V& v, MergedCloudConfig& c) {
  v.field("voxel_size_m", c.voxel_size_m);
  v.field("min_range_m", c.min_range_m);
  v.field("max_range_m", c.max_range_m);
  v.field("point_sigma_m", c.point_sigma_m);
  v.field("neighbour_fusion_radius_m", c.neighbour_fusion_radius_m);
}

template <class V>
void visitFields(V& v, FieldOffsetConfig& c) {
  v.field("enabled", c.enabled);
  v.field("min_shared_cells", c.min_shared_cells);
  v.field("observed_vertical_sigma_uT", c.observed_vertical_sigma_uT);
  v.field("earth_vertical_sigma_uT", c.earth_vertical_sigma_uT);
}

template <class V>
void visitFields(V& v, MagneticChangeConfig& c) {
  v.field("noise_floor_uT", c.noise_floor_uT);
  v.field("min_chi2", c.min_chi2);
  v.field("min_region_area_m2", c.min_region_area_m2);
  v.field("calibration_scale", c.calibration_scale);
}

template <class V>
void visitFields(V& v, FusedMagneticMapConfig& c) {
  v.field("map", c.map);
  v.field("sensor_noise_uT", c.sensor_noise_uT);
  v.field("sensor_bias_uT", c.sensor_bias_uT);
  v.field("gradient_uT_per_m", c.gradient_uT_per_m);
  v.field("max_height_difference_m", c.max_height_difference_m);
  v.field("offsets", c.offsets);
  v.field("detect_changes", c.detect_changes);
  v.field("change", c.change);
}

template <class V>
void visitFields(V& v, OctoMapConfig& c) {
  v.field("resolution_m", c.resolution_m);
  v.field("min_range_m", c.min_range_m);
  v.field("max_range_m", c.max_range_m);
  v.field("probability_hit", c.probability_hit);
  v.field("probability_miss", c.probability_miss);
  v.field("clamping_min", c.clamping_min);
  v.field("clamping_max", c.clamping_max);
}

template <class V>
void visitFields(V& v, AtlasOutputConfig& c) {
  v.field("cloud", c.cloud);
  v.field("magnetic", c.magnetic);
  v.field("octomap", c.octomap);
}

template <class V>
void visitFields(V& v, PipelineConfig& c) {
  v.field("merge", c.merge);
  v.field("outputs", c.outputs);
}

}  // namespace mm4mm::io_detail
