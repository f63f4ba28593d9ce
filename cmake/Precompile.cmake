# Precompiled headers: most of a clean build is spent parsing the same large headers (Eigen, nlohmann-json,
# cpp-httplib, GoogleTest) in every translation unit. Each target precompiles the set its sources include,
# once, with its own flags (so sanitizer and fuzzer flags stay consistent). ROBOCAL_PCH=OFF turns it off, to
# check that every file still includes what it uses.
option(ROBOCAL_PCH "Precompile the large third-party headers per target" ON)

set(robocal_pch_std <algorithm> <cmath> <cstdint> <functional> <limits> <map> <optional> <set> <sstream>
  <stdexcept> <string> <vector>)
set(robocal_pch_eigen <Eigen/Core> <Eigen/Cholesky> <Eigen/Geometry> <Eigen/QR> <Eigen/SVD>)
set(robocal_pch_json <nlohmann/json.hpp>)
set(robocal_pch_gtest <gtest/gtest.h> <gmock/gmock.h>)
set(robocal_pch_http <httplib.h>)

# robocal_precompile(target KIND...): KIND is any of std, eigen, json, gtest, http.
function(robocal_precompile target)
  if(NOT ROBOCAL_PCH)
    return()
  endif()
  set(headers "")
  foreach(kind IN LISTS ARGN)
    list(APPEND headers ${robocal_pch_${kind}})
  endforeach()
  target_precompile_headers(${target} PRIVATE ${headers})
endfunction()
