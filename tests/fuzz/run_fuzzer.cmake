# Runs one libFuzzer target for a bounded time on a scratch copy of its corpus (libFuzzer adds the inputs it
# finds to the corpus directory it is given, and the source tree must never be written). Crashing inputs go to
# WORK_DIR/artifacts. The corpus, and so every regression input, is run first.
# Run by ctest: cmake -DFUZZER=... -DCORPUS=... -DWORK_DIR=... -DSECONDS=... -P run_fuzzer.cmake
# The environment variable ROBOCAL_FUZZ_SECONDS overrides SECONDS (`make fuzz` runs longer than ctest does).
# libFuzzer's random choices take a seed, ROBOCAL_FUZZ_SEED (1 unless set), so that a failure can be replayed with
# the same seed; `make fuzz` with other seeds explores further.
if(DEFINED ENV{ROBOCAL_FUZZ_SECONDS})
  set(SECONDS "$ENV{ROBOCAL_FUZZ_SECONDS}")
endif()
set(SEED 1)
if(DEFINED ENV{ROBOCAL_FUZZ_SEED})
  set(SEED "$ENV{ROBOCAL_FUZZ_SEED}")
endif()
file(REMOVE_RECURSE "${WORK_DIR}")
file(MAKE_DIRECTORY "${WORK_DIR}/corpus" "${WORK_DIR}/artifacts")
file(COPY "${CORPUS}/" DESTINATION "${WORK_DIR}/corpus")
execute_process(
  COMMAND "${FUZZER}" -seed=${SEED} -max_total_time=${SECONDS} -timeout=30 -print_final_stats=1
          "-artifact_prefix=${WORK_DIR}/artifacts/" "${WORK_DIR}/corpus"
  RESULT_VARIABLE result)
if(NOT result EQUAL 0)
  file(GLOB artifacts "${WORK_DIR}/artifacts/*")
  message(FATAL_ERROR "${FUZZER} failed (${result}, seed ${SEED}). Inputs that crash it: ${artifacts}\n"
                      "Reproduce with: ${FUZZER} INPUT; keep it as a regression input in ${CORPUS}/")
endif()
