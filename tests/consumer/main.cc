// The smallest cell program: builds a client, a plan request and a typed resource against the installed headers
// and libraries.
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
  request.measurement_type = robocal::MeasurementType::kPosition;
  // The client's results are the api's resources: written and read by their to_json / from_json.
  robocal::api::Campaign campaign;
  campaign.id = "cell7-2024";
  campaign.calibrated = true;
  const auto back = robocal::api::FromWire<robocal::api::Campaign>(nlohmann::json(campaign));
  if (back.id != campaign.id || !back.calibrated) return 1;
  std::cout << "robocal consumer: " << request.robot << " " << nlohmann::json(request).at("measurement_type")
            << " via " << client.options().server_url << "\n";
  return 0;
}
