# The README's commands. `make test` installs what is missing, configures, builds and runs every test.
BUILD_DIR ?= build
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?= -DCMAKE_BUILD_TYPE=RelWithDebInfo

.PHONY: all deps configure build test run bench format clean demo

all: build

deps:
	bash deploy/install-deps.sh

configure: deps
	cmake -S . -B $(BUILD_DIR) $(CMAKE_FLAGS)

build: configure
	cmake --build $(BUILD_DIR) -j $(JOBS)

test: build
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS) --timeout 600

# Starts the server on 127.0.0.1:8080 with its SQLite file under ./var (Ctrl-C stops it).
run: build
	mkdir -p var
	$(BUILD_DIR)/server/robocal-server --host 127.0.0.1 --port 8080 --db ./var/robocal.db

# The whole calibration against a throw-away server: plan, measure (simulated), fit, validate, the table.
demo: build
	bash tests/curl/demo.sh $(BUILD_DIR)

bench: build
	$(BUILD_DIR)/tests/bench/robocal_core_bench
	$(BUILD_DIR)/tests/bench/robocal_planning_bench
	$(BUILD_DIR)/tests/bench/robocal_identification_bench
	$(BUILD_DIR)/tests/bench/robocal_compensation_bench

format:
	find core api server client tests -name '*.h' -o -name '*.cc' | xargs -r clang-format -i

clean:
	rm -rf $(BUILD_DIR)
