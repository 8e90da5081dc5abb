// atlas.yaml: the manifest of an atlas directory (versions, sessions, settings, file checksums).
#include "fuzz_input.hpp"
#include "mm4mm/io/atlas_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto atlas = mm4mm::fuzz::scratchDirectory() / "atlas";
  std::filesystem::create_directories(atlas);
  mm4mm::fuzz::writeInput(atlas / "atlas.yaml", data, size);
  mm4mm::fuzz::expectReadOrRefusal([&] { mm4mm::readAtlasManifest(atlas); });
  return 0;
}
