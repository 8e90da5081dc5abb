#include "mm4mm/io/octomap_io.hpp"

#include <sstream>
#include <string>

#include "text_io.hpp"

namespace mm4mm {

// The header AbstractOccupancyOcTree::writeBinaryConst writes (octomap/src/
// AbstractOccupancyOcTree.cpp), then the tree; OcTree::readBinary checks its first line and reads
// `id`, `size` and `res` up to `data`.
void writeOctoMap(const std::filesystem::path& file_bt, const OctoMapTree& tree) {
  std::ostringstream header;
  header << "# Octomap OcTree binary file\n"
         << "# (feel free to add / change comments, but leave the first line as it is!)\n#\n"
         << "id OcTree\nsize " << tree.stats.nodes << "\nres " << tree.resolution_m << "\ndata\n";
  io_detail::writeFileAtomically(file_bt, header.str() + tree.data);
}

}  // namespace mm4mm
