// Scans (scans/NNNNNN.pcd), ASCII, binary or binary_compressed, through PCL's reader; and the same
// file as LIO-SAM's transformations.pcd, whose named fields (x y z intensity roll pitch yaw time)
// the LIO-SAM importer reads as key poses.
#include "fuzz_input.hpp"
#include "mm4mm/import/lio_sam_map.hpp"
#include "mm4mm/io/pcd_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto dir = mm4mm::fuzz::scratchDirectory();
  const auto file = dir / "transformations.pcd";
  mm4mm::fuzz::writeInput(file, data, size);
  mm4mm::fuzz::expectReadOrRefusal([&] { mm4mm::readPcd(file); });
  mm4mm::fuzz::expectReadOrRefusal([&] { mm4mm::readLioSamMap(dir); });
  return 0;
}
