# Checks the deployment files without tools beyond CMake (run by ctest as deploy_files):
# the example config is a JSON object whose keys are all known configuration keys, and the systemd unit
# starts the binary where `cmake --install` puts it. Usage: cmake -DDEPLOY_DIR=<dir> -P check_deploy.cmake
cmake_minimum_required(VERSION 3.25)
set(known_keys host port db tokens_file allow_insecure_bind tls_cert tls_key log_level log_format max_body_bytes
    max_measurements_per_campaign max_plan_configurations max_array_length max_plan_evaluations max_running_operations
    request_timeout_s keep_alive_timeout_s request_read_timeout_s write_timeout_s threads
    max_head_bytes max_connections max_queued_connections
    max_plan_jacobians max_plan_candidates max_fit_jacobian_entries)

file(READ "${DEPLOY_DIR}/robocal.example.json" config)
string(JSON type ERROR_VARIABLE error TYPE "${config}")
if(error)
  message(FATAL_ERROR "robocal.example.json is not valid JSON: ${error}")
endif()
if(NOT type STREQUAL "OBJECT")
  message(FATAL_ERROR "robocal.example.json must be a JSON object, is ${type}")
endif()
string(JSON count LENGTH "${config}")
math(EXPR last "${count} - 1")
foreach(i RANGE ${last})
  string(JSON key MEMBER "${config}" ${i})
  if(NOT key IN_LIST known_keys)
    message(FATAL_ERROR "robocal.example.json: unknown key '${key}'")
  endif()
endforeach()

file(STRINGS "${DEPLOY_DIR}/robocal.service" exec_start REGEX "^ExecStart=")
if(NOT exec_start MATCHES "^ExecStart=/usr/local/bin/robocal-server( |$)")
  message(FATAL_ERROR "robocal.service: ExecStart must run /usr/local/bin/robocal-server, has '${exec_start}'")
endif()
file(STRINGS "${DEPLOY_DIR}/robocal.service" state REGEX "^StateDirectory=robocal$")
if(NOT state)
  message(FATAL_ERROR "robocal.service: StateDirectory=robocal missing")
endif()
message(STATUS "deploy files ok")
