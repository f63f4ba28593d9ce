// The service's cells: where the tracker stands, the reflectors, obstacles and capsules, and which
// configurations a cell can measure.
#include "robocal/server/service.h"
#include "service_support.h"

namespace robocal::server {

using api::ApiError;
using api::Status;

Service::LoadedCell Service::LoadCell(const std::string& id) {
  CheckId(id, "cell");
  const auto doc = storage_->Get(kCells, id);
  if (!doc) throw ApiError(Status::kNotFound, "cell \"" + id + "\" not found", {{"cell", "unknown cell"}});
  api::StoredCell stored = ReadStored<api::StoredCell>(*doc);
  RobotModel model = api::BuildModel(stored.robot_definition);
  Cell cell = api::ToCell(stored.cell, model);
  return {std::move(stored.cell), std::move(model), std::move(cell), std::move(stored.robot_definition)};
}

api::CellWire Service::CreateCell(const nlohmann::json& body) {
  // The robot first: the cell's sizes are checked against it.
  const nlohmann::json* robot = body.is_object() && body.contains("robot") ? &body.at("robot") : nullptr;
  if (robot == nullptr || !robot->is_string()) {
    throw ApiError(Status::kInvalidArgument, "invalid cell: robot: required (the id of a robot)",
                   {{"robot", robot == nullptr ? "required" : "expected a robot id"}});
  }
  const ResolvedRobot resolved = ResolveRobot(robot->get<std::string>());
  const api::CellWire request = api::ParseCellRequest(body, resolved.model, options_.limits);
  const Cell cell = api::ToCell(request, resolved.model);
  const api::StoredCell stored{api::CellResource(request, cell, resolved.model), resolved.definition};
  try {
    storage_->Create(kCells, request.id, nlohmann::json(stored).dump());
  } catch (const StorageError& e) {
    if (e.kind() == StorageError::Kind::kAlreadyExists) {
      throw ApiError(Status::kAlreadyExists, "cell \"" + request.id + "\" already exists", {{"id", "already exists"}});
    }
    throw;
  }
  return stored.cell;
}

api::CellWire Service::GetCell(const std::string& id) { return LoadCell(id).wire; }

api::CellList Service::ListCells(const std::string& page_size, const std::string& page_token) {
  const PageRequest page = ParsePageRequest(kCells, page_size, page_token);
  auto docs = storage_->List(kCells, page.token, static_cast<int>(page.size + 1));
  const bool more = docs.size() > page.size;
  if (more) docs.resize(page.size);
  api::CellList list;
  for (const Document& d : docs) list.cells.push_back(ReadStored<api::StoredCell>(d).cell);
  if (more) list.next_page_token = PageToken(kCells, docs.back().id);
  return list;
}

void Service::DeleteCell(const std::string& id) {
  CheckId(id, "cell");
  // Plans keep their configurations and checks; deleting a cell changes none of them.
  if (!storage_->Delete(kCells, id)) throw ApiError(Status::kNotFound, "cell \"" + id + "\" not found");
}

api::CellCheckResult Service::CheckCell(const std::string& id, const nlohmann::json& body) {
  const LoadedCell loaded = LoadCell(id);
  // Joints outside the robot's limits are refused; inside them but outside the cell's ranges, reported.
  const api::ForwardRequest req = api::ParseCellCheckRequest(body, loaded.model, options_.limits);
  const TrimWhenDone trim(&trimmer_, req.joints.size() >= kLargeRequest);
  api::CellCheckResult result;
  result.cell = id;
  result.results.reserve(req.joints.size());
  for (const auto& q : req.joints) {
    result.results.push_back(
        api::ToWire(CheckConfiguration(loaded.model, loaded.cell, api::JointsToCore(loaded.model, q))));
  }
  return result;
}

}  // namespace robocal::server
