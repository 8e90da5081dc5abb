#pragma once
// Top-down pictures of mapping sessions, drawn by one renderer:
//  - one session in its own frame: the keyframe scans as a grey density map, the magnetometer
//    samples coloured by field magnitude, and the keyframe trajectory;
//  - an atlas: every connected session's scans moved by its optimised keyframe poses as one grey
//    density map, each session's trajectory in its own colour, and a legend of session ids.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "mm4mm/session/session.hpp"

namespace mm4mm {

struct SessionRenderOptions {
  /// Picture scale (px/m); lowered when the picture would exceed `max_image_side_px`.
  double pixels_per_metre = 10.0;
  /// Upper bound on the picture's width and height (px), title, colour bar and legend included.
  int max_image_side_px = 4000;
  /// Empty border around the drawn content (m).
  double margin_m = 2.0;
  /// Points outside this height band (picture frame: the session's or the atlas frame, both
  /// gravity-aligned with z up, m) are left out so that floor and ceiling do not cover walls,
  /// pillars and shelves.
  double min_point_height_m = 0.2;
  double max_point_height_m = 2.5;

  /// False, with the offending field named in `error`, when an option is out of range.
  bool IsValid(std::string* error) const;
};

/// Where the picture frame (a session's frame, or the atlas frame) lands in a rendered picture.
struct SessionRenderLayout {
  int width_px = 0;
  int height_px = 0;
  /// The scale actually used (px/m), after any scaling down to the size limit.
  double pixels_per_metre = 0.0;
  /// Picture-frame area shown (content bounding box plus margin), m.
  Eigen::AlignedBox2d map_area_m;
  /// Picture position (px) of the area's top-left corner (min x, max y).
  Eigen::Vector2d map_corner_px = Eigen::Vector2d::Zero();
  /// True when magnetometer samples are drawn, so a |B| colour bar is shown (single session).
  bool has_colour_bar = false;
  /// True when a legend of session ids and trajectory colours is shown (atlas).
  bool has_legend = false;

  /// Picture position (px; x right, y down; pixel (i, j) covers [i, i+1) x [j, j+1)) of a
  /// picture-frame point (m; x right, y up in the picture).
  Eigen::Vector2d pixelOf(const Eigen::Vector2d& xy_m) const;
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

/// Trajectory colour (8-bit RGB) of the atlas session at `session_index`: Tableau 10 without its
/// grey (which would vanish into the point density), repeating after 9 sessions. Keyed by the
/// session's position in the atlas, so a session keeps its colour when others join or connect.
std::array<std::uint8_t, 3> atlasSessionColour(std::size_t session_index);

/// The layout `renderAtlasPng` uses. Inputs are parallel, one entry per atlas session:
/// `T_atlas_keyframe[s][k]` is keyframe k of `sessions[s]` in the atlas frame (needed for
/// connected sessions only), `connected[s]` whether the session was placed in the atlas. Only
/// connected sessions are drawn; unconnected ones are listed in the legend as such, never put in
/// a frame they do not belong to. Points more than 30 m outside the drawn trajectories' bounding
/// box do not count. Throws std::invalid_argument for invalid options, inputs of different
/// lengths, a null session, a connected session whose pose count differs from its keyframe count
/// or whose scan count differs from it, or no connected session with keyframes.
SessionRenderLayout layoutAtlasRender(
    const std::vector<const Session*>& sessions,
    const std::vector<std::vector<Eigen::Isometry3d>>& T_atlas_keyframe,
    const std::vector<bool>& connected, const SessionRenderOptions& options);

/// Draws the merged map of an atlas top-down in the atlas frame and writes it to `png_path`
/// (temporary name, then renamed): the grey density of every connected session's scan points
/// (`T_atlas_keyframe[s][k] * point`), each connected session's trajectory in
/// `atlasSessionColour(s)`, and a legend of session ids. No magnetic samples: the fused magnetic
/// map has its own picture. `title` heads the picture ("atlas" when empty). Same errors as
/// layoutAtlasRender, plus std::runtime_error (naming the path) when the picture cannot be
/// written.
void renderAtlasPng(const std::vector<const Session*>& sessions,
                    const std::vector<std::vector<Eigen::Isometry3d>>& T_atlas_keyframe,
                    const std::vector<bool>& connected, const SessionRenderOptions& options,
                    const std::string& title, const std::filesystem::path& png_path);

}  // namespace mm4mm
