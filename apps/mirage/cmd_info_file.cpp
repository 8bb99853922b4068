#include "cmd_list.h"
#include "commands.h"

namespace mirage::cli {
// Filled once the importers land.
void infoFile(const std::string& path, bool) { fail(path + ": scene import is not built yet"); }
} // namespace mirage::cli
