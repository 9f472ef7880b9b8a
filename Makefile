# facesynth developer commands. `make demo` and `make test` work on a fresh clone: they create
# .venv and install facesynth with every extra but ros2 (.[all,test]) first.
VENV ?= .venv
PYTHON ?= python3
BIN := $(VENV)/bin

.PHONY: system-packages-test demo test test-browser lint bench bench-drivers install clean firmware-test test-deploy \
	test-containers test-netns test-board test-faults test-fuzz test-arm64 test-ros2

$(BIN)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e '.[all,test]'
	touch $@

install: $(BIN)/.installed

system-packages-test:
	@$(SYSTEM_PACKAGES) test browser

## The bundled performer video through S -> P -> F -> T -> C; servo commands in facesynth-commands.jsonl,
## then the side-by-side video to watch (performer | virtual face | paper16's servos) in facesynth-demo.mp4.
demo: $(BIN)/.installed
	$(BIN)/facesynth run --render facesynth-demo.mp4

## The documentation site: docs/ and mkdocs.yml built into site/ by `mkdocs build --strict` (a
## broken link or anchor, or a page left out of the nav, fails it); the docs extra installed
## into the venv first when it is missing. Open site/index.html.
.PHONY: docs
docs: $(BIN)/.installed
	@$(BIN)/python -c 'import mkdocs, material' 2>/dev/null || $(BIN)/python -m pip install -q -e '.[docs]'
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict

## Each test group's Debian packages (tools/system-packages.txt): installed with apt as root,
## else one line naming them. Every target that runs a group asks for its own first.
SYSTEM_PACKAGES := bash tools/system-packages.sh

## The Debian packages the tests need (installed as root), then lint, type-check, schema
## freshness, and the whole test suite (the browser group last). TEST_WORKERS=2 runs the suite
## in two processes (pytest-xdist, a test file to each): most tests wait on real processes,
## routers and emulators, so two workers take about half the time of one (7.5 min against
## 14-15); but a test then has a busier neighbour, and each few runs that way have found another
## emulator or timing test that is not yet sure to pass, so the default (0) is this one process,
## as CI runs it.
TEST_WORKERS ?= 0
test: system-packages-test $(BIN)/.installed lint
	$(BIN)/python -m pytest -q -n $(TEST_WORKERS) --dist loadfile -m "not browser and not containers and not netns and not board and not faults and not fuzz and not arm64 and not ros2"
	$(BIN)/python -m pytest -q -m browser tests/browser

## Faults: each process and the router killed and restarted mid-stream, a flood on every key,
## oversized messages; the servos' speed limits checked on the record file.
test-faults: $(BIN)/.installed
	@$(SYSTEM_PACKAGES) faults
	$(BIN)/python -m pytest -q -s -m faults tests/faults

## The soak (not in CI): the router and the five stages as processes on loopback, the bundled
## video looped through the tracker, for HOURS hours (fractions too: HOURS=0.1), with a fault every
## minute in turn (kill -9 of a stage or the router, a 3 s stall of points, a flood, oversized
## messages). Prints RSS steps and slopes per process, the largest servo step against its limit,
## stale commands and the longest gaps; the report in runs/soak-<date>.json, logs and the record
## beside it. SOAK_ARGS adds options (`python -m tools.soak --help`: --interval, --kinds, --kill).
.PHONY: soak
HOURS ?= 2
soak: $(BIN)/.installed
	$(BIN)/python -m tools.soak --hours $(HOURS) $(SOAK_ARGS)

## Fuzz: 10,000 hypothesis cases for every decoder, loader and protocol parser, in two shards
## of about equal time run side by side (one per core); each prints its own tally, then the other's.
## A test past its timeout ends its shard with every thread's stack (pytest-timeout's thread
## method): hypothesis would run a hanging case again to report it, past a signal's one alarm.
## Shard A's files: 50 % of the suite's CPU time in a 1,000-case run (session 38, 2026-11-27:
## 69.0 s against 69.0 s, per test in the report; the old split gave A 44 %, 61 s against 77 s).
FUZZ_SHARD_A := tests/fuzz/test_fuzz_codec.py tests/fuzz/test_fuzz_loaders.py \
	tests/fuzz/test_fuzz_serial_protocols.py tests/fuzz/test_fuzz_dynamixel.py \
	tests/fuzz/test_fuzz_learned_profiles.py tests/fuzz/test_fuzz_firmware_parser.py
