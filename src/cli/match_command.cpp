// placeholder: mm4mm match
#include "commands.hpp"
namespace mm4mm::cli {
void addMatchCommand(CLI::App&) {}
}  // namespace mm4mm::cli
