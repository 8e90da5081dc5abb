#pragma once
// Top-down picture of one session in its own frame: the keyframe scans as a grey density map,
// the magnetometer samples coloured by field magnitude, and the keyframe trajectory.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <filesystem>
#include <string>

#include "mm4mm/session/session.hpp"

namespace mm4mm {

struct SessionRenderOptions {
  /// Picture scale (px/m); lowered when the picture would exceed `max_image_side_px`.
  double pixels_per_metre = 10.0;
  /// Upper bound on the picture's width and height (px), title and colour bar included.
  int max_image_side_px = 4000;
  /// Empty border around the drawn content (m).
  double margin_m = 2.0;
  /// Points outside this height band (session frame, z up, m) are left out so that floor and
  /// ceiling do not cover walls, pillars and shelves.
  double min_point_height_m = 0.2;
  double max_point_height_m = 2.5;

  /// False, with the offending field named in `error`, when an option is out of range.
  bool IsValid(std::string* error) const;
};

/// Where the session frame lands in the picture that `renderSessionPng` draws.
struct SessionRenderLayout {
  int width_px = 0;
  int height_px = 0;
  /// The scale actually used (px/m), after any scaling down to the size limit.
  double pixels_per_metre = 0.0;
  /// Session-frame area shown (content bounding box plus margin), m.
  Eigen::AlignedBox2d map_area_m;
  /// Picture position (px) of the area's top-left corner (min x, max y).
  Eigen::Vector2d map_corner_px = Eigen::Vector2d::Zero();
  /// True when the session has magnetometer samples to draw, so a colour bar is shown.
  bool has_colour_bar = false;

  /// Picture position (px; x right, y down; pixel (i, j) covers [i, i+1) x [j, j+1)) of a
  /// session-frame point (m; x right, y up in the picture).
  Eigen::Vector2d pixelOf(const Eigen::Vector2d& xy_session_m) const;
};

/// The layout `renderSessionPng` uses for `session`. Points more than 30 m outside the
/// trajectory's bounding box do not count, so one long LiDAR return cannot blow up the picture.
/// Throws std::invalid_argument for invalid options or a session without keyframes.
SessionRenderLayout layoutSessionRender(const Session& session,
                                        const SessionRenderOptions& options);

/// Draws `session` top-down in its own frame and writes it to `png_path` (written to a temporary
/// name beside it, then renamed). A session without magnetometer samples gets no dots and no
/// colour bar; one without scans gets no points. Throws std::invalid_argument for invalid
/// options or a session without keyframes, std::runtime_error (naming the path) when the
/// picture cannot be written.
void renderSessionPng(const Session& session, const SessionRenderOptions& options,
                      const std::filesystem::path& png_path);

}  // namespace mm4mm
