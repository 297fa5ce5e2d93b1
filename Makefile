# arlight — the two commands a new user needs are `make demo` and `make test`.
BUILD ?= build
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?=
DEMO_PROBE ?= data/probes/venice.exr
DEMO_ORDER ?= 35
DEMO_OUT ?= out/demo

.PHONY: all build deps configure test demo bench clean

all: build

deps:
	@./deploy/install-deps.sh

$(BUILD)/build.ninja:
	cmake -S . -B $(BUILD) -G Ninja -DCMAKE_BUILD_TYPE=Release $(CMAKE_FLAGS)

configure: $(BUILD)/build.ninja

build: configure
	cmake --build $(BUILD) -j $(JOBS)

test: deps
	@$(MAKE) --no-print-directory build
	ctest --test-dir $(BUILD) --output-on-failure -j $(JOBS)

demo: deps
	@$(MAKE) --no-print-directory build
	$(BUILD)/bin/arlight-maps sh --input $(DEMO_PROBE) --order $(DEMO_ORDER) --size 512 --out $(DEMO_OUT)
	@echo
	@echo "Demo results are in $(DEMO_OUT)/:"
	@echo "  input.png           the probe resampled to a 512x512 angle map"
	@echo "  reconstruction.png  the same map rebuilt from $(DEMO_ORDER)^2 SH coefficients"
	@echo "  reconstruction.exr  the reconstruction (half-float EXR, SH coefficients in its metadata)"
	@echo "  sh.json             coefficients, timings and the RMS error"

bench: deps
	@$(MAKE) --no-print-directory build
	$(BUILD)/bin/arlight-bench --benchmark_min_time=1 $(BENCH_ARGS)

clean:
	rm -rf $(BUILD) out
