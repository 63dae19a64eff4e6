# activeskin: two commands on a fresh Debian/Ubuntu machine.
#   make demo   installs what is missing, builds, runs the built-in demo, writes ./out
#   make test   installs what is missing, then runs the whole test suite
CARGO ?= cargo
OUT ?= out

.PHONY: all deps build twin-test demo test farm-test blender-test bench lint soak fuzz wheel wheel-vdb blender-addon clean

all: build

deps:
	@bash .ci/deps

# The twin build (src/cli/twin.rs): the same program for x86-64-v3 CPUs (AVX2, FMA),
# 8-15 % faster, the same frames bit for bit, beside the baseline one, which hands over
# to it where the CPU runs it. Its stamp names the baseline binary's build ID, so it is
# built as `cargo $(1)` builds that binary (a test build unifies the dev-dependencies'
# features, another binary). TWIN=0 skips it (x86-64 machines only).
TWIN ?= $(if $(filter x86_64,$(shell uname -m)),1,0)
TWIN_DIR ?= target/x86-64-v3
CPU_RUNS_V3 := $(shell grep -qw avx2 /proc/cpuinfo 2>/dev/null && grep -qw fma /proc/cpuinfo && echo 1)
define build_twin
	RUSTFLAGS="$$RUSTFLAGS -C target-cpu=x86-64-v3" $(CARGO) $(1) --target-dir $(TWIN_DIR)
	cp $(TWIN_DIR)/release/activeskin target/release/activeskin-x86-64-v3.tmp
	mv -f target/release/activeskin-x86-64-v3.tmp target/release/activeskin-x86-64-v3
	readelf -n target/release/activeskin | sed -n 's/^ *Build ID: //p' > target/release/activeskin-x86-64-v3.for.tmp
	mv -f target/release/activeskin-x86-64-v3.for.tmp target/release/activeskin-x86-64-v3.for
endef

build: deps
	$(CARGO) build --release
ifeq ($(TWIN),1)
	$(call build_twin,build --release --bin activeskin)
endif

# The binary the tests run, and its twin (tests/twin.rs compares their files).
twin-test: deps
ifeq ($(TWIN),1)
	$(CARGO) test --release --no-run --test twin
	$(call build_twin,test --release --no-run --test twin)
endif

demo: build
	@mkdir -p $(OUT)
	./target/release/activeskin demo --out $(OUT)
	./target/release/activeskin info $(OUT)/fig7/fig7.0048.vdb
	@echo "demo: in ./$(OUT): fig7/ (six blobs to two spheres), orbit/ (a moving target), splash/ (a drop of particles): VDB, OBJ, EXR, a USD shot, stats"

# The peer race (activeskin bench: OpenVDB's tools side by side), the step alone, and
# the README's and docs/' long examples (console slow blocks).
bench: deps
	$(CARGO) run --release -- bench
	$(CARGO) bench --bench step
	$(CARGO) test --release --test readme -- --ignored

# Tests run optimised: they solve and mesh real grids. Lint first: it is the quick part.
test: deps lint twin-test
	ACTIVESKIN_EXPECT_TWIN=$(if $(filter 1,$(TWIN)),$(CPU_RUNS_V3),0) $(CARGO) test --release
	$(CARGO) test --release --no-default-features --lib --tests
	$(MAKE) farm-test
	$(MAKE) blender-test

# A one-node Slurm cluster started by the test itself (as root; Debian's slurm-wlm and
# munge, installed when missing): a 4-chunk job array against the sequential run.
farm-test: deps
	@if [ "$$(id -u)" -ne 0 ]; then \
		echo "farm-test: skipped, it starts Slurm's daemons as root: sudo make farm-test"; \
	else \
		bash .ci/deps slurm-wlm munge && \
		$(CARGO) test --release --test farm -- --ignored --nocapture; \
	fi

# The Blender add-on in Blender without a window (Debian's Blender and numpy, installed
# when missing, as root); then the zip `make blender-addon` writes installed as an
# extension in Blender 4.5 LTS and 5.0 from pip (bpy, CPython 3.11; ~400 MB each, once).
blender-test: deps
	@if ! command -v blender >/dev/null && [ "$$(id -u)" -ne 0 ]; then \
		echo "blender-test: skipped, Blender is not installed: sudo make blender-test"; \
	else \
		bash .ci/deps blender python3-numpy && \
		$(CARGO) test --release --test python -- --ignored --nocapture; \
	fi

