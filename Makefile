# The README's commands. `make test` installs what is missing, configures, builds and runs every test.
BUILD_DIR ?= build
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?= -DCMAKE_BUILD_TYPE=RelWithDebInfo

.PHONY: all deps configure build test run bench format clean

all: build

deps:
	bash deploy/install-deps.sh

configure: deps
	cmake -S . -B $(BUILD_DIR) $(CMAKE_FLAGS)

build: configure
	cmake --build $(BUILD_DIR) -j $(JOBS)

test: build
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS) --timeout 600

run:
	@echo 'make run: the calibration server is not built yet; it arrives with the HTTP service (see README).' >&2
	@exit 2

bench: build
	$(BUILD_DIR)/tests/bench/robocal_core_bench
	$(BUILD_DIR)/tests/bench/robocal_planning_bench
	$(BUILD_DIR)/tests/bench/robocal_identification_bench

format:
	find core api server client tests -name '*.h' -o -name '*.cc' | xargs -r clang-format -i

clean:
	rm -rf $(BUILD_DIR)
