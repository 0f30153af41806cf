# The two commands a new user needs (see README):
#   make demo   installs dependencies if missing, builds, runs the demo on the embedded default
#   make test   installs dependencies if missing, builds, runs every test
BUILD_DIR ?= build
BUILD_TYPE ?= Release
JOBS ?= $(shell nproc 2>/dev/null || echo 2)
DEMO_DIR ?= out/demo
# LibTorch's OpenMP threads spin while waiting unless told otherwise; on a shared 2-core machine
# that makes a second busy process 10x slower.
export OMP_WAIT_POLICY ?= PASSIVE

.PHONY: demo test deps configure build clean

demo: build
	./tools/run_demo.sh $(BUILD_DIR) $(DEMO_DIR)

test: build
	cd $(BUILD_DIR) && status=0 && { ctest --output-on-failure -j$(JOBS) || status=$$?; } && \
	  $(CURDIR)/tools/test_skips.sh Testing/Temporary/LastTest.log && exit $$status

deps:
	./tools/install_deps.sh

configure: deps
	cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=$(BUILD_TYPE)

build: configure
	cmake --build $(BUILD_DIR) -j$(JOBS)

clean:
	rm -rf $(BUILD_DIR)
