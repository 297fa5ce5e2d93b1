# arlight — the two commands a new user needs are `make demo` and `make test`.
BUILD ?= build
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?=
DEMO_PROBE ?= data/probes/venice.exr
DEMO_OUT ?= out/demo

.PHONY: all build deps configure test demo bench clean test-sanitize fuzz

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
	  --trajectory orbit --marker 7,0.2 --gyro-drift 0.5 --seed 2 \
	  --object data/models/bunny.glb --object-material 0.7,0.3,80 --reference-every 15
	./deploy/demo-daemon.sh $(BUILD) $(DEMO_OUT)/capture/recording $(DEMO_OUT)/daemon \
	  $(DEMO_OUT)/ar/recording data/models/bunny.glb $(DEMO_OUT)/ar/client $(DEMO_OUT)/compositing \
	  $(DEMO_OUT)/eval
	node deploy/compositing-sheet.mjs $(DEMO_OUT)/eval/contact_sheet.png \
	  "reference (ray traced)=$(DEMO_OUT)/ar/recording/truth/reference" \
	  "maps=$(DEMO_OUT)/eval/maps/frames" "differences seen (maps)=$(DEMO_OUT)/eval/maps/seen" \
	  "sh-9=$(DEMO_OUT)/eval/sh-9/frames" "differences seen (sh-9)=$(DEMO_OUT)/eval/sh-9/seen"
	node deploy/compositing-sheet.mjs $(DEMO_OUT)/compositing/contact_sheet.png \
	  maps=$(DEMO_OUT)/ar/client/frames hemisphere=$(DEMO_OUT)/compositing/hemisphere/frames \
	  "hemisphere + occlusion=$(DEMO_OUT)/compositing/hemisphere-occlusion/frames" \
	  "glass (live refraction)=$(DEMO_OUT)/compositing/glass/frames" \
	  "gold (metallic-roughness, GGX chain)=$(DEMO_OUT)/compositing/gold/frames" \
	  "tiled ball (its glTF materials)=$(DEMO_OUT)/compositing/tiles/frames"
	mkdir -p $(DEMO_OUT)/pbr
	$(BUILD)/bin/arlight-bench-pbr --probe $(DEMO_OUT)/capture/env.exr \
	  --json $(DEMO_OUT)/pbr/spheres.json --grid $(DEMO_OUT)/pbr/spheres.png
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
	@echo "  compositing/contact_sheet.png  the bunny shaded with the maps, with hemisphere shading,"
	@echo "                            with hemisphere shading and occlusion, and as glass showing"
	@echo "                            the camera frame through it, and as gold (glTF metallic-"
	@echo "                            roughness lit by the room's GGX chain), side by side (rows:"
	@echo "                            three frames); compositing/<mode>/ each run's frames and"
	@echo "                            JSON; compositing/gold/ also the room's light files"
	@echo "                            (specular.ktx2, light.json, lighting.gltf); and the"
	@echo "                            textured tiled ball (data/models/tiles.glb) drawn with its"
	@echo "                            own glTF materials"
	@echo "  pbr/spheres.png           metallic-roughness spheres (rows metallic 0, 0.5, 1; roughness"
	@echo "                            0.05 ... 1) rendered lit by the captured room (capture/env.exr);"
	@echo "                            pbr/spheres.json their errors against the full BRDF ray"
	@echo "                            traced over that room"
	@echo "  eval/contact_sheet.png    the bunny ray traced under the true room (the reference,"
	@echo "                            ar/recording/truth/reference/) beside arlight-client's"
	@echo "                            composites at the true pose lit by the maps and by SH-9"
	@echo "                            alone, and where a viewer would see them differ"
	@echo "  eval/table.md             PSNR/SSIM in the object and its shadow, differences seen"
	@echo "                            (arlight-eval), also for the tracked run; <run>.json"
	@echo "  web/contact_sheet.png     the phone page arlightd serves, in headless Chromium: a simulated"
	@echo "                            phone sweeps the room, the sphere takes on its light, then"
	@echo "                            the page tracks the marker and stands the bunny on it;"
	@echo "                            page.png, page_*.png, web.json the page's own figures"
	@echo "  three/spheres.png, bunny.png  /three.html: three.js lighting a sphere grid and the bunny"
	@echo "                            with the room's light (ArlightEstimatedLight watching the"
	@echo "                            phone's session); three.json its status and estimate"
	@echo "  Connect your phone: README.md, \"Connect your phone\" (arlightd --web 0.0.0.0:8443)"

