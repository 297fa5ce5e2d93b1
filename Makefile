# arlight — the two commands a new user needs are `make demo` and `make test`.
BUILD ?= build
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?=
DEMO_PROBE ?= data/probes/venice.exr
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
	$(BUILD)/bin/arlight-maps compute --input $(DEMO_PROBE) --method auto --size 512 --out $(DEMO_OUT)
	$(BUILD)/bin/arlight-maps compare --input $(DEMO_PROBE) --size 128 --out $(DEMO_OUT)/compare
	@echo
	@echo "Demo results are in $(DEMO_OUT)/:"
	@echo "  auto_s<S>.exr / .png      irradiance (s = 1) and reflection maps (s = 10 ... 1280) of"
	@echo "                            $(DEMO_PROBE), 512x512 angle maps, by the auto method"
	@echo "  contact_sheet.png         all eight maps side by side; input.png is the probe itself"
	@echo "  maps.json                 seconds per map and how auto made each one"
	@echo "  compare/contact_sheet.png every method (rows) for every shininess (columns), 128x128"
	@echo "  compare/compare.json      their times and errors against accurate (thesis eqs. 6.1/6.2)"

bench: deps
	@$(MAKE) --no-print-directory build
	$(BUILD)/bin/arlight-bench --benchmark_min_time=1 $(BENCH_ARGS)

clean:
	rm -rf $(BUILD) out