test-fuzz: $(BIN)/.installed
	@$(SYSTEM_PACKAGES) fuzz
	@mkdir -p build; \
	$(BIN)/python -m pytest -q -s -p no:cacheprovider --timeout-method=thread -m fuzz $(FUZZ_SHARD_A) >build/fuzz-a.log 2>&1 & a=$$!; \
	$(BIN)/python -m pytest -q -s -p no:cacheprovider --timeout-method=thread -m fuzz tests/fuzz \
		$(addprefix --ignore=,$(FUZZ_SHARD_A)) >build/fuzz-b.log 2>&1 & b=$$!; \
	ra=0; wait $$a || ra=$$?; rb=0; wait $$b || rb=$$?; \
	cat build/fuzz-a.log build/fuzz-b.log; \
	echo "fuzz shards: exit $$ra and $$rb"; test $$ra -eq 0 && test $$rb -eq 0

## The live face page in a real headless Chromium (Debian's chromium and chromium-driver).
test-browser: $(BIN)/.installed
	@$(SYSTEM_PACKAGES) browser
	$(BIN)/python -m pytest -q -m browser tests/browser

## The deployment groups (root; .ci/run installs what they need): docker-compose on Podman,
## services on separate hosts in network namespaces, the servo-board install.
test-deploy: test-board test-netns test-containers

test-containers: $(BIN)/.installed
	@$(SYSTEM_PACKAGES) containers
	$(BIN)/python -m pytest -q -s -m containers tests/containers

test-netns: $(BIN)/.installed
	@$(SYSTEM_PACKAGES) netns
	$(BIN)/python -m pytest -q -s -m netns tests/netns

test-board: $(BIN)/.installed
	@$(SYSTEM_PACKAGES) board
	$(BIN)/python -m pytest -q -s -m board tests/board

## The board side on arm64 (a Raspberry Pi) under qemu-user emulation (root; qemu-user-static with
## binfmt_misc, which .ci/run installs and mounts): the arm64 board image runs the board graph fed
## from this machine, a plain `pip install .` in an arm64 venv, the tracker on a few frames.
test-arm64: $(BIN)/.installed
	@$(SYSTEM_PACKAGES) arm64
	$(BIN)/python -m pytest -q -s -m arm64 tests/arm64

## ROS 2 (root): installs the [ros2] extra (rclpy, Fast DDS, ~250 MB), then real rclpy nodes in
## other processes against facesynth, in a network namespace with only loopback (DDS discovery
## never leaves the machine; each test also sets ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and a
## ROS_DOMAIN_ID of its own).
## ROS2_PIP: how the [ros2] extra is installed first (.ci/run installs it up front and sets it
## empty: a reinstall of the editable package mid-run would race the other lane's processes).
ROS2_PIP ?= $(BIN)/python -m pip install -q -e '.[ros2]'
test-ros2: $(BIN)/.installed
	@$(SYSTEM_PACKAGES) ros2
	$(ROS2_PIP)
	unshare -n sh -c 'ip link set lo up && exec $(BIN)/python -m pytest -q -s -m ros2 tests/ros2'

lint: $(BIN)/.installed
	$(BIN)/ruff check .
	$(BIN)/mypy
	$(BIN)/lint-imports --no-cache
	$(BIN)/python -m facesynth.schemas.export --check
	$(BIN)/python -m facesynth.app.graph_schema --check

## The servo firmware: host unit tests, Uno build with size report, simavr harness, tests/firmware.
firmware-test: $(BIN)/.installed
	@$(SYSTEM_PACKAGES) test
	$(MAKE) -C firmware host-test build emulator
	$(BIN)/python -m pytest -q tests/firmware

bench: $(BIN)/.installed
	$(BIN)/facesynth bench chain
	$(BIN)/facesynth bench tracker
	$(BIN)/facesynth bench drivers

## Servo drivers: bytes and wire time of one pose per driver, then command -> pulse latency
## through the arduino driver on the emulated Uno (emulated time; needs the firmware toolchain).
bench-drivers: $(BIN)/.installed
	$(BIN)/facesynth bench drivers
	$(BIN)/python -m pytest -q -s tests/control/test_arduino_driver.py -k latency
	$(BIN)/python -m pytest -q -s tests/firmware/test_firmware_emulated.py -k latency

clean:
	rm -rf $(VENV) .mypy_cache .ruff_cache .pytest_cache facesynth-commands.jsonl facesynth-demo.mp4 firmware/build
