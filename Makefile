# The two commands of the README: `make demo` and `make test`. Both install what is missing
# (scripts/setup, via sudo when not root), configure CMake (Ninja, Release) into build/, and build.
BUILD ?= build
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?=

.PHONY: all setup configure build demo test bench format clean

all: build

setup:
	@bash scripts/setup

$(BUILD)/build.ninja:
	cmake -S . -B $(BUILD) -G Ninja -DCMAKE_BUILD_TYPE=Release $(CMAKE_FLAGS)

configure: setup $(BUILD)/build.ninja

build: configure
	cmake --build $(BUILD) -j $(JOBS)

demo: build
	$(BUILD)/mirage demo --out demo-out

test: build
	cd $(BUILD) && ctest --output-on-failure -j $(JOBS) --timeout 900

bench: build
	$(BUILD)/bench/mirage_microbench

format:
	clang-format -i $$(git ls-files '*.cpp' '*.h' '*.glsl' | grep -v '^shaders/.*\.glsl$$')

clean:
	rm -rf $(BUILD) demo-out
