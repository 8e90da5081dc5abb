// placeholder: mm4mm map
#include "commands.hpp"
namespace mm4mm::cli {
void addMapCommand(CLI::App&) {}
}  // namespace mm4mm::cli
