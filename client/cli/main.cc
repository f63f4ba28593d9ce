// robocal: the command line client of the calibration service (see `robocal --help`).
#include <cstdlib>
#include <iostream>

#include "cli.h"

int main(int argc, char** argv) {
  std::map<std::string, std::string> env;
  for (const char* name : {"ROBOCAL_SERVER", "ROBOCAL_TOKEN", "ROBOCAL_CA_CERT"}) {
    if (const char* value = std::getenv(name)) env[name] = value;
  }
  return robocal::cli::Run(std::vector<std::string>(argv + 1, argv + argc), env, std::cout, std::cerr);
}
