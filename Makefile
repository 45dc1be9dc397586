# The two commands of the README: `make run` and `make test`.
BUILD      ?= build
BUILD_ASAN ?= build-asan
BUILD_COMPARE ?= build-compare
JOBS       ?= $(shell nproc)
OUT        ?= out

.PHONY: all deps build run test asan-build test-asan fuzz-smoke lint bench compare format clean
all: build

deps:
	@./scripts/install-deps.sh

# The Python module is built for Debian's interpreter, for which `deps` installs NumPy (another
# python3 first on PATH, e.g. pyenv's, may lack it); PYTHON=... picks another.
PYTHON     ?= $(firstword $(wildcard /usr/bin/python3) python3)

$(BUILD)/CMakeCache.txt: | deps
	cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release -DPYTHON_EXECUTABLE=$(PYTHON)

build: deps $(BUILD)/CMakeCache.txt
	cmake --build $(BUILD) -j $(JOBS)

run: build
	$(BUILD)/apps/rangeseg/rangeseg demo -o $(OUT)

test: build
	ctest --test-dir $(BUILD) --output-on-failure -j $(JOBS)

# Sanitizer build with clang: the test suite under ASan + UBSan, and the libFuzzer targets.
asan-build:
	RANGESEG_WITH_CLANG=1 ./scripts/install-deps.sh
	CC=clang CXX=clang++ cmake -S . -B $(BUILD_ASAN) -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g1" \
	  -DRANGESEG_SANITIZE=ON -DRANGESEG_FUZZ=ON -DRANGESEG_BUILD_BENCH=OFF
	cmake --build $(BUILD_ASAN) -j $(JOBS)

test-asan: asan-build
	ctest --test-dir $(BUILD_ASAN) --output-on-failure -j $(JOBS)

fuzz-smoke: asan-build
	./scripts/fuzz-smoke.sh $(BUILD_ASAN)

# clang-tidy (checks in .clang-tidy, every finding an error) over LINT_DIRS (default: the library,
# CLI, tests, benchmarks, examples and Python module; CI lints the library, CLI, examples and
# Python module only, and with
# LINT_BASE only the units that may have changed since that commit, to stay within its time
# budget on 2 cores; see scripts/lint.sh), and clang-format (.clang-format) over every source file.
LINT_DIRS  ?= src|apps|tests|bench|examples|python
LINT_BASE  ?=
lint: build
	RANGESEG_WITH_LINT=1 ./scripts/install-deps.sh
	JOBS=$(JOBS) ./scripts/lint.sh $(BUILD) '$(LINT_DIRS)' '$(LINT_BASE)'
	find include src apps tests bench fuzz examples python -name '*.[ch]pp' | xargs clang-format --dry-run --Werror

bench: build
	$(BUILD)/bench/rangeseg_bench

# rangeseg against PCL 1.13 and Open3D 0.16 (installs libpcl-dev and libopen3d-dev, ~520 Debian
# packages): time per stage on a Kinect frame and SegComp scores of each on the synthetic scenes,
# OSD and ABW; tables on stdout, files in $(OUT)/compare. Not part of `make test`: nothing of
# rangeseg needs either library.
compare: build
	RANGESEG_WITH_COMPARE=1 ./scripts/install-deps.sh
	cmake -S . -B $(BUILD_COMPARE) -DCMAKE_BUILD_TYPE=Release -DRANGESEG_COMPARE_PCL=ON \
	  -DRANGESEG_COMPARE_OPEN3D=ON -DRANGESEG_BUILD_APPS=OFF -DRANGESEG_BUILD_TESTS=OFF \
	  -DRANGESEG_BUILD_EXAMPLES=OFF -DRANGESEG_BUILD_BENCH=OFF
	cmake --build $(BUILD_COMPARE) -j $(JOBS) --target rangeseg_bench_pcl rangeseg_pcl_segment \
	  rangeseg_bench_open3d rangeseg_open3d_segment
	./scripts/compare.sh $(BUILD_COMPARE) $(BUILD) $(OUT)/compare

format:
	find include src apps tests bench fuzz examples python -name '*.[ch]pp' | xargs clang-format -i

clean:
	rm -rf $(BUILD) $(BUILD_ASAN) $(BUILD_COMPARE) $(OUT)
