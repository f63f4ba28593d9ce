// Fuzz target: a URDF document as POST /v1/robots imports it (urdf::ImportUrdf), from link "a" down to link "b".
// The corpus holds documents with those links, so that mutations reach the chain walk and the joint mapping.
#include "fuzz_util.h"
#include "robocal/urdf/urdf_import.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace robocal;
  api::ImportUrdfRequest request;
  request.urdf = fuzz::Text(data, size);
  request.base_link = "a";
  request.tip_link = "b";
  if (const auto robot = fuzz::Parsed([&] { return urdf::ImportUrdf(request); })) {
    // What an import accepts is a robot the service registers: a valid id and a model the core builds.
    fuzz::Check(api::IsValidId(robot->id), "an imported robot has a valid id");
    fuzz::Check(fuzz::Parsed([&] { return api::BuildModel(*robot); }).has_value(),
                "an imported robot builds as a model");
  }
  return 0;
}
