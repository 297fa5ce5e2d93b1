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
	$(BUILD)/bin/arlight-sim --env $(DEMO_PROBE) --out $(DEMO_OUT)/capture/recording --frames 300 \
	  --gyro-drift 0.5 --seed 1
	$(BUILD)/bin/arlight-capture --recording $(DEMO_OUT)/capture/recording \
	  --out $(DEMO_OUT)/capture/env.exr --json $(DEMO_OUT)/capture/capture.json
	$(BUILD)/bin/arlight-maps diff --reference $(DEMO_OUT)/capture/recording/truth/env.exr \
	  --test $(DEMO_OUT)/capture/env.exr --method auto --size 128 --json $(DEMO_OUT)/capture/diff.json
	$(BUILD)/bin/arlight-sim --env $(DEMO_PROBE) --out $(DEMO_OUT)/ar/recording --frames 90 \
	  --trajectory orbit --marker 7,0.2 --gyro-drift 0.5 --seed 2
	./deploy/demo-daemon.sh $(BUILD) $(DEMO_OUT)/capture/recording $(DEMO_OUT)/daemon \
	  $(DEMO_OUT)/ar/recording data/models/bunny.glb $(DEMO_OUT)/ar/client
	node deploy/web-demo.mjs $(BUILD)/bin $(DEMO_OUT)/web $(DEMO_PROBE)
	@echo
	@echo "Demo results are in $(DEMO_OUT)/:"
	@echo "  auto_s<S>.exr / .png      irradiance (s = 1) and reflection maps (s = 10 ... 1280) of"
	@echo "                            $(DEMO_PROBE), 512x512 angle maps, by the auto method"
	@echo "  contact_sheet.png         all eight maps side by side; input.png is the probe itself"
	@echo "  maps.json                 seconds per map and how auto made each one"
	@echo "  compare/contact_sheet.png every method (rows) for every shininess (columns), 128x128"
	@echo "  compare/compare.json      their times and errors against accurate (thesis eqs. 6.1/6.2)"
	@echo "  capture/recording/        a simulated phone sweeping $(DEMO_PROBE) (300 frames, 0.5 deg/s"
	@echo "                            gyro drift), with its ground truth in truth/"
	@echo "  capture/env.exr / .png    the HDR environment map captured from it; env_coverage.png"
	@echo "  capture/capture.json      coverage, ms per frame, orientation error vs truth, live SH"
	@echo "  capture/diff.json         its irradiance/reflection maps against the truth's"
	@echo "  daemon/replay/            the same recording streamed to arlightd by arlight-replay:"
	@echo "                            replay.json (live SH, coverage, counts), maps/s<S>.exr"
	@echo "  daemon/envmap.png         the daemon's live environment map (admin HTTP), metrics.txt,"
	@echo "                            sessions.json, arlightd.log; daemon/data/ its checkpoint"
	@echo "  ar/recording/              a simulated phone orbiting an ArUco marker in the same room"
	@echo "  ar/client/contact_sheet.png  the bunny on the marker, lit by the captured room"
	@echo "  ar/client/frames/          every composited frame (arlight-client, camera-matched"
	@echo "                            tone mapping); client.json: timings and pose error vs truth"
	@echo "  web/contact_sheet.png     the phone page arlightd serves, in headless Chromium: a simulated"
	@echo "                            phone sweeps the room, the sphere takes on its light, then"
	@echo "                            the page tracks the marker and stands the bunny on it;"
	@echo "                            page.png, page_*.png, web.json the page's own figures"
	@echo "  Connect your phone: README.md, \"Connect your phone\" (arlightd --web 0.0.0.0:8443)"

bench: deps
	@$(MAKE) --no-print-directory build
	$(BUILD)/bin/arlight-bench --benchmark_min_time=1 $(BENCH_ARGS)

clean:
	rm -rf $(BUILD) out
