# The README's commands. `make test` installs what is missing, configures, builds and runs every test.
BUILD_DIR ?= build
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?= -DCMAKE_BUILD_TYPE=RelWithDebInfo
# Ninja schedules the two cores better than make; a tree already configured keeps its generator.
GENERATOR ?= Ninja
generator_flag = $(if $(wildcard $(1)/CMakeCache.txt),,-G $(GENERATOR))

.PHONY: all deps configure build test run bench format clean demo sanitize-build test-sanitize fuzz

all: build

deps:
	bash deploy/install-deps.sh

configure: deps
	cmake -S . -B $(BUILD_DIR) $(call generator_flag,$(BUILD_DIR)) $(CMAKE_FLAGS)

build: configure
	cmake --build $(BUILD_DIR) -j $(JOBS)

test: build
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS) --timeout 600

# One clang tree serves the sanitizers and the fuzzers, so CI builds it once: every target with ASan and UBSan,
# the fuzz targets with libFuzzer. test-sanitize runs the whole suite there (each fuzz target for
# ROBOCAL_FUZZ_SECONDS, 10 s); fuzz runs only the fuzz targets, FUZZ_SECONDS each (docs/testing.md).
SANITIZE_BUILD_DIR ?= build-sanitize
SANITIZERS ?= address,undefined
FUZZ_SECONDS ?= 300

sanitize-build: deps
	cmake -S . -B $(SANITIZE_BUILD_DIR) $(call generator_flag,$(SANITIZE_BUILD_DIR)) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++ \
	  -DROBOCAL_SANITIZE=$(SANITIZERS) -DROBOCAL_FUZZ=ON
	cmake --build $(SANITIZE_BUILD_DIR) -j $(JOBS)

test-sanitize: sanitize-build
	cd $(SANITIZE_BUILD_DIR) && UBSAN_OPTIONS=print_stacktrace=1 ctest --output-on-failure -j $(JOBS) --timeout 900

fuzz: sanitize-build
	cd $(SANITIZE_BUILD_DIR) && ROBOCAL_FUZZ_SECONDS=$(FUZZ_SECONDS) UBSAN_OPTIONS=print_stacktrace=1 \
	  ctest --output-on-failure -j $(JOBS) -L fuzz --timeout $$(($(FUZZ_SECONDS) + 300))

# Starts the server on 127.0.0.1:8080 with its SQLite file under ./var (Ctrl-C stops it). Builds only the server:
# a fresh machine answers after the server's build, not after every test, benchmark and fuzz target's.
run: configure
	cmake --build $(BUILD_DIR) -j $(JOBS) --target robocal-server
	mkdir -p var
	$(BUILD_DIR)/server/robocal-server --host 127.0.0.1 --port 8080 --db ./var/robocal.db

# The whole calibration against a throw-away server: plan, measure (simulated), fit, validate, the table. Builds
# only the programs it runs.
demo: configure
	cmake --build $(BUILD_DIR) -j $(JOBS) --target robocal-server robocal-mock-tracker
	bash tests/curl/demo.sh $(BUILD_DIR)

bench: build
	$(BUILD_DIR)/tests/bench/robocal_core_bench
	$(BUILD_DIR)/tests/bench/robocal_planning_bench
	$(BUILD_DIR)/tests/bench/robocal_identification_bench
	$(BUILD_DIR)/tests/bench/robocal_compensation_bench
	$(BUILD_DIR)/tests/bench/robocal_program_bench
	$(BUILD_DIR)/tests/bench/robocal_ipa_fit_bench

# Formats the C++ lines changed since the last commit (staged or not) with the project's .clang-format; older
# code is left as it is, so that a change's diff holds only the change. C++ only: clang-format would rewrite
# api/openapi.json, which keeps the layout of json.dumps(indent=1).
format:
	git clang-format --force --extensions h,cc

clean:
	rm -rf $(BUILD_DIR)
