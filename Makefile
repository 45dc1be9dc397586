# The two commands of the README: `make run` and `make test`.
BUILD      ?= build
BUILD_ASAN ?= build-asan
BUILD_FUZZ ?= build-fuzz
JOBS       ?= $(shell nproc)
OUT        ?= out

.PHONY: all deps build run test test-asan fuzz-smoke bench format clean
all: build

deps:
	@./scripts/install-deps.sh

$(BUILD)/CMakeCache.txt: | deps
	cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release

build: deps $(BUILD)/CMakeCache.txt
	cmake --build $(BUILD) -j $(JOBS)

run: build
	$(BUILD)/apps/rangeseg/rangeseg demo -o $(OUT)

test: build
	ctest --test-dir $(BUILD) --output-on-failure -j $(JOBS)

test-asan: deps
	cmake -S . -B $(BUILD_ASAN) -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g1" \
	  -DRANGESEG_SANITIZE=ON -DRANGESEG_BUILD_BENCH=OFF
	cmake --build $(BUILD_ASAN) -j $(JOBS)
	ctest --test-dir $(BUILD_ASAN) --output-on-failure -j $(JOBS)

fuzz-smoke:
	RANGESEG_WITH_CLANG=1 ./scripts/install-deps.sh
	CC=clang CXX=clang++ cmake -S . -B $(BUILD_FUZZ) -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g1" -DRANGESEG_FUZZ=ON \
	  -DRANGESEG_BUILD_TESTS=OFF -DRANGESEG_BUILD_BENCH=OFF -DRANGESEG_BUILD_APPS=OFF
	cmake --build $(BUILD_FUZZ) -j $(JOBS)
	./scripts/fuzz-smoke.sh $(BUILD_FUZZ)

bench: build
	$(BUILD)/bench/rangeseg_bench

format:
	find include src apps tests bench fuzz -name '*.[ch]pp' | xargs clang-format -i

clean:
	rm -rf $(BUILD) $(BUILD_ASAN) $(BUILD_FUZZ) $(OUT)