# The hardening builds share a second build folder, compiled by clang with AddressSanitizer and
# UndefinedBehaviorSanitizer, and libFuzzer's coverage in the code that parses the fuzz targets'
# input (tests/fuzz/fuzz.cmake; no browser client, no benchmarks).
SANITIZE_BUILD ?= build-sanitize
FUZZ_SECONDS ?= 60
FUZZ_OUT ?= out/fuzz
# Mesa's GL driver stays loaded for the whole of every test process (preloaded): unloaded at
# exit, the 112 bytes of per-process state it keeps would show up as a leak of an unknown
# module in every GL test (LeakSanitizer cannot name, nor be told to ignore, what is unmapped).
MESA_DRIVER := $(firstword $(wildcard /usr/lib/*/dri/swrast_dri.so))
SANITIZER_ENV = ASAN_OPTIONS=detect_leaks=1:strict_string_checks=1:detect_stack_use_after_return=1:verify_asan_link_order=0 \
  UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  LSAN_OPTIONS=suppressions=$(CURDIR)/tests/sanitize/lsan.supp:print_suppressions=0 \
  LD_PRELOAD=$(MESA_DRIVER)

# -O1 with line tables only: what ASan's reports need (file and line), and less to compile than
# RelWithDebInfo's -O2 -g.
SANITIZE_OPT = -O1 -gline-tables-only -DNDEBUG

$(SANITIZE_BUILD)/build.ninja:
	CC=clang-14 CXX=clang++-14 cmake -S . -B $(SANITIZE_BUILD) -G Ninja \
	  -DCMAKE_BUILD_TYPE=RelWithDebInfo -DARLIGHT_SANITIZE=address,undefined -DARLIGHT_FUZZ=ON \
	  "-DCMAKE_C_FLAGS_RELWITHDEBINFO=$(SANITIZE_OPT)" "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=$(SANITIZE_OPT)" \
	  -DARLIGHT_WEB=OFF -DARLIGHT_BENCH=OFF $(CMAKE_FLAGS)

# The suites of code that parses input or runs concurrently (ctest label `sanitize`, see
# tests/CMakeLists.txt; only what they need is built: target sanitize_suites), built with ASan +
# UBSan: any report fails its test. SANITIZE_TESTS=all builds and runs the whole suite (but the
# browser's) sanitized.
SANITIZE_TESTS ?= sanitize
SANITIZE_SELECT = $(if $(filter all,$(SANITIZE_TESTS)),,-L $(SANITIZE_TESTS))
SANITIZE_TARGET = $(if $(filter all,$(SANITIZE_TESTS)),all,sanitize_suites)
test-sanitize: deps $(SANITIZE_BUILD)/build.ninja
	cmake --build $(SANITIZE_BUILD) -j $(JOBS) --target $(SANITIZE_TARGET)
	$(SANITIZER_ENV) ctest --test-dir $(SANITIZE_BUILD) --output-on-failure -j $(JOBS) $(SANITIZE_SELECT)

# Every fuzz target for FUZZ_SECONDS from its committed corpus; findings and stats in FUZZ_OUT.
fuzz: deps $(SANITIZE_BUILD)/build.ninja
	cmake --build $(SANITIZE_BUILD) -j $(JOBS) --target fuzz_targets
	$(SANITIZER_ENV) ./tests/fuzz/run-fuzzers.sh $(SANITIZE_BUILD)/tests $(FUZZ_SECONDS) $(FUZZ_OUT)

bench: deps
	@$(MAKE) --no-print-directory build
	$(BUILD)/bin/arlight-bench --benchmark_min_time=1 $(BENCH_ARGS)
	$(BUILD)/bin/arlight-bench-fill data/probes/heldout/*.exr --json out/bench/fill/heldout.json
	$(BUILD)/bin/arlight-bench-guided data/probes/heldout/*.exr --json out/bench/guided/heldout.json
	$(BUILD)/bin/arlight-bench-two-phones data/probes/heldout/*.exr --json out/bench/two_phones.json
	$(BUILD)/bin/arlight-bench-colour data/probes/heldout/*.exr --model data/models/bunny.glb \
	  --json out/bench/colour.json
	bench/eval_rooms.sh $(BUILD) out/bench/eval data/probes/venice.exr data/probes/lab.exr \
	  data/probes/park.exr
	bench/load_maps.sh $(BUILD) out/bench/load_maps 1 4 8
	bench/capture_merge.sh $(BUILD) out/bench/capture_merge
	for p in park venice studio; do $(BUILD)/bin/arlight-bench-ggx --probe data/probes/$$p.exr \
	  --json out/bench/ggx_$$p.json; done
	$(BUILD)/bin/arlight-bench-pbr --probe data/probes/park.exr --probe data/probes/venice.exr \
	  --probe data/probes/studio.exr --json out/bench/pbr.json --grid out/bench/pbr-spheres.png
	for p in venice park; do node bench/three_spheres.mjs $(BUILD)/bin out/bench/three_$$p \
	  data/probes/$$p.exr; done
	bench/shaped_links.sh $(BUILD) out/bench/shaped_links

clean:
	rm -rf $(BUILD) $(SANITIZE_BUILD) out
