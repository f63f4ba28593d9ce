// The smallest cell program: builds a client and a plan request against the installed headers and libraries.
#include <iostream>

#include "robocal/client/client.h"
#include "robocal/core/presets.h"

int main() {
  robocal::ClientOptions options;
  options.server_url = "http://127.0.0.1:1";
  std::string error;
  if (!options.IsValid(&error)) return 1;
  robocal::Client client(options);
  robocal::api::PlanRequest request;
  request.robot = robocal::PresetNames().front();
  std::cout << "robocal consumer: " << request.robot << " via " << client.options().server_url << "\n";
  return 0;
}
