# Front door: thin wrappers around the CMake presets (the PX4 / Crazyflie convention).
#   make flight     set up, build and fly the default HIL flight (TARGET=avr|cortex-m4: the board's image)
#   make test       set up, build (host and both cross targets) and run every test through ctest
JOBS ?= $(shell nproc 2>/dev/null || echo 2)
SCENARIO ?= sim/scenarios/hover.yaml

.PHONY: all setup configure build test avr cortex-m4 flash debug test-debug fuzz fuzz-short flight clean results

all: build

setup:
	@tools/setup.sh

configure:
	cmake --preset host

build: configure
	cmake --build --preset host -j $(JOBS)

avr:
	cmake --preset avr-apm25
	cmake --build --preset avr-apm25 -j $(JOBS)

cortex-m4:
	cmake --preset cortex-m4
	cmake --build --preset cortex-m4 -j $(JOBS)

test: setup
	$(MAKE) --no-print-directory build
	$(MAKE) --no-print-directory avr
	$(MAKE) --no-print-directory cortex-m4
	ctest --preset host
	$(MAKE) --no-print-directory fuzz-short

# Flashes the APM 2.5 through its stk500v2 bootloader over USB (docs/targets.md): -c wiring pulses DTR
# to reset the board into the bootloader; -D skips the chip erase the bootloader cannot do.
PORT ?= /dev/ttyACM0
FLASH_IMAGE ?= build/avr-apm25/firmware/targets/avr/apm25_board.hex
flash: avr
	avrdude -c wiring -p m2560 -P $(PORT) -b 115200 -D -U flash:w:$(FLASH_IMAGE):i

debug:
	cmake --preset host-debug
	cmake --build --preset host-debug -j $(JOBS)

test-debug: setup debug
	ctest --preset host-debug

# libFuzzer targets: FUZZ_SECONDS per target (make fuzz), or a short run that make test includes.
FUZZ_SECONDS ?= 300
fuzz: setup
	tools/fuzz.sh $(FUZZ_SECONDS)

fuzz-short:
	tools/fuzz.sh 12 1

# The default flight is the closed-loop flight (sim/scenarios/flight.yaml); SCENARIO=... picks another.
# TARGET=avr or TARGET=cortex-m4 builds that image and flies it on its emulated processor instead.
flight: setup
	$(MAKE) --no-print-directory build
	$(if $(TARGET),$(MAKE) --no-print-directory $(filter avr cortex-m4,$(TARGET)))
	tools/flight.sh $(if $(TARGET),--target $(TARGET) )$(if $(filter command line environment,$(origin SCENARIO)),$(SCENARIO),sim/scenarios/flight.yaml)

# Every headline figure flown again by its campaign (sim/campaigns/*.yaml; docs/campaigns.md) on a local
# Dask cluster, the generated sections of docs/results.md and docs/reliability.md rewritten; exits non-zero
# when a campaign's bound is not met. CAMPAIGN_ARGS="--scheduler tcp://HOST:8786" runs on a cluster.
CAMPAIGNS ?= $(sort $(wildcard sim/campaigns/*.yaml))
results: setup
	$(MAKE) --no-print-directory build
	$(MAKE) --no-print-directory avr
	$(MAKE) --no-print-directory cortex-m4
	tools/campaign $(CAMPAIGNS) --update-docs $(CAMPAIGN_ARGS)

clean:
	rm -rf build
