# Checks the deployment files without tools beyond CMake (run by ctest as deploy_files):
# the example config is a JSON object whose keys are all known configuration keys; both systemd units start the
# binary where `cmake --install` puts it, the template unit on the port its instance names and without a state
# directory (its database is PostgreSQL); the nginx examples admit the bodies the server admits, and the
# multi-instance one has an upstream. Usage: cmake -DDEPLOY_DIR=<dir> -P check_deploy.cmake
cmake_minimum_required(VERSION 3.25)
set(known_keys host port db tokens_file allow_insecure_bind tls_cert tls_key log_level log_format max_body_bytes
    max_measurements_per_campaign max_plan_configurations max_array_length max_plan_evaluations max_running_operations
    request_timeout_s keep_alive_timeout_s request_read_timeout_s write_timeout_s threads
    max_head_bytes max_connections max_queued_connections
    max_plan_jacobians max_plan_candidates max_fit_jacobian_entries
    db_pool_size operation_lease_s)

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

# Both units start the binary where `cmake --install` puts it.
foreach(unit robocal.service robocal@.service)
  file(STRINGS "${DEPLOY_DIR}/${unit}" exec_start REGEX "^ExecStart=")
  if(NOT exec_start MATCHES "^ExecStart=/usr/local/bin/robocal-server( |$)")
    message(FATAL_ERROR "${unit}: ExecStart must run /usr/local/bin/robocal-server, has '${exec_start}'")
  endif()
endforeach()
file(STRINGS "${DEPLOY_DIR}/robocal.service" state REGEX "^StateDirectory=robocal$")
if(NOT state)
  message(FATAL_ERROR "robocal.service: StateDirectory=robocal missing")
endif()
# One instance per port: robocal@8081.service runs `--port 8081`.
file(STRINGS "${DEPLOY_DIR}/robocal@.service" exec_start REGEX "^ExecStart=")
if(NOT exec_start MATCHES " --port %i( |$)")
  message(FATAL_ERROR "robocal@.service: ExecStart must pass --port %i, has '${exec_start}'")
endif()
# Several instances must never share an SQLite file: the template unit has nowhere to write one.
file(STRINGS "${DEPLOY_DIR}/robocal@.service" state REGEX "^(StateDirectory|ReadWritePaths)=")
if(state)
  message(FATAL_ERROR "robocal@.service: no writable directory for a database, has '${state}'")
endif()

file(STRINGS "${DEPLOY_DIR}/nginx-upstream.conf" upstream REGEX "^[ \t]*upstream[ \t]+[A-Za-z0-9_]+[ \t]*{")
if(NOT upstream)
  message(FATAL_ERROR "nginx-upstream.conf: no upstream block")
endif()

# The proxies refuse with 413 exactly what the server would refuse: client_max_body_size equals max_body_bytes.
string(JSON max_body_bytes GET "${config}" max_body_bytes)
foreach(conf nginx-tls.conf nginx-upstream.conf)
  file(STRINGS "${DEPLOY_DIR}/${conf}" lines REGEX "^[ \t]*client_max_body_size[ \t]")
  list(LENGTH lines n)
  if(NOT n EQUAL 1)
    message(FATAL_ERROR "${conf}: expected one client_max_body_size, found ${n}")
  endif()
  if(NOT lines MATCHES "client_max_body_size[ \t]+([0-9]+)([kKmMgG]?)([^0-9A-Za-z]|$)")
    message(FATAL_ERROR "${conf}: cannot read '${lines}'")
  endif()
  set(bytes ${CMAKE_MATCH_1})
  string(TOLOWER "${CMAKE_MATCH_2}" unit)
  if(unit STREQUAL "k")
    math(EXPR bytes "${bytes} * 1024")
  elseif(unit STREQUAL "m")
    math(EXPR bytes "${bytes} * 1048576")
  elseif(unit STREQUAL "g")
    math(EXPR bytes "${bytes} * 1073741824")
  endif()
  if(NOT bytes EQUAL max_body_bytes)
    message(FATAL_ERROR "${conf}: client_max_body_size is ${bytes} bytes, robocal.example.json's max_body_bytes "
                        "${max_body_bytes}; change both together")
  endif()
endforeach()
message(STATUS "deploy files ok")
