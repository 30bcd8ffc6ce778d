# CDFF: two commands on a fresh Debian 12 machine, as root:
#   make demo   installs the dependencies, builds, and runs the main job
#   make test   installs the dependencies, builds, and runs every test
# Also: make bench (benchmarks), make templates (the detection's LINEMOD templates), make fuzz
# (the MCAP reader fuzzer), make format.
# Sanitizers: make test SANITIZE=address,undefined   (or thread)

SANITIZE ?=
BUILD_TYPE ?= $(if $(SANITIZE),Debug,RelWithDebInfo)
BUILD_DIR ?= build$(if $(SANITIZE),-$(subst $(comma),-,$(SANITIZE)))
JOBS ?= $(shell nproc)
comma := ,

CMAKE_FLAGS = -G Ninja -DCMAKE_BUILD_TYPE=$(BUILD_TYPE) -DCDFF_SANITIZE=$(SANITIZE)

.PHONY: all deps configure build test demo bench templates stereo-templates tof-templates fuzz \
  format clean

all: build

deps:
	@bash scripts/install-deps.sh

configure: deps
	@cmake -S . -B $(BUILD_DIR) $(CMAKE_FLAGS) > $(BUILD_DIR).configure.log 2>&1 || \
	  { cat $(BUILD_DIR).configure.log; exit 1; }

build: configure
	@cmake --build $(BUILD_DIR) -j $(JOBS)

test: build
	@cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS) --timeout 600

# The rendezvous from 2 km to capture, the LIDAR tracking chain on the simulated mid-range
# approach, visual tracking on the close-range approach, and detection then tracking with no
# ground truth (scripts/demo.sh: the detection's templates first, once); the foundation DFNs' demo stays available as `cdff demo --out DIR`.
demo: build stereo-templates
	@bash scripts/demo.sh $(BUILD_DIR) out/demo

bench: build templates
	@cmake --build $(BUILD_DIR) --target benchmarks -j $(JOBS)
	@bash scripts/run-benchmarks.sh $(BUILD_DIR)

# The LINEMOD templates of the detection graphs, for the procedural target (data/models/target.ply)
# with the default view sphere and ranges (docs/detection.md), each trained once:
# dfpcs/detection.yaml's (detect.template_file) for the rectified left camera of the simulator's
# Prosilica pair, about 10 minutes on 2 cores; dfpcs/detection_tof.yaml's for its ToF camera.
TEMPLATES = $(BUILD_DIR)/templates/target_stereo.yml.gz
TOF_TEMPLATES = $(BUILD_DIR)/templates/target_tof.yml.gz
templates: stereo-templates tof-templates
stereo-templates: build
	@mkdir -p $(dir $(TEMPLATES))
	@test -f $(TEMPLATES) || $(BUILD_DIR)/apps/cdff train mid_range_approach \
	  --rectified-with camera_right --check 0 -o $(TEMPLATES)
tof-templates: build
	@mkdir -p $(dir $(TOF_TEMPLATES))
	@test -f $(TOF_TEMPLATES) || $(BUILD_DIR)/apps/cdff train mid_range_approach --sensor tof \
	  --check 0 -o $(TOF_TEMPLATES)

fuzz:
	@bash fuzz/run.sh

format:
	@git ls-files '*.cpp' '*.hpp' | xargs clang-format -i

clean:
	rm -rf build build-* build*.configure.log
