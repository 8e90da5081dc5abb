// Scans (scans/NNNNNN.pcd), ASCII, binary or binary_compressed, through PCL's reader.
#include "fuzz_input.hpp"
#include "mm4mm/io/pcd_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto file = mm4mm::fuzz::scratchDirectory() / "scan.pcd";
  mm4mm::fuzz::writeInput(file, data, size);
  mm4mm::fuzz::expectReadOrRefusal([&] { mm4mm::readPcd(file); });
  return 0;
}
