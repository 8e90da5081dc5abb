#pragma once
// Magnetic maps as PCD files (docs/design.md: magnetic_map.pcd), one point per covered cell:
//
//   x y z     cell centre in the map's frame (m); z = MagneticMap::height_m
//   bh bv bf  the fingerprint: horizontal, vertical and total field (µT)
//   bx by     the horizontal field along the frame's x and y axes (µT)
//
// all float32. The grid itself (origin, cell size, size in cells, height) cannot be recovered
// exactly from float32 cell centres, so it travels in a header comment that PCD readers skip:
//
//   # mm4mm_magnetic_grid origin_x_m=-12.35 origin_y_m=3.3 cell_size_m=0.05 width=37 height=23
//       height_m=0.3                                                          (one line)
//
// Numbers there are written in their shortest exact decimal form, so a map read back equals the
// one written, bit for bit: geometry, coverage mask and every field.

#include <filesystem>

#include "mm4mm/magnetic/magnetic_map.hpp"
#include "mm4mm/merge/magnetic_change.hpp"

namespace mm4mm {

/// Writes `map` to `file` (binary_compressed PCD with the grid comment above). An empty or
/// uncovered map gives a file with no points. Written under a temporary name and renamed.
/// Throws std::invalid_argument when the map's vectors do not match its width and height,
/// std::runtime_error when the file cannot be written.
void writeMagneticMapPcd(const std::filesystem::path& file, const MagneticMap& map);

/// Reads a magnetic map PCD (any encoding). Fields x y bh bv bf are required; bx by are optional
/// (NaN where absent) and z only supplies the height when the grid comment is missing. Without
/// the comment (a map from another tool) the grid is inferred from the points: the cell size is
/// the smallest spacing of distinct centres along x or y, the origin half a cell below the
/// lowest centres. Throws InputError (file, and line for a malformed grid comment) when the file
/// is missing or not a PCD, lacks a required field, holds a non-finite value, a point off the
/// grid's cell centres or outside it, or two points for one cell.
MagneticMap readMagneticMapPcd(const std::filesystem::path& file);

/// Writes an atlas's change map (changes/magnetic_change.pcd; ChangeMap in
/// merge/magnetic_change.hpp), one point per cell some pair of sessions compared:
///
///   x y z   cell centre in the atlas frame (m); z = ChangeMap::height_m
///   delta   |ΔB| (µT) of the pair that differs most there by its chi-square
///   chi2    that chi-square (a cell past the change rule's min_chi2 has changed)
///   region  the number of the change region holding the cell, as report.json's "changes"
///           lists them from 1; 0 where none
///   pairs   how many pairs of sessions compared the cell
///
/// all float32 (region and pairs whole numbers), with the grid comment above, so that CloudCompare
/// or PCL's viewer can colour the cells by any field. Written under a temporary name and renamed.
/// Throws std::invalid_argument when the map's vectors do not match its size, std::runtime_error
/// when the file cannot be written.
void writeChangeMapPcd(const std::filesystem::path& file, const ChangeMap& map);

/// Reads a change map writeChangeMapPcd wrote: equal to it, bit for bit. Throws InputError (file,
/// and what) when the file is missing or not a PCD, lacks the grid comment or a field, holds a
/// non-finite or negative value, a region or pair count that is not a whole number, a point off
/// the grid's cell centres or two points for one cell.
ChangeMap readChangeMapPcd(const std::filesystem::path& file);

}  // namespace mm4mm