# 10 000 solver steps against ever-changing targets (about a minute).
soak: deps
	$(CARGO) test --release --test soak -- --ignored --nocapture

# cargo fuzz (nightly) of the frame-pattern parser and the particle-file readers,
# FUZZ_SECONDS each; crashes land in fuzz/artifacts.
FUZZ_SECONDS ?= 600
fuzz: deps
	@command -v cargo-fuzz >/dev/null || $(CARGO) install cargo-fuzz
	cd fuzz && $(CARGO) +nightly fuzz run -O frame_pattern -- -max_total_time=$(FUZZ_SECONDS) -max_len=256
	cd fuzz && mkdir -p corpus/particle_files && $(CARGO) +nightly fuzz run -O particle_files corpus/particle_files seeds/particle_files -- -max_total_time=$(FUZZ_SECONDS) -max_len=4096

# The Python package: an abi3 wheel (CPython 3.10+) in target/wheels; then
# pip install target/wheels/activeskin-*.whl
# maturin in a venv the Makefile owns: `pip install --user` put it in ~/.local/bin, off a
# fresh machine's PATH, and Debian's pip refuses system-wide installs.
# (Both folders are variables for tests/python.rs, which builds the wheel with `make wheel`
# in a clean environment.)
MATURIN_VENV ?= target/maturin-venv
MATURIN := $(MATURIN_VENV)/bin/maturin
WHEELS ?= target/wheels

$(MATURIN):
	python3 -m venv --clear $(MATURIN_VENV)
	$(MATURIN_VENV)/bin/python -m pip install --quiet --disable-pip-version-check "maturin>=1.5,<2"

wheel: deps $(MATURIN)
	$(MATURIN) build --release -m python/Cargo.toml -o $(WHEELS)

# The wheel with OpenVDB (VDB files in LevelSetSkin, save_vdb, skin_sequence), linked to
# the system's libopenvdb (not bundled: for machines that have it), in target/wheels-vdb.
wheel-vdb: deps $(MATURIN)
	$(MATURIN) build --release -m python/Cargo.toml --features vdb --auditwheel skip -o target/wheels-vdb

# The add-on as one zip with the wheel inside: Blender 3.x installs it from Preferences >
# Add-ons > Install; 4.2+ as an extension (the manifest lists the wheel). In ADDON_DIR
# (a variable for tests/python.rs, which makes it in a clean environment).
ADDON_DIR ?= target/blender
blender-addon: wheel
	rm -rf $(ADDON_DIR)/activeskin_blender && mkdir -p $(ADDON_DIR)/activeskin_blender/wheels
	cp blender/activeskin_blender/__init__.py $(ADDON_DIR)/activeskin_blender/
	cp $(WHEELS)/activeskin-*.whl $(ADDON_DIR)/activeskin_blender/wheels/
	sed "s|^wheels = \[\]|wheels = [$$(cd $(ADDON_DIR)/activeskin_blender && ls wheels/*.whl | sed 's|.*|\"./&\"|' | paste -sd,)]|" \
		blender/activeskin_blender/blender_manifest.toml > $(ADDON_DIR)/activeskin_blender/blender_manifest.toml
	cd $(ADDON_DIR) && rm -f activeskin_blender.zip && python3 -m zipfile -c activeskin_blender.zip activeskin_blender
	@echo "$(ADDON_DIR)/activeskin_blender.zip: Blender > Preferences > Add-ons > Install (3.x), Get Extensions > Install from Disk (4.2+)"

lint:
	$(CARGO) fmt --all -- --check
	$(CARGO) clippy --release --all-targets -- -D warnings
	$(CARGO) clippy --release --no-default-features --lib --tests -- -D warnings
	$(CARGO) clippy --release -p activeskin-python --all-targets -- -D warnings
	$(CARGO) clippy --release -p activeskin-python --features vdb --all-targets -- -D warnings

clean:
	$(CARGO) clean
	rm -rf $(OUT)
