// What the service's parts share: collection names, identifiers from paths, pages of lists, stored documents
// read as their typed schema, and returning the memory of large requests.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "robocal/api/campaigns.h"
#include "robocal/api/error.h"
#include "robocal/api/robots.h"
#include "robocal/api/stored.h"
#include "robocal/api/wire.h"
#include "robocal/core/measurement.h"
#include "robocal/server/memory_trimmer.h"
#include "server/storage/storage.h"

namespace robocal::server {

inline constexpr const char* kRobots = "robots";
inline constexpr const char* kPlans = "plans";
inline constexpr const char* kCampaigns = "campaigns";
inline constexpr const char* kCalibrations = "calibrations";
inline constexpr const char* kOperations = "operations";
inline constexpr const char* kCells = "cells";

/// Whether `id` names a preset robot.
bool IsPresetRobot(const std::string& id);

/// An id from a path that cannot name anything is the caller's mistake (400 naming `what`), not a missing
/// resource (404).
void CheckId(const std::string& id, const std::string& what);

/// One page of a list: page_size items after the last id of the previous page.
struct PageRequest {
  std::size_t size = 100;
  std::string token;  // the last id of the previous page ("" for the first page)
};
/// Checks the query of list `list` (INVALID_ARGUMENT naming page_size or page_token).
PageRequest ParsePageRequest(const std::string& list, const std::string& size_text, const std::string& token);
/// The next_page_token of a page of `list` that ended with `last_id`: the id with a check of the list it came
/// from, so that a token made up or taken from another list is refused instead of silently giving a wrong page.
std::string PageToken(const std::string& list, const std::string& last_id);

/// A stored document read as its schema T (api/stored.h). A document that does not parse or has not T's shape
/// is the server's problem, not the caller's: INTERNAL naming the collection, id and field.
template <typename T>
T ReadStored(const Document& doc) {
  try {
    return api::FromWire<T>(nlohmann::json::parse(doc.json));
  } catch (const api::WireError& e) {
    throw api::ApiError(api::Status::kInternal,
                        "stored " + doc.collection + " document \"" + doc.id + "\" is unreadable: " + e.what());
  } catch (const nlohmann::json::exception& e) {
    throw api::ApiError(api::Status::kInternal,
                        "stored " + doc.collection + " document \"" + doc.id + "\" is not JSON: " + e.what());
  }
}

/// A stored measurement's joints and pose (INTERNAL naming its sequence if unreadable).
api::MeasurementWire ReadMeasurement(const StoredMeasurement& stored);

/// Calls `visit` for a campaign's measurements of `role` in sequence order, a page at a time, so that a
/// campaign's stored text is never all in memory at once (only what the caller keeps of it).
void ForEachMeasurement(Storage* storage, const std::string& campaign_id, const std::string& role,
                        const std::function<void(const StoredMeasurement&)>& visit);

/// Whether the stored fit `result` saw the calibration measurement with `sequence`, the `index`-th (from 0) in
/// sequence order: up to the last sequence the fit recorded, or, for a fit stored before it recorded one, among its
/// first used + excluded ones (the same measurements: they are append-only in sequence order).
bool SeenByFit(const api::CalibrationResult& result, const std::optional<std::int64_t>& last_calibration_sequence,
               std::int64_t sequence, std::int64_t index);

/// Calls `visit` for each calibration measurement of the campaign that the stored fit `result` used: those it saw
/// (SeenByFit), less the outliers it excluded (its stale shots among them), in sequence order.
void ForEachUsedMeasurement(Storage* storage, const std::string& campaign_id, const api::CalibrationResult& result,
                            const std::optional<std::int64_t>& last_calibration_sequence,
                            const std::function<void(const api::MeasurementWire&)>& visit);

/// A stored measurement as the core takes it; `reflectors`: the campaign's, by which the measurement's reflector
/// id becomes an index.
Measurement MeasurementToCore(const RobotModel& model, const api::MeasurementWire& w,
                              const api::StoredCampaign& campaign);

/// A registered robot's resource: its model, and the links of the URDF it was imported from.
api::Robot RobotResource(const std::string& id, const RobotModel& model, const api::RegisterRobotRequest& definition);

/// Tool poses of `model` with `errors` (empty: nominal) for the request's joint vectors.
std::vector<api::PoseResultWire> ForwardPoses(const RobotModel& model, const Eigen::VectorXd& errors,
                                        const api::ForwardRequest& req, const Payload& payload = Payload());

/// A plan resource's members every plan has: its id, robot, request, type, objective, optimiser and joint units.
void PlanHeader(const RobotModel& model, const api::PlanRequest& req, const std::string& plan_id,
                api::PlanResult* result);

/// Requests with at least this many elements (measurements, joint vectors, targets) count as large.
inline constexpr std::size_t kLargeRequest = 1000;

/// Asks `trimmer` for a trim as a large request's work ends; the trim's delay covers what is freed after this
/// (the request's other locals, its request and reply documents).
class TrimWhenDone {
 public:
  TrimWhenDone(MemoryTrimmer* trimmer, bool large) : trimmer_(large ? trimmer : nullptr) {}
  ~TrimWhenDone() {
    if (trimmer_ != nullptr) trimmer_->Schedule();
  }
  TrimWhenDone(const TrimWhenDone&) = delete;
  TrimWhenDone& operator=(const TrimWhenDone&) = delete;

 private:
  MemoryTrimmer* trimmer_;
};

}  // namespace robocal::server
