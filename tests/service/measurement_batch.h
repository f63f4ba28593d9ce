// A batch upload body of measurements of the nominal robot at random configurations, for the tests that drive a
// server process (durability, several instances).
#pragma once

#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "robocal/api/campaigns.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/random.h"

namespace robocal::server::testing {

/// {"request_id", "measurements"}: `count` poses of `model` at random configurations (seeded), each position
/// moved by Gaussian noise of `noise_mm` per axis (0: exact), so that a fit has work to do.
inline nlohmann::json MeasurementBatch(const RobotModel& model, const std::string& request_id, int count,
                                       std::uint64_t seed, double noise_mm = 0.0) {
  Rng rng(seed);
  nlohmann::json list = nlohmann::json::array();
  for (int i = 0; i < count; ++i) {
    const Eigen::VectorXd q = RandomConfiguration(model, &rng);
    Transform t = ForwardKinematics(model, q);
    if (noise_mm > 0.0) t.translation() += noise_mm * Eigen::Vector3d(rng.Normal(), rng.Normal(), rng.Normal());
    list.push_back({{"joints", api::JointsToWire(model, q)}, {"pose", nlohmann::json(api::TransformToPose(t))}});
  }
  return {{"request_id", request_id}, {"measurements", list}};
}

}  // namespace robocal::server::testing
