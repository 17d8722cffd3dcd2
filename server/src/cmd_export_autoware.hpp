#pragma once
// mapdelta-server export-autoware: one command, registered in main.cpp's dispatcher.
#include <string>
#include <vector>

namespace mapdelta::server {

// Runs the command with its options (without the command word); returns the exit code.
int ExportAutowareCommand(const std::vector<std::string>& args);

}  // namespace mapdelta::server
